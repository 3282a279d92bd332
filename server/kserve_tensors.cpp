#include "server/kserve_tensors.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>
#include <map>
#include <set>

namespace glint {
namespace {

// raw_input_contents / raw_output_contents are little-endian by the protocol's definition;
// they are copied as they are, which is right only on a little-endian host (x86-64, arm64).
static_assert(std::endian::native == std::endian::little,
              "kserve_tensors copies raw FP32 tensor bytes as they are: little-endian hosts only");

// Triton's clients set these request parameters for their own features (request priority,
// timeouts, sequence batching); they mean nothing to a stateless BRDF evaluation.
const std::set<std::string> kIgnoredParameters = {"priority", "timeout", "sequence_id",
                                                  "sequence_start", "sequence_end"};

std::string ShapeText(const google::protobuf::RepeatedField<int64_t> &shape) {
  std::string s = "[";
  for (int i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + "]";
}

std::string InputNames(const std::vector<KServeInput> &inputs) {
  std::string s;
  for (size_t i = 0; i < inputs.size(); ++i) s += (i ? ", " : "") + std::string(inputs[i].name);
  return s;
}

// The name of the first typed-contents field other than fp32_contents that holds data.
const char *NonFp32Contents(const inference::InferTensorContents &c) {
  if (!c.bool_contents().empty()) return "bool_contents";
  if (!c.int_contents().empty()) return "int_contents";
  if (!c.int64_contents().empty()) return "int64_contents";
  if (!c.uint_contents().empty()) return "uint_contents";
  if (!c.uint64_contents().empty()) return "uint64_contents";
  if (!c.fp64_contents().empty()) return "fp64_contents";
  if (!c.bytes_contents().empty()) return "bytes_contents";
  return nullptr;
}

bool HasContents(const inference::ModelInferRequest::InferInputTensor &t) {
  return t.has_contents() &&
         (!t.contents().fp32_contents().empty() || NonFp32Contents(t.contents()) != nullptr);
}

google::protobuf::RepeatedField<float> *Field(glint::v1::QueryBatch *q, const std::string &name) {
  if (name == "wo") return q->mutable_wo();
  if (name == "wi") return q->mutable_wi();
  if (name == "uv") return q->mutable_uv();
  if (name == "footprint") return q->mutable_footprint();
  if (name == "position") return q->mutable_position();
  if (name == "normal") return q->mutable_normal();
  if (name == "tangent") return q->mutable_tangent();
  return nullptr;
}

}  // namespace

std::vector<KServeInput> KServeInputs(bool has_lights) {
  std::vector<KServeInput> inputs = {{"wo", 3, true}};
  if (!has_lights) inputs.push_back({"wi", 3, true});
  for (const KServeInput &in : {KServeInput{"uv", 2, false}, KServeInput{"footprint", 4, false},
                                KServeInput{"position", 3, false}, KServeInput{"normal", 3, false},
                                KServeInput{"tangent", 3, false}})
    inputs.push_back(in);
  return inputs;
}

namespace {

// Raw contents come one per input, in the order of inputs, or not at all (KServe v2).
Status CheckRawContentsCount(const inference::ModelInferRequest &request) {
  if (request.raw_input_contents_size() > 0 &&
      request.raw_input_contents_size() != request.inputs_size()) {
    return Status::InvalidArgument(
        "raw_input_contents: " + std::to_string(request.raw_input_contents_size()) +
        " entries for " + std::to_string(request.inputs_size()) +
        " inputs; expected one per input, in the order of inputs");
  }
  return Status::Ok();
}

}  // namespace

Status DecodeInferInputs(const inference::ModelInferRequest &request, bool has_lights,
                         glint::v1::QueryBatch *queries) {
  const std::vector<KServeInput> accepted = KServeInputs(has_lights);
  const bool raw = request.raw_input_contents_size() > 0;
  // The row count and wo itself (present, FP32 [N, 3], its data filling the shape): checked once,
  // by the function admission calls first, so wo has one message per problem (the decoder had
  // its own wo checks, worded differently: "N >= 1" here, "1 <= N < 2^32" there).
  uint64_t wo_rows = 0;
  if (Status s = InferQueryCount(request, &wo_rows); !s.ok()) return s;
  const int64_t rows = int64_t(wo_rows);
  // Check names before reading any data.
  std::map<std::string, int> index;  // input name -> position in request.inputs
  for (int i = 0; i < request.inputs_size(); ++i) {
    const std::string &name = request.inputs(i).name();
    const auto known = std::find_if(accepted.begin(), accepted.end(),
                                    [&](const KServeInput &in) { return name == in.name; });
    if (known == accepted.end()) {
      return Status::InvalidArgument(
          "input '" + name + "': unknown; this model takes " + InputNames(accepted) +
          (name == "wi" ? " (it has lights, and a BRDF probe batch with wi must have none)" : ""));
    }
    if (!index.emplace(name, i).second) {
      return Status::InvalidArgument("input '" + name + "': given twice");
    }
  }
  for (const KServeInput &in : accepted) {
    if (in.required && !index.count(in.name)) {
      return Status::InvalidArgument(
          std::string("input '") + in.name + "': missing; this model requires it (FP32 [N, " +
          std::to_string(in.width) + "]" +
          (std::string(in.name) == "wi" ? ", BRDF probes: the model has no lights)" : ")"));
    }
  }

  for (const KServeInput &in : accepted) {
    const auto found = index.find(in.name);
    if (found == index.end()) continue;
    const auto &tensor = request.inputs(found->second);
    const std::string what = std::string("input '") + in.name + "'";
    if (tensor.datatype() != "FP32") {
      return Status::InvalidArgument(what + ": datatype '" + tensor.datatype() +
                                     "'; expected FP32");
    }
    const auto &shape = tensor.shape();
    if (shape.size() != 2 || shape[0] != rows || shape[1] != in.width) {
      return Status::InvalidArgument(what + ": shape " + ShapeText(shape) + "; expected [" +
                                     std::to_string(rows) + ", " + std::to_string(in.width) +
                                     "] (one row per query, as many rows as wo)");
    }
    const uint64_t elements = uint64_t(rows) * uint64_t(in.width);
    google::protobuf::RepeatedField<float> *field = Field(queries, in.name);
    if (raw) {
      if (HasContents(tensor)) {
        return Status::InvalidArgument(what +
                                       ": has contents although the request uses "
                                       "raw_input_contents; give every input's data one way");
      }
      const std::string &bytes = request.raw_input_contents(found->second);
      if (bytes.size() != elements * sizeof(float)) {
        return Status::InvalidArgument(
            what + ": raw_input_contents holds " + std::to_string(bytes.size()) + " bytes; shape " +
            ShapeText(shape) + " FP32 needs " + std::to_string(elements * sizeof(float)));
      }
      field->Resize(int(elements), 0.0f);
      std::memcpy(field->mutable_data(), bytes.data(), bytes.size());
    } else {
      if (const char *other = NonFp32Contents(tensor.contents())) {
        return Status::InvalidArgument(what + ": data in contents." + other +
                                       "; expected contents.fp32_contents (datatype FP32)");
      }
      const auto &values = tensor.contents().fp32_contents();
      if (uint64_t(values.size()) != elements) {
        return Status::InvalidArgument(what + ": contents.fp32_contents holds " +
                                       std::to_string(values.size()) + " values; shape " +
                                       ShapeText(shape) + " needs " + std::to_string(elements));
      }
      *field = values;
    }
  }
  queries->set_count(uint32_t(rows));
  return Status::Ok();
}

Status InferQueryCount(const inference::ModelInferRequest &request, uint64_t *rows) {
  *rows = 0;
  const bool raw = request.raw_input_contents_size() > 0;
  if (Status s = CheckRawContentsCount(request); !s.ok()) return s;
  int wo = -1;
  for (int i = 0; i < request.inputs_size() && wo < 0; ++i)
    if (request.inputs(i).name() == "wo") wo = i;
  if (wo < 0) {
    return Status::InvalidArgument(
        "input 'wo': missing; every model requires it (FP32 [N, 3], one row per query)");
  }
  const auto &input = request.inputs(wo);
  if (input.datatype() != "FP32") {
    return Status::InvalidArgument("input 'wo': datatype '" + input.datatype() +
                                   "'; expected FP32");
  }
  const auto &shape = input.shape();
  if (shape.size() != 2 || shape[1] != 3 || shape[0] < 1 ||
      shape[0] > int64_t(std::numeric_limits<uint32_t>::max())) {
    return Status::InvalidArgument("input 'wo': shape " + ShapeText(shape) +
                                   "; expected [N, 3] with 1 <= N < 2^32 queries");
  }
  const uint64_t n = uint64_t(shape[0]);
  if (!raw) {
    if (const char *other = NonFp32Contents(input.contents())) {
      return Status::InvalidArgument(std::string("input 'wo': data in contents.") + other +
                                     "; expected contents.fp32_contents (datatype FP32)");
    }
  }
  // The data must fill the shape exactly: the shape is what admission charges.
  const uint64_t floats = raw ? request.raw_input_contents(wo).size() / sizeof(float)
                              : uint64_t(input.contents().fp32_contents_size());
  const bool whole = !raw || request.raw_input_contents(wo).size() % sizeof(float) == 0;
  if (floats != 3 * n || !whole) {
    const std::string held =
        raw ? "raw_input_contents holds " + std::to_string(request.raw_input_contents(wo).size()) +
                  " bytes"
            : "contents.fp32_contents holds " + std::to_string(floats) + " values";
    const std::string as_rows = whole && floats % 3 == 0
                                    ? " (FP32 [" + std::to_string(floats / 3) + ", 3])"
                                    : " (not a whole number of FP32 rows of 3)";
    const std::string needed =
        raw ? std::to_string(3 * n * sizeof(float)) + " bytes" : std::to_string(3 * n) + " values";
    return Status::InvalidArgument("input 'wo': shape " + ShapeText(shape) + " needs " + needed +
                                   ", but its " + held + as_rows +
                                   "; the shape must describe the data");
  }
  *rows = n;
  return Status::Ok();
}

Status ApplyInferParameters(const inference::ModelInferRequest &request,
                            glint::v1::EvaluateRequest *settings) {
  using P = inference::InferParameter;
  for (const auto &[name, value] : request.parameters()) {
    const std::string what = "parameter '" + name + "'";
    if (name == "seed") {
      if (value.parameter_choice_case() == P::kUint64Param) {
        settings->set_seed(value.uint64_param());
      } else if (value.parameter_choice_case() == P::kInt64Param && value.int64_param() >= 0) {
        settings->set_seed(uint64_t(value.int64_param()));
      } else {
        return Status::InvalidArgument(what + ": expected an int64 >= 0 or a uint64");
      }
    } else if (name == "precision") {
      glint::v1::Precision p{};
      if (value.parameter_choice_case() != P::kStringParam ||
          !glint::v1::Precision_Parse(value.string_param(), &p) ||
          p == glint::v1::PRECISION_UNSPECIFIED) {
        return Status::InvalidArgument(what + ": expected the string FP32 or FP64");
      }
      settings->set_precision(p);
    } else if (name == "area_method") {
      glint::v1::AreaMethod m{};
      if (value.parameter_choice_case() != P::kStringParam ||
          !glint::v1::AreaMethod_Parse(value.string_param(), &m) ||
          m == glint::v1::AREA_METHOD_UNSPECIFIED) {
        return Status::InvalidArgument(
            what +
            ": expected the string LTC, LECOCQ, LECOCQ_PEARSON, MONTE_CARLO, REFERENCE or AUTO");
      }
      settings->set_area_method(m);
    } else if (name == "area_samples") {
      // The range itself is ValidateSettings' to check, as for glint.v1.
      if (value.parameter_choice_case() == P::kInt64Param && value.int64_param() >= 0 &&
          value.int64_param() <= int64_t(std::numeric_limits<uint32_t>::max())) {
        settings->set_area_samples(uint32_t(value.int64_param()));
      } else if (value.parameter_choice_case() == P::kUint64Param &&
                 value.uint64_param() <= std::numeric_limits<uint32_t>::max()) {
        settings->set_area_samples(uint32_t(value.uint64_param()));
      } else {
        return Status::InvalidArgument(what + ": expected an integer in [0, 2^32)");
      }
    } else if (name == "max_relative_error") {
      // AUTO's budget; ValidateSettings checks it is finite and > 0.
      if (value.parameter_choice_case() == P::kDoubleParam) {
        settings->set_max_relative_error(float(value.double_param()));
      } else {
        return Status::InvalidArgument(what + ": expected a double (e.g. 0.05)");
      }
    } else if (!kIgnoredParameters.count(name)) {
      return Status::InvalidArgument(
          what +
          ": unknown; glintd reads seed, precision, area_method, area_samples and "
          "max_relative_error");
    }
  }
  return Status::Ok();
}

Status CheckRequestedOutputs(const inference::ModelInferRequest &request) {
  if (request.outputs_size() > 1 ||
      (request.outputs_size() == 1 && request.outputs(0).name() != "radiance")) {
    const std::string name = request.outputs(0).name() == "radiance" ? request.outputs(1).name()
                                                                     : request.outputs(0).name();
    return Status::InvalidArgument("output '" + name +
                                   "': the model has one output, radiance; request it at most "
                                   "once (or request none for all)");
  }
  return Status::Ok();
}

namespace {

// The refusal of a tensor parameter: the shared-memory extension's (Triton's system and CUDA
// shared memory: the client's tritonclient set_shared_memory sets all three) named as such.
Status TensorParameterRefusal(const std::string &what, const std::string &parameter) {
  if (parameter.rfind("shared_memory_", 0) == 0) {
    return Status::InvalidArgument(
        what + ": parameter '" + parameter +
        "': glintd does not implement the shared-memory extension (system or CUDA shared "
        "memory); send the data in the request and receive radiance in raw_output_contents "
        "(same-host clients: glint.v1 EvaluateRequest.shared_memory)");
  }
  return Status::InvalidArgument(what + ": parameter '" + parameter +
                                 "': not supported; glintd reads no tensor parameters");
}

}  // namespace

Status CheckTensorParameters(const inference::ModelInferRequest &request) {
  // Map order is unspecified: name the smallest parameter so the message is deterministic.
  auto first = [](const auto &parameters) {
    std::string name;
    for (const auto &[key, value] : parameters)
      if (name.empty() || key < name) name = key;
    return name;
  };
  for (const auto &input : request.inputs())
    if (!input.parameters().empty())
      return TensorParameterRefusal("input '" + input.name() + "'", first(input.parameters()));
  for (const auto &output : request.outputs())
    if (!output.parameters().empty())
      return TensorParameterRefusal("output '" + output.name() + "'", first(output.parameters()));
  return Status::Ok();
}

std::string InferMessage(const std::string &m) {
  const std::string prefix = "queries.";
  if (m.compare(0, prefix.size(), prefix) != 0) return m;
  const size_t colon = m.find(':');
  if (colon == std::string::npos) return m;
  const std::string field = m.substr(prefix.size(), colon - prefix.size());
  const size_t open = field.find('[');
  if (open == std::string::npos || field.back() != ']')
    return "input '" + field + "'" + m.substr(colon);
  return "input '" + field.substr(0, open) + "' row " +
         field.substr(open + 1, field.size() - open - 2) + m.substr(colon);
}

void EncodeRadiance(const float *rgb, uint32_t count, inference::ModelInferResponse *response) {
  auto *out = response->add_outputs();
  out->set_name("radiance");
  out->set_datatype("FP32");
  out->add_shape(count);
  out->add_shape(3);
  response->add_raw_output_contents()->assign(reinterpret_cast<const char *>(rgb),
                                              size_t(count) * 3 * sizeof(float));
}

}  // namespace glint
