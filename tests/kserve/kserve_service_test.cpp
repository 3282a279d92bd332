// inference.GRPCInferenceService against a real glintd (tests/support/glintd_process.h), with
// the C++ stubs of proto/inference/grpc_service.proto. The reference for every ModelInfer
// result is glint.v1 Evaluate of the same queries and settings on the same server: the two
// must agree bit for bit, typed contents or raw bytes alike. (tests/kserve/tritonclient_test.py
// does the same with Triton's own Python client.)
#include "server/kserve_service.h"

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "inference/grpc_service.grpc.pb.h"
#include "queue_depth_gauge.h"
#include "server/kserve_models.h"
#include "server/normal_map_decode.h"
#include "server/status.h"

namespace glint {
namespace {

using inference::GRPCInferenceService;
using inference::ModelInferRequest;
using inference::ModelInferResponse;

const std::string kExamples = GLINT_EXAMPLES_DIR;

// Queries of one batch, row-major per input (the protocol's layout and glint.v1's).
struct Queries {
  uint32_t n = 0;
  std::vector<float> wo, wi, uv, footprint, position, normal, tangent;
};

std::vector<float> UnitVectors(std::mt19937 &rng, uint32_t n, float min_z) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> v;
  for (uint32_t i = 0; i < n; ++i) {
    const float z = min_z + (1.0f - min_z) * u(rng), phi = 6.2831853f * u(rng);
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    v.insert(v.end(), {r * std::cos(phi), r * std::sin(phi), z});
  }
  return v;
}

// The mirror direction of rect_small.json's light seen from the origin: the sparkle preset's
// glints (binomial counts of facets reflecting the light) light up only near it.
constexpr float kSparkleMirror[3] = {0.0f, -0.845f, 0.534f};

// With `near`, wo is scattered about it and footprints cover some 100 sparkle facets.
Queries MakeQueries(uint32_t n, bool probe, bool frame, uint32_t seed,
                    const float *near = nullptr) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f), f(1e-4f, 2e-3f), big(5e-3f, 2e-2f);
  std::normal_distribution<float> g(0.0f, 0.15f);
  Queries q;
  q.n = n;
  q.wo = UnitVectors(rng, n, 0.1f);
  if (near) {
    for (uint32_t i = 0; i < n; ++i) {
      float w[3] = {near[0] + g(rng), near[1] + g(rng), std::max(near[2] + g(rng), 0.1f)};
      const float len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      for (int c = 0; c < 3; ++c) q.wo[3 * i + c] = w[c] / len;
    }
  }
  if (probe) q.wi = UnitVectors(rng, n, 0.1f);
  for (uint32_t i = 0; i < 2 * n; ++i) q.uv.push_back(u(rng));
  for (uint32_t i = 0; i < 4 * n; ++i) q.footprint.push_back(near ? big(rng) : f(rng));
  if (frame) {
    for (uint32_t i = 0; i < n; ++i) {
      // A frame tilted about x by angle a: n = (0, -sin a, cos a), t = (1, 0, 0).
      const float a = 0.3f * float(i % 5);
      q.position.insert(q.position.end(), {u(rng), u(rng), 0.0f});
      q.normal.insert(q.normal.end(), {0.0f, -std::sin(a), std::cos(a)});
      q.tangent.insert(q.tangent.end(), {1.0f, 0.0f, 0.0f});
    }
  }
  return q;
}

void AddTensor(ModelInferRequest *r, const char *name, const std::vector<float> &v, int width,
               bool raw) {
  if (v.empty()) return;
  auto *in = r->add_inputs();
  in->set_name(name);
  in->set_datatype("FP32");
  in->add_shape(int64_t(v.size()) / width);
  in->add_shape(width);
  if (raw) {
    r->add_raw_input_contents()->assign(reinterpret_cast<const char *>(v.data()),
                                        v.size() * sizeof(float));
  } else {
    in->mutable_contents()->mutable_fp32_contents()->Add(v.begin(), v.end());
  }
}

ModelInferRequest InferRequest(const std::string &model, const Queries &q, bool raw) {
  ModelInferRequest r;
  r.set_model_name(model);
  r.set_id("req-1");
  AddTensor(&r, "wo", q.wo, 3, raw);
  AddTensor(&r, "wi", q.wi, 3, raw);
  AddTensor(&r, "uv", q.uv, 2, raw);
  AddTensor(&r, "footprint", q.footprint, 4, raw);
  AddTensor(&r, "position", q.position, 3, raw);
  AddTensor(&r, "normal", q.normal, 3, raw);
  AddTensor(&r, "tangent", q.tangent, 3, raw);
  return r;
}

glint::v1::QueryBatch Batch(const Queries &q) {
  glint::v1::QueryBatch b;
  b.set_count(q.n);
  b.mutable_wo()->Add(q.wo.begin(), q.wo.end());
  b.mutable_wi()->Add(q.wi.begin(), q.wi.end());
  b.mutable_uv()->Add(q.uv.begin(), q.uv.end());
  b.mutable_footprint()->Add(q.footprint.begin(), q.footprint.end());
  b.mutable_position()->Add(q.position.begin(), q.position.end());
  b.mutable_normal()->Add(q.normal.begin(), q.normal.end());
  b.mutable_tangent()->Add(q.tangent.begin(), q.tangent.end());
  return b;
}

// Four unit quads side by side at height 2: under area_method REFERENCE at 1024 nodes,
// 4 x 3 fan triangles x 1024^2 nodes = 1.26e7 BRDF evaluations a query.
void WriteQuads(const std::string &path) {
  std::ofstream out(path);
  out << R"({"lights": [)";
  for (int k = 0; k < 4; ++k)
    out << (k ? "," : "") << R"({"polygon": {"vertices": [)" << -2 + k << ", -1, 2, " << -1 + k
        << ", -1, 2, " << -1 + k << ", 1, 2, " << -2 + k << R"(, 1, 2], "radiance": [1, 1, 1]}})";
  out << "]}";
}

