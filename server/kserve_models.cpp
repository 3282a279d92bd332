#include "server/kserve_models.h"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace glint {
namespace {

namespace fs = std::filesystem;
using google::protobuf::util::JsonParseOptions;
using google::protobuf::util::JsonStringToMessage;
using google::protobuf::util::MessageToJsonString;

Status ReadText(const std::string &path, std::string *text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::InvalidArgument(path + ": cannot open the file");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) return Status::InvalidArgument(path + ": cannot read the file");
  *text = s.str();
  return Status::Ok();
}

// Strict proto3 JSON parse: a misspelt key is an error, never a silently defaulted field.
Status ParseStrict(const std::string &json, google::protobuf::Message *message,
                   const std::string &what) {
  JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = JsonStringToMessage(json, message, options);
  if (!status.ok()) {
    return Status::InvalidArgument(what + ": not a valid " + message->GetTypeName() +
                                   " in proto3 JSON form: " + std::string(status.message()));
  }
  return Status::Ok();
}

// Model names travel in URLs of the protocol's HTTP form and in metric labels: keep them plain.
bool ValidName(const std::string &name) {
  if (name.empty() || name.size() > 128) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

}  // namespace

Status ReadPresetFile(const std::string &path, glint::v1::EvaluateRequest *settings) {
  std::string json;
  Status s = ReadText(path, &json);
  if (!s.ok()) return s;
  // Split off the "lights" key through a Struct, then parse both halves strictly. Numbers
  // pass through a double, which holds every JSON number the float fields could take exactly
  // as a direct parse would read it (both parse to double, then round to float).
  google::protobuf::Struct root;
  s = ParseStrict(json, &root, path);
  if (!s.ok()) return s;
  glint::v1::LightList lights;
  auto it = root.fields().find("lights");
  if (it != root.fields().end()) {
    google::protobuf::Struct light_list;
    (*light_list.mutable_fields())["lights"] = it->second;
    std::string lights_json;
    MessageToJsonString(light_list, &lights_json);
    s = ParseStrict(lights_json, &lights, path + " (\"lights\")");
    if (!s.ok()) return s;
    root.mutable_fields()->erase("lights");
  }
  std::string material_json;
  MessageToJsonString(root, &material_json);
  s = ParseStrict(material_json, settings->mutable_material(), path);
  if (!s.ok()) return s;
  for (const auto &light : lights.lights()) *settings->add_lights() = light;
  return Status::Ok();
}

Status LoadModelFlag(const std::string &flag, KServeModel *model) {
  const size_t eq = flag.find('=');
  if (eq == std::string::npos) {
    return Status::InvalidArgument("--model " + flag +
                                   ": expected NAME=MATERIAL.json[,LIGHTS.json]");
  }
  model->name = flag.substr(0, eq);
  const std::string files = flag.substr(eq + 1);
  const size_t comma = files.find(',');
  const std::string material = files.substr(0, comma);
  const std::string lights = comma == std::string::npos ? "" : files.substr(comma + 1);
  if (material.empty() || (comma != std::string::npos && lights.empty())) {
    return Status::InvalidArgument("--model " + flag +
                                   ": expected NAME=MATERIAL.json[,LIGHTS.json]");
  }
  model->source = lights.empty() ? material : material + "," + lights;
  Status s = ReadPresetFile(material, &model->settings);
  if (!s.ok() || lights.empty()) return s;
  if (model->settings.lights_size() > 0) {
    return Status::InvalidArgument("--model " + flag + ": " + material +
                                   " has its own \"lights\"; give LIGHTS.json only with a "
                                   "material file without them");
  }
  std::string json;
  s = ReadText(lights, &json);
  glint::v1::LightList list;
  if (s.ok()) s = ParseStrict(json, &list, lights);
  if (!s.ok()) return s;
  for (const auto &light : list.lights()) *model->settings.add_lights() = light;
  return Status::Ok();
}

Status LoadModelDir(const std::string &dir, std::vector<KServeModel> *models) {
  std::error_code ec;
  fs::directory_iterator it(dir, ec);
  if (ec) return Status::InvalidArgument("--model-dir " + dir + ": " + ec.message());
  std::vector<fs::path> files;
  for (const auto &entry : it) {
    if (entry.is_regular_file() && entry.path().extension() == ".json")
      files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  for (const auto &path : files) {
    KServeModel model;
    model.name = path.stem().string();
    model.source = path.string();
    Status s = ReadPresetFile(path.string(), &model.settings);
    if (!s.ok()) return s;
    models->push_back(std::move(model));
  }
  return Status::Ok();
}

Status LoadKServeModels(const std::vector<std::string> &model_flags,
                        const std::vector<std::string> &model_dirs, const ValidationLimits &limits,
                        std::vector<KServeModel> *models) {
  for (const auto &flag : model_flags) {
    KServeModel model;
    Status s = LoadModelFlag(flag, &model);
    if (!s.ok()) return s;
    models->push_back(std::move(model));
  }
  for (const auto &dir : model_dirs) {
    Status s = LoadModelDir(dir, models);
    if (!s.ok()) return s;
  }
  std::set<std::string> names;
  for (const auto &model : *models) {
    if (!ValidName(model.name)) {
      return Status::InvalidArgument("model name '" + model.name + "' (" + model.source +
                                     "): expected 1 to 128 characters from A-Z a-z 0-9 _ - .");
    }
    if (!names.insert(model.name).second) {
      return Status::InvalidArgument("model name '" + model.name + "' (" + model.source +
                                     ") is registered twice");
    }
    Status s = ValidateSettings(model.settings, limits);
    if (!s.ok()) {
      return Status::InvalidArgument("model '" + model.name + "' (" + model.source +
                                     "): " + s.message());
    }
  }
  return Status::Ok();
}

}  // namespace glint
