// Work-group sizes below the configured one (server/work_group_size.h): a device whose limits
// are smaller than DeviceEngineOptions::local_size, imposed on PoCL with max_local_size 1, 3 (not
// a power of two) and 7, must give every model's results bit for bit as the default size does,
// for probes, each light kind (directional, point, polygon by LTC and by MONTE_CARLO, whose random
// numbers depend on the query) and the sample pass; and the cap must be what the launches used.
// Every work-item evaluates its own queries from its global index alone (kernels/work_item.h;
// no kernel uses local memory or barriers), so the grouping cannot change a bit.
//
// The cost is PoCL compiling a work-group function per kernel and size (half to all of the
// kernel's first compile: 2-35 s per kernel and size for the glint models on the loaded 2-core
// VM), so ctest runs a subset: SMOOTH at every cap with probes, directional + point, a quad by
// LTC and the sample pass; each glint model at cap 3 with the sphere light of
// model_test_settings.h (the variant the sliced and batched evaluation tests build too) and its
// sample pass (session 20, cold kernel cache, ctest -j2, load ~5: 15-60 s per model).
// GLINT_WORK_GROUP_ALL=1 runs every cap, light kind (MONTE_CARLO included) and the sample pass
// for every model (session 20, load ~5: SMOOTH 58 s, BINOMIAL 310 s, CHERMAIN 445 s, KEMPPINEN
// 258 s, NORMAL_MAP 153 s; all passed).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "model_test_settings.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_pass.h"
#include "server/model_table.h"
#include "test_queries.h"

namespace {

namespace v1 = glint::v1;

constexpr size_t kCaps[] = {0, 1, 3, 7};  // 0: the default (no cap)

bool All() {
  const char *all = std::getenv("GLINT_WORK_GROUP_ALL");
  return all && std::string(all) == "1";
}

// 5000 queries: several work-groups at the default size (313 work-items of 16 probe queries,
// 79 of BINOMIAL's 4 x 16 lights queries in groups of 32), none a multiple of the lanes.
constexpr uint32_t kQueries = 5000;

// The light kinds of one plan each: a probe batch, directional + point (one punctual kernel),
// a quad by LTC, a quad by MONTE_CARLO beside the sphere light, the sphere light alone.
enum class Lights { kProbe, kPunctual, kPolygonLtc, kPolygonMc, kPoint };

v1::EvaluateRequest Request(v1::Model model, Lights lights) {
  v1::EvaluateRequest r = glint::test::ModelTestSettings(model, lights == Lights::kPolygonMc);
  if (lights == Lights::kProbe) r.clear_lights();
  if (lights == Lights::kPunctual) {
    auto *d = r.add_lights()->mutable_directional();
    for (float v : {0.3f, 0.2f, 0.9f}) d->add_direction(v);
    for (float v : {2.0f, 2.0f, 2.0f}) d->add_irradiance(v);
    d->set_cone_half_angle_deg(2.0f);
  }
  if (lights == Lights::kPolygonLtc) {
    r.clear_lights();
    auto *q = r.add_lights()->mutable_polygon();
    for (float v : {-1.0f, -1.0f, 2.0f, 1.0f, -1.0f, 2.0f, 1.0f, 1.0f, 2.0f, -1.0f, 1.0f, 2.0f})
      q->add_vertices(v);
    for (float v : {1.0f, 1.0f, 1.0f}) q->add_radiance(v);
    q->set_two_sided(true);
    r.set_area_method(v1::LTC);
  }
  *r.mutable_queries() = glint::test::RandomQueries(kQueries, lights == Lights::kProbe, false, 5);
  return r;
}

const char *Name(Lights l) {
  switch (l) {
    case Lights::kProbe:
      return "probe";
    case Lights::kPunctual:
      return "directional + point";
    case Lights::kPolygonLtc:
      return "quad LTC";
    case Lights::kPolygonMc:
      return "quad MONTE_CARLO + point";
    case Lights::kPoint:
      return "point";
  }
  return "?";
}

class WorkGroupSize : public ::testing::TestWithParam<v1::Model> {
 protected:
  // One single-queue engine per cap, on the suite's program cache (each program compiles once,
  // the others load it; PoCL still compiles a work-group function per kernel and size).
  static void SetUpTestSuite() {
    for (size_t cap : kCaps) {
      glint::DeviceEngineOptions o;
      o.workers = 1;
      o.max_local_size = cap;
      if (const char *d = std::getenv("GLINT_CACHE_DIR")) o.cache_dir = d;
      std::unique_ptr<glint::DeviceEngine> e;
      glint::Status s = glint::DeviceEngine::Create(o, &e);
      ASSERT_TRUE(s.ok()) << s.message();
      engines_.push_back(std::move(e));
    }
  }
  static void TearDownTestSuite() { engines_.clear(); }