// A 64 x 64 bumpy normal map made by `glint normal-map` in `dir`, and a NORMAL_MAP probe preset
// naming its digest (glintd must hold the map from the start: --normal-map FILE).
struct NormalMapPreset {
  std::string map_file, preset_file;
};

NormalMapPreset MakeNormalMapPreset(const test::TempDir &dir) {
  NormalMapPreset p;
  p.map_file = dir.File("bumpy64.exr");
  p.preset_file = dir.File("nm.json");
  const pid_t pid = test::Spawn(
      {GLINT_CLI_PATH, "normal-map", "bumpy", "--size", "64", "--seed", "5", "--out", p.map_file},
      dir.File("nm_gen.out"), dir.File("nm_gen.err"));
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << test::ReadFile(dir.File("nm_gen.err"));
  DecodedNormalMap map;
  const Status decoded = DecodeNormalMap(p.map_file, test::ReadFile(p.map_file), 1u << 20, &map);
  EXPECT_TRUE(decoded.ok()) << decoded.message();
  std::ofstream(p.preset_file)
      << R"({"model": "NORMAL_MAP", "schlick": {"f0": [0.95, 0.93, 0.88]},)"
      << R"( "normal_map": {"digest": ")" << NormalMapDigest(map)
      << R"(", "intrinsic_roughness": 0.05}})";
  return p;
}

// Calls queued behind a long one may wait for its kernels to compile on a cold cache: 120 s.
template <class Stop>
double WaitForDepth(httplib::Client &http, double want, Stop &&stop) {
  return glint::test::WaitForQueueDepth(http, want, stop, std::chrono::seconds(120));
}

// ModelInfer's radiance as floats (empty unless it is one raw output).
std::vector<float> RawRadiance(const ModelInferResponse &r) {
  if (r.raw_output_contents_size() != 1 || r.raw_output_contents(0).size() % sizeof(float) != 0)
    return {};
  std::vector<float> v(r.raw_output_contents(0).size() / sizeof(float));
  std::memcpy(v.data(), r.raw_output_contents(0).data(), r.raw_output_contents(0).size());
  return v;
}

bool SameBits(const std::vector<float> &a, const std::vector<float> &b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// A ModelInfer that holds glintd's one worker: 2000 sparkle queries by REFERENCE 256, some 1.6e6
// units each (10-40 s of the worker at any load), run on its own thread until the test cancels
// it.
class LongCall {
 public:
  explicit LongCall(GRPCInferenceService::Stub *kserve) {
    ModelInferRequest r =
        InferRequest("sparkle", MakeQueries(2000, false, false, 17, kSparkleMirror), true);
    (*r.mutable_parameters())["area_method"].set_string_param("REFERENCE");
    (*r.mutable_parameters())["area_samples"].set_int64_param(256);
    ctx_.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(600));
    thread_ = std::thread([this, kserve, r] {
      ModelInferResponse response;
      status_ = kserve->ModelInfer(&ctx_, r, &response);
      done_ = true;
    });
  }
  ~LongCall() { Cancel(); }
  bool done() const { return done_; }
  // Cancels the call (it stops at its next query slice) and waits for its answer.
  grpc::Status Cancel() {
    if (thread_.joinable()) {
      ctx_.TryCancel();
      thread_.join();
    }
    return status_;
  }

 private:
  grpc::ClientContext ctx_;
  grpc::Status status_;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

class KServeService : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir("kserve_service");
    std::string error;
    server_ = test::Glintd::Start(GLINTD_PATH, *dir_, "glintd",
                                  {"--model", "paint=" + Paint(), "--model", "probe=" + Probe(),
                                   "--model", "sparkle=" + Sparkle()},
                                  &error)
                  .release();
    ASSERT_NE(server_, nullptr) << error;
    auto channel = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
    kserve_ = GRPCInferenceService::NewStub(channel).release();
    glint_ = glint::v1::GlintService::NewStub(channel).release();
  }
  static void TearDownTestSuite() {
    delete kserve_;
    delete glint_;
    delete server_;
    delete dir_;
  }
  static std::string Paint() {
    return kExamples + "/materials/paint_schlick.json," + kExamples + "/lights/studio.json";
  }
  static std::string Probe() { return kExamples + "/materials/gold_aniso.json"; }
  static std::string Sparkle() {
    return kExamples + "/materials/sparkle_binomial.json," + kExamples + "/lights/rect_small.json";
  }

  // The preset as glint.v1 settings, read by glintd's own loader.
  static glint::v1::EvaluateRequest Settings(const std::string &model_flag) {
    KServeModel m;
    EXPECT_TRUE(LoadModelFlag(model_flag, &m).ok());
    return m.settings;
  }

  static grpc::Status Infer(const ModelInferRequest &r, ModelInferResponse *response) {
    grpc::ClientContext ctx;
    return kserve_->ModelInfer(&ctx, r, response);
  }

  static std::vector<float> Evaluate(glint::v1::EvaluateRequest request, const Queries &q) {
    *request.mutable_queries() = Batch(q);
    glint::v1::EvaluateResponse response;
    grpc::ClientContext ctx;
    const grpc::Status s = glint_->Evaluate(&ctx, request, &response);
    EXPECT_TRUE(s.ok()) << s.error_message();
    return std::vector<float>(response.radiance().begin(), response.radiance().end());
  }

  // ModelInfer's radiance, after checking the envelope (name, shape, raw FP32).
  static std::vector<float> Radiance(const ModelInferResponse &r, uint32_t n) {
    EXPECT_EQ(r.id(), "req-1");
    EXPECT_EQ(r.model_version(), "1");
    EXPECT_EQ(r.outputs_size(), 1);
    EXPECT_EQ(r.raw_output_contents_size(), 1);
    if (r.outputs_size() != 1 || r.raw_output_contents_size() != 1) return {};
    EXPECT_EQ(r.outputs(0).name(), "radiance");
    EXPECT_EQ(r.outputs(0).datatype(), "FP32");
    EXPECT_EQ(r.outputs(0).shape_size(), 2);
    EXPECT_EQ(r.outputs(0).shape(0), int64_t(n));
    EXPECT_EQ(r.outputs(0).shape(1), 3);
    const std::string &bytes = r.raw_output_contents(0);
    EXPECT_EQ(bytes.size(), size_t(n) * 3 * sizeof(float));
    std::vector<float> v(bytes.size() / sizeof(float));
    std::memcpy(v.data(), bytes.data(), v.size() * sizeof(float));
    return v;
  }

  static bool BitEqual(const std::vector<float> &a, const std::vector<float> &b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
  }

  static test::TempDir *dir_;
  static test::Glintd *server_;
  static GRPCInferenceService::Stub *kserve_;
  static glint::v1::GlintService::Stub *glint_;
};

