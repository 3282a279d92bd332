// Open Inference Protocol tensors -> glint.v1 query batches (server/kserve_tensors.h) and
// material presets (server/kserve_models.h), without a server. The reference for a decoded
// batch is the explicit row-major layout of the protocol: element (r, c) of an [N, k] tensor
// is value r * k + c, which must land at queries.<input>[r * k + c].
#include "server/kserve_tensors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "server/kserve_models.h"
#include "tests/support/glintd_process.h"

namespace glint {
namespace {

using inference::ModelInferRequest;

std::vector<float> Ramp(size_t n, float offset) {
  std::vector<float> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = offset + 0.001f * float(i);
  return v;
}

// Adds an FP32 [rows, width] input carrying `values` as typed contents or as raw bytes.
void AddInput(ModelInferRequest *r, const std::string &name, int64_t rows, int64_t width,
              const std::vector<float> &values, bool raw) {
  auto *in = r->add_inputs();
  in->set_name(name);
  in->set_datatype("FP32");
  in->add_shape(rows);
  in->add_shape(width);
  if (raw) {
    r->add_raw_input_contents()->assign(reinterpret_cast<const char *>(values.data()),
                                        values.size() * sizeof(float));
  } else {
    for (float v : values) in->mutable_contents()->add_fp32_contents(v);
  }
}

std::vector<float> AsVector(const google::protobuf::RepeatedField<float> &f) {
  return std::vector<float>(f.begin(), f.end());
}

Status Decode(const ModelInferRequest &r, bool has_lights, glint::v1::QueryBatch *q) {
  return DecodeInferInputs(r, has_lights, q);
}

void ExpectRefused(const ModelInferRequest &r, bool has_lights, const std::string &needle) {
  glint::v1::QueryBatch q;
  const Status s = Decode(r, has_lights, &q);
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << "accepted; expected: " << needle;
  EXPECT_NE(s.message().find(needle), std::string::npos) << s.message();
}

TEST(KServeTensors, RowMajorTensorsLandInTheQueryArraysRawAndTyped) {
  const int64_t n = 5;
  const auto wo = Ramp(n * 3, 0.1f), uv = Ramp(n * 2, 3.0f), fp = Ramp(n * 4, -1.0f),
             p = Ramp(n * 3, 7.0f), nn = Ramp(n * 3, 0.2f), t = Ramp(n * 3, 0.3f);
  for (bool raw : {false, true}) {
    ModelInferRequest r;
    // Order of inputs in the request is free.
    AddInput(&r, "tangent", n, 3, t, raw);
    AddInput(&r, "uv", n, 2, uv, raw);
    AddInput(&r, "wo", n, 3, wo, raw);
    AddInput(&r, "footprint", n, 4, fp, raw);
    AddInput(&r, "position", n, 3, p, raw);
    AddInput(&r, "normal", n, 3, nn, raw);
    glint::v1::QueryBatch q;
    ASSERT_TRUE(Decode(r, true, &q).ok()) << Decode(r, true, &q).message();
    EXPECT_EQ(q.count(), uint32_t(n));
    EXPECT_EQ(AsVector(q.wo()), wo);
    EXPECT_EQ(AsVector(q.uv()), uv);
    EXPECT_EQ(AsVector(q.footprint()), fp);
    EXPECT_EQ(AsVector(q.position()), p);
    EXPECT_EQ(AsVector(q.normal()), nn);
    EXPECT_EQ(AsVector(q.tangent()), t);
    EXPECT_TRUE(q.wi().empty());
  }
}

TEST(KServeTensors, RawBytesAreLittleEndianFloats) {
  // 1.0f is 0x3f800000: little-endian bytes 00 00 80 3f.
  ModelInferRequest r;
  auto *in = r.add_inputs();
  in->set_name("wo");
  in->set_datatype("FP32");
  in->add_shape(1);
  in->add_shape(3);
  const unsigned char bytes[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x80, 0x3f};
  r.add_raw_input_contents()->assign(reinterpret_cast<const char *>(bytes), sizeof bytes);
  AddInput(&r, "wi", 1, 3, {0, 0, 1}, true);
  glint::v1::QueryBatch q;
  ASSERT_TRUE(Decode(r, false, &q).ok());
  EXPECT_EQ(AsVector(q.wo()), (std::vector<float>{0.0f, 0.0f, 1.0f}));
}

TEST(KServeTensors, ProbeModelsNeedWiAndLitModelsRefuseIt) {
  ModelInferRequest r;
  AddInput(&r, "wo", 2, 3, Ramp(6, 0), false);
  ExpectRefused(r, false, "input 'wi': missing");
  AddInput(&r, "wi", 2, 3, Ramp(6, 0), false);
  glint::v1::QueryBatch q;
  EXPECT_TRUE(Decode(r, false, &q).ok());
  EXPECT_EQ(AsVector(q.wi()), Ramp(6, 0));
  ExpectRefused(r, true, "input 'wi': unknown; this model takes wo, uv, footprint");
}

TEST(KServeTensors, MalformedTensorsAreRefusedNamingTheInput) {
  {
    ModelInferRequest r;
    AddInput(&r, "uv", 2, 2, Ramp(4, 0), false);
    ExpectRefused(r, true, "input 'wo': missing");
  }
  {
    ModelInferRequest r;
    AddInput(&r, "wo", 2, 3, Ramp(6, 0), false);
    AddInput(&r, "colour", 2, 3, Ramp(6, 0), false);
    ExpectRefused(r, true,
                  "input 'colour': unknown; this model takes wo, uv, footprint, "
                  "position, normal, tangent");
  }
  {
    ModelInferRequest r;
    AddInput(&r, "wo", 2, 3, Ramp(6, 0), false);
    AddInput(&r, "wo", 2, 3, Ramp(6, 0), false);
    ExpectRefused(r, true, "input 'wo': given twice");
  }
  {
    ModelInferRequest r;
    AddInput(&r, "wo", 2, 3, Ramp(6, 0), false);
    r.mutable_inputs(0)->set_datatype("FP64");
    ExpectRefused(r, true, "input 'wo': datatype 'FP64'; expected FP32");
  }
  {
    ModelInferRequest r;
    AddInput(&r, "wo", 6, 1, Ramp(6, 0), false);
    ExpectRefused(r, true, "input 'wo': shape [6, 1]; expected [N, 3] with 1 <= N < 2^32");
  }
  {
    ModelInferRequest r;
    AddInput(&r, "wo", 0, 3, {}, false);
    ExpectRefused(r, true, "input 'wo': shape [0, 3]; expected [N, 3] with 1 <= N < 2^32");
  }
  {
    ModelInferRequest r;  // uv with a row count other than wo's
    AddInput(&r, "wo", 2, 3, Ramp(6, 0), false);
    AddInput(&r, "uv", 3, 2, Ramp(6, 0), false);
    ExpectRefused(r, true, "input 'uv': shape [3, 2]; expected [2, 2]");
  }
  {
    ModelInferRequest r;  // shape says 2 rows, data holds 5 values
    AddInput(&r, "wo", 2, 3, Ramp(5, 0), false);
    ExpectRefused(r, true,
                  "input 'wo': shape [2, 3] needs 6 values, but its contents.fp32_contents holds 5 "
                  "values");
  }
  {
    ModelInferRequest r;
    AddInput(&r, "wo", 2, 3, Ramp(5, 0), true);
    ExpectRefused(r, true,
                  "input 'wo': shape [2, 3] needs 24 bytes, but its raw_input_contents holds 20 "
                  "bytes");
  }
  {
    ModelInferRequest r;  // another input's data short of the shape: the decoder's own check
    AddInput(&r, "wo", 2, 3, Ramp(6, 0), true);
    AddInput(&r, "uv", 2, 2, Ramp(3, 0), true);
    ExpectRefused(r, true,
                  "input 'uv': raw_input_contents holds 12 bytes; shape [2, 2] FP32 needs 16");
  }
  {
    ModelInferRequest r;  // typed data in the wrong field
    AddInput(&r, "wo", 1, 3, {}, false);
    for (int i = 0; i < 3; ++i) r.mutable_inputs(0)->mutable_contents()->add_fp64_contents(1.0);
    ExpectRefused(r, true, "input 'wo': data in contents.fp64_contents");
  }
  {
    ModelInferRequest r;  // raw for one input, typed for another
    AddInput(&r, "wo", 1, 3, {0, 0, 1}, true);
    AddInput(&r, "uv", 1, 2, {0, 0}, false);
    ExpectRefused(r, true, "raw_input_contents: 1 entries for 2 inputs");
    r.add_raw_input_contents()->assign(8, '\0');
    ExpectRefused(r, true, "input 'uv': has contents although the request uses raw");
  }
}

// wo is checked once: for every malformed wo the decoder's refusal is admission's, word for
// word (before, the decoder had its own checks: "[N, 3] with N >= 1 queries" against
// "1 <= N < 2^32", "holds 5 values; shape [2, 3] needs 6" against "needs 6 values, but ...").
TEST(KServeTensors, MalformedWoGetsOneMessageAtAdmissionAndDecoding) {
  struct Case {
    int64_t rows, width;
    size_t floats;
  };
  for (bool raw : {false, true})
    for (const Case &c : {Case{0, 3, 0}, Case{6, 1, 6}, Case{5, 2, 10}, Case{2, 3, 5},
                          Case{2, 3, 7}, Case{1000000000, 3, 3}}) {
      SCOPED_TRACE(std::string(raw ? "raw" : "typed") + " [" + std::to_string(c.rows) + ", " +
                   std::to_string(c.width) + "] with " + std::to_string(c.floats) + " floats");
      ModelInferRequest r;
      AddInput(&r, "wo", c.rows, c.width, std::vector<float>(c.floats, 0.0f), raw);
      uint64_t rows = 0;
      const Status admission = InferQueryCount(r, &rows);
      glint::v1::QueryBatch q;
      const Status decoding = Decode(r, true, &q);
      EXPECT_EQ(admission.code(), Status::Code::kInvalidArgument);
      EXPECT_EQ(decoding.code(), Status::Code::kInvalidArgument);
      EXPECT_EQ(decoding.message(), admission.message());
      EXPECT_EQ(admission.message().rfind("input 'wo': ", 0), 0u) << admission.message();
    }
  ModelInferRequest fp64;  // typed data in the wrong field
  AddInput(&fp64, "wo", 1, 3, {}, false);
  for (int i = 0; i < 3; ++i) fp64.mutable_inputs(0)->mutable_contents()->add_fp64_contents(1.0);
  uint64_t rows = 0;
  glint::v1::QueryBatch q;
  EXPECT_EQ(Decode(fp64, true, &q).message(), InferQueryCount(fp64, &rows).message());
  EXPECT_EQ(InferQueryCount(fp64, &rows).message(),
            "input 'wo': data in contents.fp64_contents; expected contents.fp32_contents "
            "(datatype FP32)");
}

// The query count admission charges before decoding: wo's rows, only when its data fills them;
// otherwise INVALID_ARGUMENT naming wo, its shape and what it needs (before: 0 queries, admitted,
// and refused by the decoder on a worker, or answered "busy, retry" when the queue was full).
TEST(KServeTensors, QueryCountForAdmissionIsWoRowsItsDataFills) {
  auto refused = [](const ModelInferRequest &r, const std::string &needle) {
    uint64_t rows = 7;
    const Status s = InferQueryCount(r, &rows);
    EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << "accepted; expected: " << needle;
    EXPECT_NE(s.message().find(needle), std::string::npos) << s.message();
    EXPECT_EQ(rows, 0u);
  };
  for (bool raw : {false, true}) {
    SCOPED_TRACE(raw ? "raw" : "typed");
    ModelInferRequest r;
    AddInput(&r, "uv", 5, 2, std::vector<float>(10, 0.5f), raw);
    AddInput(&r, "wo", 5, 3, std::vector<float>(15, 0.0f), raw);
    uint64_t rows = 0;
    EXPECT_TRUE(InferQueryCount(r, &rows).ok());
    EXPECT_EQ(rows, 5u);
    ModelInferRequest lying;  // claims 1e9 rows, carries one
    AddInput(&lying, "wo", 1000000000, 3, std::vector<float>(3, 0.0f), raw);
    refused(lying, raw ? "input 'wo': shape [1000000000, 3] needs 12000000000 bytes, but its "
                         "raw_input_contents holds 12 bytes (FP32 [1, 3])"
                       : "input 'wo': shape [1000000000, 3] needs 3000000000 values, but its "
                         "contents.fp32_contents holds 3 values (FP32 [1, 3])");
    ModelInferRequest short_rows;  // claims 4 rows, carries 3 and a bit
    AddInput(&short_rows, "wo", 4, 3, std::vector<float>(10, 0.0f), raw);
    refused(short_rows, "not a whole number of FP32 rows of 3");
    ModelInferRequest narrow;
    AddInput(&narrow, "wo", 5, 2, std::vector<float>(10, 0.0f), raw);
    refused(narrow, "input 'wo': shape [5, 2]; expected [N, 3] with 1 <= N < 2^32 queries");
    ModelInferRequest empty;
    AddInput(&empty, "wo", 0, 3, {}, raw);
    refused(empty, "input 'wo': shape [0, 3]; expected [N, 3]");
  }
  refused(ModelInferRequest(), "input 'wo': missing");
  {
    ModelInferRequest r;
    AddInput(&r, "wo", 1, 3, {0, 0, 1}, true);
    r.mutable_inputs(0)->set_datatype("FP64");
    refused(r, "input 'wo': datatype 'FP64'; expected FP32");
  }
  {
    ModelInferRequest r;  // raw for one input, typed for another
    AddInput(&r, "wo", 1, 3, {0, 0, 1}, true);
    AddInput(&r, "uv", 1, 2, {0, 0}, false);
    refused(r, "raw_input_contents: 1 entries for 2 inputs");
  }
}

TEST(KServeTensors, ParametersOverrideSeedPrecisionAndAreaMethod) {
  ModelInferRequest r;
  glint::v1::EvaluateRequest settings;
  (*r.mutable_parameters())["seed"].set_int64_param(7);
  (*r.mutable_parameters())["precision"].set_string_param("FP64");
  (*r.mutable_parameters())["area_method"].set_string_param("MONTE_CARLO");
  (*r.mutable_parameters())["area_samples"].set_int64_param(16);
  (*r.mutable_parameters())["priority"].set_uint64_param(3);  // a Triton client's own: ignored
  ASSERT_TRUE(ApplyInferParameters(r, &settings).ok());
  EXPECT_EQ(settings.seed(), 7u);
  EXPECT_EQ(settings.precision(), glint::v1::FP64);
  EXPECT_EQ(settings.area_method(), glint::v1::MONTE_CARLO);
  EXPECT_EQ(settings.area_samples(), 16u);

  (*r.mutable_parameters())["seed"].set_uint64_param(18446744073709551615ull);
  ASSERT_TRUE(ApplyInferParameters(r, &settings).ok());
  EXPECT_EQ(settings.seed(), 18446744073709551615ull);

  auto refused = [](const char *name, const inference::InferParameter &value,
                    const std::string &needle) {
    ModelInferRequest bad;
    (*bad.mutable_parameters())[name] = value;
    glint::v1::EvaluateRequest s;
    const Status st = ApplyInferParameters(bad, &s);
    EXPECT_EQ(st.code(), Status::Code::kInvalidArgument) << name;
    EXPECT_NE(st.message().find(needle), std::string::npos) << st.message();
  };
  inference::InferParameter v;
  v.set_int64_param(-1);
  refused("seed", v, "parameter 'seed': expected an int64 >= 0 or a uint64");
  v.set_string_param("FP16");
  refused("precision", v, "parameter 'precision': expected the string FP32 or FP64");
  v.set_string_param("LTC2");
  refused("area_method", v, "parameter 'area_method': expected the string LTC, LECOCQ");
  v.set_bool_param(true);
  refused("exposure", v, "parameter 'exposure': unknown; glintd reads seed, precision");
}

TEST(KServeTensors, OutputsAndMessages) {
  ModelInferRequest r;
  EXPECT_TRUE(CheckRequestedOutputs(r).ok());
  r.add_outputs()->set_name("radiance");
  EXPECT_TRUE(CheckRequestedOutputs(r).ok());
  r.add_outputs()->set_name("albedo");
  EXPECT_NE(CheckRequestedOutputs(r).message().find("output 'albedo'"), std::string::npos);

  EXPECT_EQ(InferMessage("queries.wo[17]: (nan, 0, 1) is not finite"),
            "input 'wo' row 17: (nan, 0, 1) is not finite");
  EXPECT_EQ(InferMessage("queries.count: 0; expected at least one query"),
            "input 'count': 0; expected at least one query");
  EXPECT_EQ(InferMessage("lights: empty"), "lights: empty");

  const float rgb[6] = {1, 2, 3, 4, 5, 6};
  inference::ModelInferResponse response;
  EncodeRadiance(rgb, 2, &response);
  ASSERT_EQ(response.outputs_size(), 1);
  EXPECT_EQ(response.outputs(0).name(), "radiance");
  EXPECT_EQ(response.outputs(0).datatype(), "FP32");
  EXPECT_EQ(
      std::vector<int64_t>(response.outputs(0).shape().begin(), response.outputs(0).shape().end()),
      (std::vector<int64_t>{2, 3}));
  ASSERT_EQ(response.raw_output_contents(0).size(), sizeof rgb);
  EXPECT_EQ(std::memcmp(response.raw_output_contents(0).data(), rgb, sizeof rgb), 0);
}

// --- material presets ---

class KServePresets : public ::testing::Test {
 protected:
  std::string Write(const std::string &name, const std::string &text) {
    const std::string path = dir_.File(name);
    std::filesystem::create_directories(std::filesystem::path(path).parent_path());
    std::ofstream(path) << text;
    return path;
  }
  test::TempDir dir_{"kserve_presets"};
};

constexpr const char *kMaterial =
    R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1, "schlick": {"f0": [0.9, 0.6, 0.3]}})";
