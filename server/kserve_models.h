// The models glintd serves over the Open Inference Protocol (server/kserve_service.h): named
// material presets, i.e. a glint.v1 material plus lights that ModelInfer's query tensors are
// evaluated against. Registered at start-up with
//   glintd --model NAME=MATERIAL.json[,LIGHTS.json]   (repeatable)
//   glintd --model-dir DIR                            (every DIR/NAME.json)
// A preset file is a glint.v1.Material in proto3 JSON that may carry one more key, "lights",
// holding a glint.v1.LightList's "lights" array; LIGHTS.json is a LightList file (the form
// `glint eval --lights` reads). Presets are validated like a glint.v1 request's settings at
// start-up, so a bad file stops glintd with a message naming it.
#pragma once

#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/status.h"
#include "server/validation.h"

namespace glint {

struct KServeModel {
  std::string name;
  std::string source;                   // the file(s) it came from, for messages
  glint::v1::EvaluateRequest settings;  // material and lights; no queries, default options
};

// Reads a preset file (material JSON with an optional "lights" array) into settings.
Status ReadPresetFile(const std::string &path, glint::v1::EvaluateRequest *settings);

// Parses one --model value, NAME=MATERIAL.json[,LIGHTS.json]. A LIGHTS.json next to a preset
// that has its own "lights" is refused (which lights would be meant is unclear).
Status LoadModelFlag(const std::string &flag, KServeModel *model);

// Every regular file DIR/NAME.json, sorted by NAME; other files are ignored.
Status LoadModelDir(const std::string &dir, std::vector<KServeModel> *models);

// Loads every --model and --model-dir, refuses duplicate or malformed names, and validates
// each preset with ValidateSettings under `limits`.
Status LoadKServeModels(const std::vector<std::string> &model_flags,
                        const std::vector<std::string> &model_dirs, const ValidationLimits &limits,
                        std::vector<KServeModel> *models);

}  // namespace glint