test::TempDir *KServeService::dir_ = nullptr;
test::Glintd *KServeService::server_ = nullptr;
GRPCInferenceService::Stub *KServeService::kserve_ = nullptr;
glint::v1::GlintService::Stub *KServeService::glint_ = nullptr;

TEST_F(KServeService, ModelInferEqualsEvaluateBitForBitTypedAndRaw) {
  struct Case {
    const char *model;
    std::string flag;
    bool probe, frame;
  };
  const Case cases[] = {{"paint", "paint=" + Paint(), false, false},
                        {"paint", "paint=" + Paint(), false, true},
                        {"probe", "probe=" + Probe(), true, false},
                        {"probe", "probe=" + Probe(), true, true},
                        {"sparkle", "sparkle=" + Sparkle(), false, false}};
  uint32_t seed = 1;
  for (const Case &c : cases) {
    SCOPED_TRACE(std::string(c.model) + (c.frame ? " with frame" : ""));
    const bool sparkle = std::string(c.model) == "sparkle";
    const Queries q =
        MakeQueries(777, c.probe, c.frame, seed++, sparkle ? kSparkleMirror : nullptr);
    const std::vector<float> reference = Evaluate(Settings(c.flag), q);
    ASSERT_EQ(reference.size(), size_t(q.n) * 3);
    for (bool raw : {false, true}) {
      ModelInferResponse response;
      const grpc::Status s = Infer(InferRequest(c.model, q, raw), &response);
      ASSERT_TRUE(s.ok()) << s.error_message();
      EXPECT_EQ(response.model_name(), c.model);
      EXPECT_TRUE(BitEqual(Radiance(response, q.n), reference)) << (raw ? "raw" : "typed");
    }
  }
}