constexpr const char *kLights =
    R"({"lights": [{"directional": {"direction": [0, 0.6, 0.8], "irradiance": [1, 2, 3]}}]})";

TEST_F(KServePresets, LightsBlockInTheMaterialFileOrAsASecondFile) {
  const std::string inline_lights = Write(
      "inline.json",
      R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1, "schlick": {"f0": [0.9, 0.6, 0.3]},
          "lights": [{"directional": {"direction": [0, 0.6, 0.8], "irradiance": [1, 2, 3]}}]})");
  const std::string material = Write("m.json", kMaterial);
  const std::string lights = Write("l.json", kLights);
  KServeModel a, b;
  ASSERT_TRUE(LoadModelFlag("a=" + inline_lights, &a).ok());
  ASSERT_TRUE(LoadModelFlag("b=" + material + "," + lights, &b).ok());
  EXPECT_EQ(a.name, "a");
  // Both forms give the same settings, field for field (float values read the same way).
  EXPECT_EQ(a.settings.SerializeAsString(), b.settings.SerializeAsString());
  ASSERT_EQ(a.settings.lights_size(), 1);
  EXPECT_EQ(a.settings.lights(0).directional().direction(1), 0.6f);
  EXPECT_EQ(a.settings.material().alpha_x(), 0.3f);

  KServeModel c;
  const Status both = LoadModelFlag("c=" + inline_lights + "," + lights, &c);
  EXPECT_NE(both.message().find("has its own \"lights\""), std::string::npos) << both.message();
}