  // Runs `run` on the default engine and those of `caps`: the outputs must equal the default's
  // bit for bit, and each capped launch must have used the cap. A glint model's probes may all
  // be 0 (BINOMIAL's), so `nonzero` is asked of the other batches only.
  template <class Run>
  void ExpectSameUnderEveryCap(const std::string &what, size_t floats,
                               const std::vector<size_t> &caps, bool nonzero, Run run) {
    std::vector<std::vector<float>> out(std::size(kCaps), std::vector<float>(floats, -1.0f));
    std::vector<std::vector<size_t>> used(std::size(kCaps));
    for (size_t c = 0; c < std::size(kCaps); ++c) {
      if (c > 0 && std::find(caps.begin(), caps.end(), kCaps[c]) == caps.end()) continue;
      glint::Status s = run(*engines_[c], out[c].data());
      ASSERT_TRUE(s.ok()) << what << ", cap " << kCaps[c] << ": " << s.message();
      used[c] = engines_[c]->LastLaunchLocalSizes(0);
    }
    ASSERT_FALSE(used[0].empty()) << what;
    double positive = 0;
    for (float v : out[0]) positive += v > 0;
    if (nonzero) {
      EXPECT_GT(positive, 0) << what << ": the comparison is not between zero arrays";
    }
    for (size_t c = 1; c < std::size(kCaps); ++c) {
      if (used[c].empty()) continue;  // a cap not run
      EXPECT_EQ(0, std::memcmp(out[0].data(), out[c].data(), floats * sizeof(float)))
          << what << ", cap " << kCaps[c];
      ASSERT_EQ(used[c].size(), used[0].size()) << what << ", cap " << kCaps[c];
      for (size_t k = 0; k < used[0].size(); ++k) {
        EXPECT_GT(used[0][k], kCaps[c]) << what << ": the default is above every cap";
        EXPECT_EQ(used[c][k], std::min(used[0][k], kCaps[c])) << what << ", launch " << k;
      }
    }
  }