TEST_F(KServeService, ParametersOverrideSeedPrecisionAndAreaMethodAsInEvaluate) {
  const Queries q = MakeQueries(300, false, false, 11, kSparkleMirror);
  glint::v1::EvaluateRequest settings = Settings("sparkle=" + Sparkle());
  const std::vector<float> seed0 = Evaluate(settings, q);
  settings.set_seed(7);
  settings.set_area_method(glint::v1::MONTE_CARLO);
  settings.set_area_samples(16);
  settings.set_precision(glint::v1::FP64);
  const std::vector<float> reference = Evaluate(settings, q);
  // The overrides matter for these queries (otherwise the comparison below proves nothing).
  ASSERT_FALSE(BitEqual(seed0, reference));
  ASSERT_GT(*std::max_element(reference.begin(), reference.end()), 0.0f);

  ModelInferRequest r = InferRequest("sparkle", q, true);
  (*r.mutable_parameters())["seed"].set_int64_param(7);
  (*r.mutable_parameters())["area_method"].set_string_param("MONTE_CARLO");
  (*r.mutable_parameters())["area_samples"].set_int64_param(16);
  (*r.mutable_parameters())["precision"].set_string_param("FP64");
  ModelInferResponse response;
  const grpc::Status s = Infer(r, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_TRUE(BitEqual(Radiance(response, q.n), reference));
}

TEST_F(KServeService, BadTensorsAreInvalidArgumentNamingInputAndRow) {
  Queries q = MakeQueries(40, false, false, 5);
  q.wo[17 * 3 + 1] = std::nanf("");
  ModelInferResponse response;
  grpc::Status s = Infer(InferRequest("paint", q, true), &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("input 'wo' row 17"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find("not finite"), std::string::npos) << s.error_message();

  q = MakeQueries(40, false, false, 5);
  q.wo[3 * 3 + 2] *= 1.01f;  // |wo| off by about 1e-2 > the 1e-3 tolerance
  s = Infer(InferRequest("paint", q, false), &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("input 'wo' row 3"), std::string::npos) << s.error_message();

  q = MakeQueries(40, false, false, 5);
  ModelInferRequest r = InferRequest("paint", q, true);
  r.mutable_raw_input_contents(1)->resize(7);  // uv
  s = Infer(r, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("input 'uv': raw_input_contents holds 7 bytes"),
            std::string::npos)
      << s.error_message();

  r = InferRequest("paint", q, true);
  (*r.mutable_parameters())["seed"].set_string_param("seven");
  s = Infer(r, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("parameter 'seed'"), std::string::npos) << s.error_message();

  r = InferRequest("nope", q, true);
  s = Infer(r, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(s.error_message().find("registered models: paint, probe, sparkle"), std::string::npos)
      << s.error_message();
  r = InferRequest("paint", q, true);
  r.set_model_version("2");
  EXPECT_EQ(Infer(r, &response).error_code(), grpc::StatusCode::NOT_FOUND);

  // The server is unaffected: the same request without the defect is answered.
  r = InferRequest("paint", q, true);
  EXPECT_TRUE(Infer(r, &response).ok());
  EXPECT_TRUE(server_->Alive());
}

// glintd implements no shared-memory extension and reads no tensor parameters: an output asked
// for in a shared-memory region (as tritonclient's InferRequestedOutput.set_shared_memory asks)
// was answered OK with raw_output_contents and the region left untouched; now it is refused
// naming the output and the parameter, and so is an input whose data is said to be in one.
TEST_F(KServeService, TensorParametersAreRefusedNamingTensorAndParameter) {
  const Queries q = MakeQueries(4, false, false, 5);
  ModelInferResponse response;
  ModelInferRequest r = InferRequest("paint", q, true);
  auto *out = r.add_outputs();
  out->set_name("radiance");
  (*out->mutable_parameters())["shared_memory_region"].set_string_param("out_region");
  (*out->mutable_parameters())["shared_memory_byte_size"].set_int64_param(48);
  grpc::Status s = Infer(r, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  // The smallest name of the map is named (shared_memory_byte_size < shared_memory_region).
  EXPECT_NE(s.error_message().find("output 'radiance': parameter 'shared_memory_byte_size': "
                                   "glintd does not implement the shared-memory extension"),
            std::string::npos)
      << s.error_message();
  EXPECT_EQ(response.raw_output_contents_size(), 0);

  r = InferRequest("paint", q, true);
  out = r.add_outputs();
  out->set_name("radiance");
  (*out->mutable_parameters())["classification"].set_int64_param(3);
  s = Infer(r, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("output 'radiance': parameter 'classification': not supported"),
            std::string::npos)
      << s.error_message();

  r = InferRequest("paint", q, true);
  (*r.mutable_inputs(0)->mutable_parameters())["shared_memory_region"].set_string_param("in");
  s = Infer(r, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("input '" + r.inputs(0).name() +
                                   "': parameter 'shared_memory_region': glintd does not "
                                   "implement the shared-memory extension"),
            std::string::npos)
      << s.error_message();

  // Without parameters the output request is answered as before.
  r = InferRequest("paint", q, true);
  r.add_outputs()->set_name("radiance");
  s = Infer(r, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(Radiance(response, 4).size(), 12u);
}

TEST_F(KServeService, HealthMetadataConfigAndStatistics) {
  {
    grpc::ClientContext ctx;
    inference::ServerLiveResponse live;
    ASSERT_TRUE(kserve_->ServerLive(&ctx, {}, &live).ok());
    EXPECT_TRUE(live.live());
  }
  {
    grpc::ClientContext ctx;
    inference::ServerReadyResponse ready;
    ASSERT_TRUE(kserve_->ServerReady(&ctx, {}, &ready).ok());
    EXPECT_TRUE(ready.ready());  // the port file is written only when SERVING
  }
  for (const char *name : {"paint", "nope"}) {
    grpc::ClientContext ctx;
    inference::ModelReadyRequest req;
    req.set_name(name);
    inference::ModelReadyResponse ready;
    ASSERT_TRUE(kserve_->ModelReady(&ctx, req, &ready).ok());
    EXPECT_EQ(ready.ready(), std::string(name) == "paint");
  }
  {
    grpc::ClientContext ctx;
    inference::ModelMetadataRequest req;
    req.set_name("probe");
    inference::ModelMetadataResponse md;
    ASSERT_TRUE(kserve_->ModelMetadata(&ctx, req, &md).ok());
    std::string inputs;
    for (const auto &t : md.inputs()) {
      inputs += t.name() + ":" + t.datatype() + "[" + std::to_string(t.shape(0)) + "," +
                std::to_string(t.shape(1)) + "] ";
    }
    EXPECT_EQ(inputs,
              "wo:FP32[-1,3] wi:FP32[-1,3] uv:FP32[-1,2] footprint:FP32[-1,4] "
              "position:FP32[-1,3] normal:FP32[-1,3] tangent:FP32[-1,3] ");
    ASSERT_EQ(md.outputs_size(), 1);
    EXPECT_EQ(md.outputs(0).name(), "radiance");
  }
  {
    grpc::ClientContext ctx;
    inference::ModelConfigRequest req;
    req.set_name("paint");
    inference::ModelConfigResponse config;
    ASSERT_TRUE(kserve_->ModelConfig(&ctx, req, &config).ok());
    EXPECT_EQ(config.config().name(), "paint");
    EXPECT_EQ(config.config().max_batch_size(), 0);
    ASSERT_EQ(config.config().input_size(), 6);  // lit: no wi
    EXPECT_EQ(config.config().input(0).name(), "wo");
    EXPECT_FALSE(config.config().input(0).optional());
    EXPECT_EQ(config.config().input(1).name(), "uv");
    EXPECT_TRUE(config.config().input(1).optional());
    EXPECT_EQ(config.config().input(1).data_type(), inference::TYPE_FP32);
    EXPECT_EQ(config.config().input(1).dims(0), -1);
    EXPECT_EQ(config.config().input(1).dims(1), 2);
  }
  auto stats = [](inference::InferStatistics *out) {
    grpc::ClientContext ctx;
    inference::ModelStatisticsRequest req;
    req.set_name("probe");
    inference::ModelStatisticsResponse r;
    ASSERT_TRUE(kserve_->ModelStatistics(&ctx, req, &r).ok());
    ASSERT_EQ(r.model_stats_size(), 1);
    *out = r.model_stats(0).inference_stats();
  };
  inference::InferStatistics before, after;
  stats(&before);
  Queries q = MakeQueries(10, true, false, 3);
  ModelInferResponse response;
  ASSERT_TRUE(Infer(InferRequest("probe", q, true), &response).ok());
  q.wi[0] = 2.0f;
  ASSERT_FALSE(Infer(InferRequest("probe", q, true), &response).ok());
  stats(&after);
  EXPECT_EQ(after.success().count(), before.success().count() + 1);
  EXPECT_EQ(after.fail().count(), before.fail().count() + 1);
  EXPECT_GT(after.compute_infer().ns(), before.compute_infer().ns());
}

// ModelInfer is admitted by the same per-query cost as Evaluate (server/request_cost.h), and
// refused with RESOURCE_EXHAUSTED and Evaluate's very message (naming --max-query-cost), with no
// output: under area_method REFERENCE at 1024 nodes the sparkle preset's rect light costs
// (4 x 256)^2 nodes x 3 fan triangles x the glint factor 8 = 2.5e7 BRDF evaluations a query and
// the quads preset's four quads 4 x 3 x 1024^2 = 1.26e7, both over the default --max-query-cost
// 1e7. At 64 nodes (1.6e5 and 4.9e4) both are served, bit-identical to Evaluate. Before,
// ModelInfer had no cost admission at all: it ran such a request (seconds a query) and a large
// batch of them held a worker for hours.
TEST(KServeAdmission, ModelInferIsAdmittedByCostAsEvaluate) {
  test::TempDir dir("kserve_admission");
  WriteQuads(dir.File("quads.json"));
  const std::string flags[2] = {
      "sparkle=" + kExamples + "/materials/sparkle_binomial.json," + kExamples +
          "/lights/rect_small.json",
      "quads=" + kExamples + "/materials/paint_schlick.json," + dir.File("quads.json")};
  std::string error;
  auto server = test::Glintd::Start(GLINTD_PATH, dir, "glintd",
                                    {"--model", flags[0], "--model", flags[1]}, &error);
  ASSERT_NE(server, nullptr) << error;
  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  auto kserve = GRPCInferenceService::NewStub(channel);
  auto glint = glint::v1::GlintService::NewStub(channel);
  const Queries q = MakeQueries(4, false, false, 13, kSparkleMirror);
  for (const std::string &flag : flags) {
    const std::string model = flag.substr(0, flag.find('='));
    KServeModel preset;
    ASSERT_TRUE(LoadModelFlag(flag, &preset).ok());
    for (const uint32_t nodes : {1024u, 64u}) {
      SCOPED_TRACE(model + ", " + std::to_string(nodes) + " nodes");
      glint::v1::EvaluateRequest settings = preset.settings;
      settings.set_area_method(glint::v1::REFERENCE);
      settings.set_area_samples(nodes);
      *settings.mutable_queries() = Batch(q);
      glint::v1::EvaluateResponse evaluated;
      grpc::ClientContext a;
      const grpc::Status want = glint->Evaluate(&a, settings, &evaluated);

      ModelInferRequest r = InferRequest(model, q, true);
      (*r.mutable_parameters())["area_method"].set_string_param("REFERENCE");
      (*r.mutable_parameters())["area_samples"].set_int64_param(nodes);
      ModelInferResponse response;
      grpc::ClientContext b;
      const grpc::Status got = kserve->ModelInfer(&b, r, &response);
      if (nodes == 1024) {
        ASSERT_EQ(want.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << want.error_message();
        EXPECT_NE(want.error_message().find("--max-query-cost"), std::string::npos)
            << want.error_message();
        EXPECT_EQ(got.error_code(), want.error_code()) << got.error_message();
        EXPECT_EQ(got.error_message(), want.error_message());
        EXPECT_EQ(response.outputs_size(), 0);
      } else {
        ASSERT_TRUE(want.ok()) << want.error_message();
        ASSERT_TRUE(got.ok()) << got.error_message();
        ASSERT_EQ(evaluated.radiance_size(), int(q.n) * 3);
        EXPECT_TRUE(
            SameBits(RawRadiance(response),
                     std::vector<float>(evaluated.radiance().begin(), evaluated.radiance().end())));
      }
    }
  }
}

// --max-request-cost counts ModelInfer's rows (wo's shape), as Evaluate counts its queries: the
// paint preset (three lights: 1 + 3 = 4 units per query) at --max-request-cost 1000 admits 250
// rows and refuses 251 (1004 units), before any tensor is decoded.
TEST(KServeAdmission, MaxRequestCostCountsTheRows) {
  test::TempDir dir("kserve_admission");
  const std::string paint =
      kExamples + "/materials/paint_schlick.json," + kExamples + "/lights/studio.json";
  std::string error;
  auto server =
      test::Glintd::Start(GLINTD_PATH, dir, "glintd",
                          {"--model", "paint=" + paint, "--max-request-cost", "1000"}, &error);
  ASSERT_NE(server, nullptr) << error;
  auto kserve = GRPCInferenceService::NewStub(
      grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials()));
  for (uint32_t n : {250u, 251u}) {
    grpc::ClientContext ctx;
    ModelInferResponse response;
    const grpc::Status s = kserve->ModelInfer(
        &ctx, InferRequest("paint", MakeQueries(n, false, false, 3), true), &response);
    if (n == 250) {
      EXPECT_TRUE(s.ok()) << s.error_message();
    } else {
      EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
      EXPECT_NE(s.error_message().find("(251 queries x 4 per query"), std::string::npos)
          << s.error_message();
      // The cost with the digits that tell it from the limit (at 3 digits both read 1e+03).
      EXPECT_NE(s.error_message().find("request cost: 1004 BRDF evaluations (251 queries"),
                std::string::npos)
          << s.error_message();
      EXPECT_NE(s.error_message().find("exceeds --max-request-cost 1e+03;"), std::string::npos)
          << s.error_message();
    }
  }
}

// A ModelInfer whose client has gone (deadline passed) stops at its next query slice, as
// Evaluate does, instead of running to the end for nobody. With one worker, a small call sent
// after it runs only once the worker is free, so by then the abandoned call has been recorded:
// as a failure when it stopped, as a success when it ran to the end (before: its slices never
// looked at the call). Judged from ModelStatistics, not from timings.
TEST(KServeAdmission, AnAbandonedModelInferStopsAtTheNextSlice) {
  test::TempDir dir("kserve_abandoned");
  const std::string sparkle =
      kExamples + "/materials/sparkle_binomial.json," + kExamples + "/lights/rect_small.json";
  const std::string paint =
      kExamples + "/materials/paint_schlick.json," + kExamples + "/lights/studio.json";
  std::string error;
  auto server = test::Glintd::Start(GLINTD_PATH, dir, "glintd",
                                    {"--model", "sparkle=" + sparkle, "--model", "paint=" + paint,
                                     "--workers", "1", "--slice-ms", "50"},
                                    &error);
  ASSERT_NE(server, nullptr) << error;
  auto kserve = GRPCInferenceService::NewStub(
      grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials()));
  auto reference = [](uint32_t n) {
    ModelInferRequest r =
        InferRequest("sparkle", MakeQueries(n, false, false, 17, kSparkleMirror), true);
    (*r.mutable_parameters())["area_method"].set_string_param("REFERENCE");
    (*r.mutable_parameters())["area_samples"].set_int64_param(256);
    return r;
  };
  ModelInferResponse response;
  {  // Compile the REFERENCE variant first: a compile is not sliced.
    grpc::ClientContext ctx;
    ASSERT_TRUE(kserve->ModelInfer(&ctx, reference(1), &response).ok());
  }
  auto stats = [&](const char *model) {
    grpc::ClientContext ctx;
    inference::ModelStatisticsRequest req;
    req.set_name(model);
    inference::ModelStatisticsResponse r;
    EXPECT_TRUE(kserve->ModelStatistics(&ctx, req, &r).ok());
    return r.model_stats_size() == 1 ? r.model_stats(0).inference_stats()
                                     : inference::InferStatistics();
  };
  const inference::InferStatistics before = stats("sparkle");
  // 1000 queries x ~1.6e6 units: 5-20 s of the worker at any load; the deadline passes
  // within its first second.
  {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(800));
    const grpc::Status s = kserve->ModelInfer(&ctx, reference(1000), &response);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << s.error_message();
  }
  {  // Queued behind the abandoned call on the one worker.
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(600));
    const grpc::Status s = kserve->ModelInfer(
        &ctx, InferRequest("paint", MakeQueries(8, false, false, 3), true), &response);
    ASSERT_TRUE(s.ok()) << s.error_message();
  }
  const inference::InferStatistics after = stats("sparkle");
  EXPECT_EQ(after.success().count(), before.success().count())
      << "the abandoned ModelInfer ran to its end";
  EXPECT_EQ(after.fail().count(), before.fail().count() + 1);
  EXPECT_TRUE(server->Alive());
}

// glintd's warm-up names the --model presets of a variant whose warm-up fails
// (tests/service/warmup_test.cpp AFailureNamesWhoNeedsTheVariant): PresetsUsing lists every
// preset whose ModelInfer requests use the variant, with its file(s), and none for a variant no
// preset uses. Two presets of one material share a variant (lights change it only by kind).
TEST(KServeStartup, PresetsUsingNamesEachPresetAndItsFiles) {
  const std::string paint = kExamples + "/materials/paint_schlick.json";
  const std::string studio = kExamples + "/lights/studio.json";
  const std::string sparkle = kExamples + "/materials/sparkle_binomial.json";
  const std::string rect = kExamples + "/lights/rect_small.json";
  std::vector<KServeModel> models(3);
  ASSERT_TRUE(LoadModelFlag("paint=" + paint + "," + studio, &models[0]).ok());
  ASSERT_TRUE(LoadModelFlag("paint2=" + paint + "," + studio, &models[1]).ok());
  ASSERT_TRUE(LoadModelFlag("sparkle=" + sparkle + "," + rect, &models[2]).ok());
  const KServeServiceImpl kserve(nullptr, models);
  const std::vector<KernelSpec> specs = kserve.WarmSpecs();
  ASSERT_EQ(specs.size(), 2u);
  EXPECT_EQ(kserve.PresetsUsing(specs[0]), "--model presets 'paint' (" + paint + "," + studio +
                                               "), 'paint2' (" + paint + "," + studio + ")");
  EXPECT_EQ(kserve.PresetsUsing(specs[1]),
            "--model preset 'sparkle' (" + sparkle + "," + rect + ")");
  KernelSpec other = specs[0];
  other.fp64 = !other.fp64;
  EXPECT_EQ(kserve.PresetsUsing(other), "");
}

TEST(KServeStartup, ABadPresetStopsGlintdNamingTheFile) {
  test::TempDir dir("kserve_startup");
  const std::string bad = dir.File("bad.json");
  std::ofstream(bad) << R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1})";
  std::string error;
  auto server = test::Glintd::Start(GLINTD_PATH, dir, "glintd", {"--model", "bad=" + bad}, &error);
  EXPECT_EQ(server, nullptr);
  EXPECT_NE(error.find("model 'bad' (" + bad + ")"), std::string::npos) << error;
}