TEST_F(KServePresets, BadFilesAndNamesAreRefusedNamingThem) {
  const std::string typo = Write("typo.json", R"({"model": "SMOOTH", "alpha": 0.3})");
  KServeModel m;
  Status s = LoadModelFlag("t=" + typo, &m);
  EXPECT_NE(s.message().find(typo), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("alpha"), std::string::npos) << s.message();
  EXPECT_NE(LoadModelFlag("nofile", &m).message().find("expected NAME=MATERIAL.json"),
            std::string::npos);

  const std::string material = Write("m.json", kMaterial);
  std::vector<KServeModel> models;
  s = LoadKServeModels({"x=" + material, "x=" + material}, {}, {}, &models);
  EXPECT_NE(s.message().find("'x'"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("registered twice"), std::string::npos) << s.message();
  models.clear();
  s = LoadKServeModels({"a/b=" + material}, {}, {}, &models);
  EXPECT_NE(s.message().find("model name 'a/b'"), std::string::npos) << s.message();
  // Validation as for a glint.v1 request: alpha out of range names the model and the field.
  const std::string rough = Write("rough.json", R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 3,
      "alpha_y": 0.1, "schlick": {"f0": [0.9, 0.6, 0.3]}})");
  models.clear();
  s = LoadKServeModels({"r=" + rough}, {}, {}, &models);
  EXPECT_NE(s.message().find("model 'r'"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("material.alpha_x"), std::string::npos) << s.message();
}

TEST_F(KServePresets, ModelDirTakesEveryJsonFileSortedByName) {
  Write("presets/zinc.json", kMaterial);
  Write("presets/amber.json",
        R"({"model": "SMOOTH", "ndf": "BECKMANN", "alpha_x": 0.2, "alpha_y": 0.2,
            "dielectric": {"ior": 1.5}, "lights": [{"point": {"position": [0, 0, 2], "intensity": [1, 1, 1]}}]})");
  Write("presets/README.txt", "not a preset");
  std::vector<KServeModel> models;
  ASSERT_TRUE(LoadKServeModels({}, {dir_.File("presets")}, {}, &models).ok());
  ASSERT_EQ(models.size(), 2u);
  EXPECT_EQ(models[0].name, "amber");
  EXPECT_EQ(models[0].settings.lights_size(), 1);
  EXPECT_EQ(models[1].name, "zinc");
  EXPECT_EQ(models[1].settings.lights_size(), 0);
  models.clear();
  EXPECT_NE(LoadKServeModels({}, {dir_.File("missing")}, {}, &models).message().find("missing"),
            std::string::npos);
}