  static inline std::vector<std::unique_ptr<glint::DeviceEngine>> engines_;
};

TEST_P(WorkGroupSize, CappedWorkGroupsGiveTheDefaultsBits) {
  const v1::Model model = GetParam();
  const bool every = All() || model == v1::SMOOTH;
  const std::vector<size_t> caps = every ? std::vector<size_t>{1, 3, 7} : std::vector<size_t>{3};
  std::vector<Lights> kinds = {Lights::kPoint};
  if (every) kinds = {Lights::kProbe, Lights::kPunctual, Lights::kPolygonLtc};
  if (All()) kinds.push_back(Lights::kPolygonMc);
  for (Lights lights : kinds) {
    const v1::EvaluateRequest r = Request(model, lights);
    glint::EvalPlan plan = glint::MakeEvalPlan(r, r.queries());
    ASSERT_TRUE(glint::ResolveRequestTable(r.material(), &plan).ok());
    ExpectSameUnderEveryCap(
        Name(lights), size_t(kQueries) * 3, caps, lights != Lights::kProbe,
        [&](glint::DeviceEngine &e, float *out) { return e.Evaluate(0, plan, r.queries(), out); });
  }
  const glint::Model *m = glint::FindModel(model);
  if (!m->sample.kernel_file) return;
  v1::EvaluateRequest r = Request(model, Lights::kProbe);
  r.mutable_queries()->clear_wi();  // a sample request's incident directions are its output
  glint::EvalPlan plan = glint::MakeEvalPlan(r, r.queries());
  ASSERT_TRUE(glint::ResolveRequestTable(r.material(), &plan).ok());
  const uint32_t k = 3;
  ExpectSameUnderEveryCap(
      "sample", size_t(kQueries) * k * glint::kSampleFloats, caps, true,
      [&](glint::DeviceEngine &e, float *out) { return e.Sample(0, plan, r.queries(), k, out); });
}

// A configured size above what PoCL's device takes (CL_DEVICE_MAX_WORK_GROUP_SIZE 4096, and each
// kernel's CL_KERNEL_WORK_GROUP_SIZE) is lowered to the device's own limit, read from the device,
// not refused by clEnqueueNDRangeKernel (CL_INVALID_WORK_GROUP_SIZE before the limits were
// asked): a real device limit, where the tests above impose theirs.
TEST(WorkGroupSizeDevice, AConfiguredSizeAboveTheDevicesLimitRunsAtTheLimit) {
  std::unique_ptr<glint::DeviceEngine> engine[2];
  for (int i = 0; i < 2; ++i) {
    glint::DeviceEngineOptions o;
    o.workers = 1;
    o.local_size = i == 0 ? 128 : 65534;  // the largest DeviceEngine::Create accepts
    if (const char *d = std::getenv("GLINT_CACHE_DIR")) o.cache_dir = d;
    glint::Status s = glint::DeviceEngine::Create(o, &engine[i]);
    ASSERT_TRUE(s.ok()) << s.message();
  }
  size_t device_max = 0;
  ASSERT_EQ(CL_SUCCESS,
            clGetDeviceInfo(engine[0]->runtime().device(), CL_DEVICE_MAX_WORK_GROUP_SIZE,
                            sizeof device_max, &device_max, nullptr));
  size_t item_max[3] = {0, 0, 0};
  ASSERT_EQ(CL_SUCCESS,
            clGetDeviceInfo(engine[0]->runtime().device(), CL_DEVICE_MAX_WORK_ITEM_SIZES,
                            sizeof item_max, item_max, nullptr));
  device_max = std::min(device_max, item_max[0]);
  if (device_max >= 65534) GTEST_SKIP() << "the device takes groups of " << device_max;
  const v1::EvaluateRequest r = Request(v1::SMOOTH, Lights::kProbe);
  const glint::EvalPlan plan = glint::MakeEvalPlan(r, r.queries());
  std::vector<float> out[2];
  for (int i = 0; i < 2; ++i) {
    out[i].assign(size_t(kQueries) * 3, -1.0f);
    glint::Status s = engine[i]->Evaluate(0, plan, r.queries(), out[i].data());
    ASSERT_TRUE(s.ok()) << "local_size " << (i ? 65534 : 128) << ": " << s.message();
  }
  EXPECT_EQ(0, std::memcmp(out[0].data(), out[1].data(), out[0].size() * sizeof(float)));
  const std::vector<size_t> used = engine[1]->LastLaunchLocalSizes(0);
  ASSERT_EQ(used.size(), 1u);
  // Exactly the device's limit: PoCL's kernels report CL_KERNEL_WORK_GROUP_SIZE equal to it. An
  // engine that ignored the limits and halved after each refused enqueue would land on 4095
  // (65534 / 16), not 4096, and fail here.
  EXPECT_EQ(used[0], device_max);
}

// Listed, not read from Models() during static initialisation; the next test keeps the list whole.
constexpr v1::Model kModels[] = {v1::SMOOTH, v1::BINOMIAL, v1::CHERMAIN, v1::KEMPPINEN,
                                 v1::NORMAL_MAP};

INSTANTIATE_TEST_SUITE_P(EveryModel, WorkGroupSize, ::testing::ValuesIn(kModels),
                         [](const ::testing::TestParamInfo<v1::Model> &param) {
                           return std::string(glint::FindModel(param.param)->name);
                         });

TEST(WorkGroupSizeModels, TheListHoldsEveryModelOfTheTable) {
  EXPECT_EQ(std::size(kModels), glint::Models().size());
  for (const glint::Model *m : glint::Models())
    EXPECT_NE(std::find(std::begin(kModels), std::end(kModels), m->id), std::end(kModels))
        << m->name;
}

}  // namespace