// A NORMAL_MAP preset (Model::query_costs: the work of a query grows with its footprint's
// cut-off box) is admitted before queueing without a cost (its queries are not decoded yet),
// then on the worker by Evaluate's per-query cost once they are (server/request_cost.h
// EstimateQueriesCost). Over a 64 x 64 map at --max-query-cost 1e5, probes with footprints of
// 0.5 (32 texels: the 5-sigma box covers the map's period copies, 3.3e5 units a query; 0.2
// costs 8.5e4) are refused with RESOURCE_EXHAUSTED and Evaluate's very message; footprints of
// 1e-3 (a few texels, ~240 units) are served, bit-identical to Evaluate. Without the worker-side
// check the big footprints would run. No test reached that check before: no NORMAL_MAP preset could
// be registered (its map must be held when the preset is validated at startup, and the store starts
// empty) until glintd --normal-map FILE.
TEST(KServeAdmission, NormalMapQueriesAreAdmittedByTheirFootprintsOnceDecoded) {
  test::TempDir dir("kserve_normal_map");
  const NormalMapPreset nm = MakeNormalMapPreset(dir);
  std::string error;
  auto server = test::Glintd::Start(GLINTD_PATH, dir, "glintd",
                                    {"--normal-map", nm.map_file, "--model", "nm=" + nm.preset_file,
                                     "--max-query-cost", "1e5", "--device", "host"},
                                    &error);
  ASSERT_NE(server, nullptr) << error;
  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  auto kserve = GRPCInferenceService::NewStub(channel);
  auto glint = glint::v1::GlintService::NewStub(channel);
  KServeModel preset;
  ASSERT_TRUE(LoadModelFlag("nm=" + nm.preset_file, &preset).ok());
  for (const float footprint : {0.5f, 1e-3f}) {
    SCOPED_TRACE("footprint " + std::to_string(footprint));
    Queries q = MakeQueries(6, true, false, 21);
    for (size_t i = 0; i < q.footprint.size(); ++i)
      q.footprint[i] = i % 4 == 0 || i % 4 == 3 ? footprint : 0.0f;
    glint::v1::EvaluateRequest request = preset.settings;
    *request.mutable_queries() = Batch(q);
    glint::v1::EvaluateResponse evaluated;
    grpc::ClientContext a;
    const grpc::Status want = glint->Evaluate(&a, request, &evaluated);
    ModelInferResponse response;
    grpc::ClientContext b;
    const grpc::Status got = kserve->ModelInfer(&b, InferRequest("nm", q, true), &response);
    if (footprint > 0.1f) {
      ASSERT_EQ(want.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << want.error_message();
      EXPECT_NE(want.error_message().find("--max-query-cost 1e+05"), std::string::npos)
          << want.error_message();
      EXPECT_EQ(got.error_code(), want.error_code()) << got.error_message();
      EXPECT_EQ(got.error_message(), want.error_message());
      EXPECT_EQ(response.outputs_size(), 0);
    } else {
      ASSERT_TRUE(want.ok()) << want.error_message();
      ASSERT_TRUE(got.ok()) << got.error_message();
      EXPECT_TRUE(SameBits(RawRadiance(response), std::vector<float>(evaluated.radiance().begin(),
                                                                     evaluated.radiance().end())));
    }
  }
}

// A wo tensor whose shape does not describe its data is refused up front with INVALID_ARGUMENT
// naming wo, its shape and what it needs, before admission and the queue. Before, it was
// admitted as 0 queries and refused only by the decoder on a worker; with the queue full it was
// answered RESOURCE_EXHAUSTED "server busy ... retry later", a retry that could never succeed.
// With glintd's one worker held by a long call and --max-pending 1, a well-formed request is
// busy (the queue is full) while the lying one must be INVALID_ARGUMENT.
TEST(KServeAdmission, AShapeThatLiesAboutItsDataIsRefusedBeforeTheQueue) {
  test::TempDir dir("kserve_lying_shape");
  std::string error;
  auto server = test::Glintd::Start(
      GLINTD_PATH, dir, "glintd",
      {"--model",
       "sparkle=" + kExamples + "/materials/sparkle_binomial.json," + kExamples +
           "/lights/rect_small.json",
       "--model",
       "paint=" + kExamples + "/materials/paint_schlick.json," + kExamples + "/lights/studio.json",
       "--workers", "1", "--max-pending", "1", "--slice-ms", "50", "--metrics-listen",
       "127.0.0.1:0"},
      &error);
  ASSERT_NE(server, nullptr) << error;
  const int metrics_port = server->MetricsPort();  // --metrics-listen 127.0.0.1:0
  ASSERT_GT(metrics_port, 0) << server->Stderr();
  httplib::Client http("127.0.0.1", metrics_port);
  auto kserve = GRPCInferenceService::NewStub(
      grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials()));
  LongCall long_call(kserve.get());
  ASSERT_EQ(WaitForDepth(http, 1, [&] { return long_call.done(); }), 1);

  const Queries q = MakeQueries(250, false, false, 3);
  ModelInferResponse response;
  {
    grpc::ClientContext ctx;
    const grpc::Status s = kserve->ModelInfer(&ctx, InferRequest("paint", q, true), &response);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
    EXPECT_NE(s.error_message().find("server busy"), std::string::npos) << s.error_message();
  }
  for (bool raw : {true, false}) {
    SCOPED_TRACE(raw ? "raw" : "typed");
    ModelInferRequest lying = InferRequest("paint", q, raw);
    ASSERT_EQ(lying.inputs(0).name(), "wo");
    lying.mutable_inputs(0)->set_shape(0, 251);  // 251 rows claimed, 250 carried
    grpc::ClientContext ctx;
    const grpc::Status s = kserve->ModelInfer(&ctx, lying, &response);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
    EXPECT_NE(s.error_message().find(
                  raw ? "input 'wo': shape [251, 3] needs 3012 bytes, but its raw_input_contents "
                        "holds 3000 bytes (FP32 [250, 3])"
                      : "input 'wo': shape [251, 3] needs 753 values, but its "
                        "contents.fp32_contents holds 750 values (FP32 [250, 3])"),
              std::string::npos)
        << s.error_message();
  }
  EXPECT_FALSE(long_call.done()) << "the long call ended first, so the queue was not full";
  EXPECT_EQ(long_call.Cancel().error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_TRUE(server->Alive());
}

// ModelInfers queued behind a long call when SIGTERM arrives still run during --shutdown-grace,
// as every queued glint.v1 call does: only new calls are refused (UNAVAILABLE, "shutting down").
// One queued call is of the paint preset, one of a NORMAL_MAP preset (admitted again by cost on
// the worker once decoded): each fails if the worker checked shutdown admission again (as it
// did before, through GlintServiceImpl::Admit). Both must answer OK, bit-identical to Evaluate
// before the signal, and glintd must then exit 0.
TEST(KServeShutdown, ModelInfersQueuedBeforeSigtermRunInTheGrace) {
  test::TempDir dir("kserve_shutdown");
  const NormalMapPreset nm = MakeNormalMapPreset(dir);
  const std::string sparkle =
      kExamples + "/materials/sparkle_binomial.json," + kExamples + "/lights/rect_small.json";
  const std::string paint =
      kExamples + "/materials/paint_schlick.json," + kExamples + "/lights/studio.json";
  std::string error;
  auto server = test::Glintd::Start(
      GLINTD_PATH, dir, "glintd",
      {"--model", "sparkle=" + sparkle, "--model", "paint=" + paint, "--normal-map", nm.map_file,
       "--model", "nm=" + nm.preset_file, "--workers", "1", "--max-pending", "8", "--slice-ms",
       "50", "--shutdown-grace", "600", "--metrics-listen", "127.0.0.1:0"},
      &error);
  ASSERT_NE(server, nullptr) << error;
  const int metrics_port = server->MetricsPort();  // --metrics-listen 127.0.0.1:0
  ASSERT_GT(metrics_port, 0) << server->Stderr();
  httplib::Client http("127.0.0.1", metrics_port);
  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  auto kserve = GRPCInferenceService::NewStub(channel);
  auto glint = glint::v1::GlintService::NewStub(channel);

  struct Queued {
    std::string model, flag;
    Queries q;
    std::vector<float> reference;
    grpc::Status status;
    ModelInferResponse response;
  };
  Queued calls[2] = {{"paint", "paint=" + paint, MakeQueries(8, false, false, 3), {}, {}, {}},
                     {"nm", "nm=" + nm.preset_file, MakeQueries(8, true, false, 4), {}, {}, {}}};
  for (Queued &c : calls) {  // the references (and the kernels) before the long call
    KServeModel preset;
    ASSERT_TRUE(LoadModelFlag(c.flag, &preset).ok());
    glint::v1::EvaluateRequest request = preset.settings;
    *request.mutable_queries() = Batch(c.q);
    glint::v1::EvaluateResponse evaluated;
    grpc::ClientContext ctx;
    const grpc::Status s = glint->Evaluate(&ctx, request, &evaluated);
    ASSERT_TRUE(s.ok()) << c.model << ": " << s.error_message();
    c.reference.assign(evaluated.radiance().begin(), evaluated.radiance().end());
  }

  LongCall long_call(kserve.get());
  ASSERT_EQ(WaitForDepth(http, 1, [&] { return long_call.done(); }), 1);
  std::vector<std::thread> threads;
  for (Queued &c : calls) {
    threads.emplace_back([&kserve, &c] {
      grpc::ClientContext ctx;
      ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(600));
      c.status = kserve->ModelInfer(&ctx, InferRequest(c.model, c.q, true), &c.response);
    });
    const double want = double(threads.size()) + 1;
    // EXPECT and break, not ASSERT: returning here with joinable threads would std::terminate
    // the whole test binary; the checks below then fail and the threads are still joined.
    const double depth = WaitForDepth(http, want, [&] { return long_call.done(); });
    EXPECT_EQ(depth, want);
    if (depth != want) break;
  }

  server->Signal(SIGTERM);
  // Shutdown has begun once a new call is refused as shutting down. The probe is one that is
  // never queued either way: over --max-query-cost (RESOURCE_EXHAUSTED) until then.
  ModelInferRequest probe = InferRequest("sparkle", MakeQueries(1, false, false, 9), true);
  (*probe.mutable_parameters())["area_method"].set_string_param("REFERENCE");
  (*probe.mutable_parameters())["area_samples"].set_int64_param(1024);
  grpc::Status refused;
  for (int i = 0; i < 6000; ++i) {
    grpc::ClientContext ctx;
    ModelInferResponse unused;
    refused = kserve->ModelInfer(&ctx, probe, &unused);
    if (refused.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE) << refused.error_message();
  EXPECT_NE(refused.error_message().find("shutting down"), std::string::npos)
      << refused.error_message();
  EXPECT_FALSE(long_call.done()) << "the long call ended before shutdown began";
  long_call.Cancel();  // frees the worker for the queued calls, within the grace

  for (std::thread &t : threads) t.join();
  for (Queued &c : calls) {
    SCOPED_TRACE(c.model);
    ASSERT_TRUE(c.status.ok()) << c.status.error_message();
    EXPECT_TRUE(SameBits(RawRadiance(c.response), c.reference));
  }
  int status = 0;
  ASSERT_TRUE(server->WaitExit(std::chrono::seconds(60), &status));
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "wait status " << status;
}

}  // namespace
}  // namespace glint