// GLINTD_UNDER_TEST replaces the glintd every Glintd::Start / Launch starts
// (tests/support/glintd_process.h), not only where a test remembered GlintdUnderTest(): a script
// standing in for glintd records its arguments and writes the port file as glintd does once
// SERVING. Started as a path that does not exist, so only the variable can make it start.
TEST(GlintdUnderTest, ReplacesTheBinaryEveryStartRuns) {
  test::TempDir dir("glintd_under_test");
  const std::string script = dir.File("fake_glintd.sh"), args = dir.File("args");
  {
    std::ofstream out(script);
    out << "#!/bin/sh\necho \"$@\" > '" << args << "'\n"
        << "while [ $# -gt 0 ]; do\n"
        << "  if [ \"$1\" = --port-file ]; then echo 43210 > \"$2\"; fi\n"
        << "  shift\n"
        << "done\n"
        << "exec sleep 600\n";
  }
  std::filesystem::permissions(script, std::filesystem::perms::owner_all);
  const char *before = std::getenv("GLINTD_UNDER_TEST");
  const std::string saved = before ? before : "";
  setenv("GLINTD_UNDER_TEST", script.c_str(), 1);
  std::string error;
  auto server = test::Glintd::Start(dir.File("no_such_glintd"), dir, "fake", {"--quiet"}, &error);
  if (before) {
    setenv("GLINTD_UNDER_TEST", saved.c_str(), 1);
  } else {
    unsetenv("GLINTD_UNDER_TEST");
  }
  ASSERT_NE(server, nullptr) << error;
  EXPECT_EQ(server->address(), "127.0.0.1:43210");
  EXPECT_NE(test::ReadFile(args).find("--listen 127.0.0.1:0 --port-file"), std::string::npos)
      << test::ReadFile(args);
}

}  // namespace
}  // namespace glint
