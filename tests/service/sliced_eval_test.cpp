// Query slices (server/sliced_eval.h): a request evaluated in many small slices is bit-identical
// to the same request in one call, on the OpenCL device and on the host path, for every model
// and the stochastic area method (their random numbers come from each query's own inputs, never
// its index). The stop check runs before every slice, the first included: a stop there does no
// work at all, a stop later leaves the remaining queries unwritten.
#include "server/sliced_eval.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "model_test_settings.h"
#include "server/model_table.h"
#include "test_queries.h"

namespace {

namespace v1 = glint::v1;

v1::EvaluateRequest Request(v1::Model model, bool polygon_mc) {
  v1::EvaluateRequest r = glint::test::ModelTestSettings(model, polygon_mc);
  *r.mutable_queries() = glint::test::RandomQueries(1001, false, false, 3);
  return r;
}

class SlicedEval : public ::testing::TestWithParam<bool> {  // true: OpenCL device
 protected:
  static void SetUpTestSuite() {
    glint::DeviceEngineOptions o;
    o.workers = 1;
    if (const char *d = std::getenv("GLINT_CACHE_DIR")) o.cache_dir = d;
    glint::Status s = glint::DeviceEngine::Create(o, &engine_);
    ASSERT_TRUE(s.ok()) << s.message();
  }
  static void TearDownTestSuite() { engine_.reset(); }
  glint::DeviceEngine *engine() const { return GetParam() ? engine_.get() : nullptr; }
  static std::unique_ptr<glint::DeviceEngine> engine_;
};
std::unique_ptr<glint::DeviceEngine> SlicedEval::engine_;

TEST_P(SlicedEval, ManySlicesAreBitIdenticalToOneCall) {
  for (const glint::Model *model : glint::Models()) {
    for (bool mc : {false, true}) {
      if (mc && model->id != v1::SMOOTH) continue;  // kernel variants the server warms anyway
      // NORMAL_MAP needs an uploaded map (Model::request_table); its chunking is checked
      // bit for bit in models/normal_map/tests/normal_map_engine_test.cpp.
      if (model->request_table) continue;
      const v1::EvaluateRequest r = Request(model->id, mc);
      const glint::EvalPlan plan = glint::MakeEvalPlan(r, r.queries());
      const uint32_t n = r.queries().count();
      std::vector<float> whole(size_t(n) * 3), sliced(size_t(n) * 3, -1.0f);
      glint::SliceOptions one;
      one.per_query_cost = 1e-9;  // one slice
      glint::SliceStats one_stats;
      glint::Status s =
          glint::EvaluateSliced(engine(), 0, plan, r.queries(), whole.data(), one, &one_stats);
      ASSERT_TRUE(s.ok()) << s.message();
      ASSERT_EQ(one_stats.slices, 1);
      glint::SliceOptions many;
      many.max_slice_queries = 37;  // not a multiple of the 8 SIMD lanes
      many.target_ms = 1e12;        // exactly 37 each, however slow a slice (see below)
      glint::SliceStats stats;
      s = glint::EvaluateSliced(engine(), 0, plan, r.queries(), sliced.data(), many, &stats);
      ASSERT_TRUE(s.ok()) << s.message();
      EXPECT_EQ(stats.slices, int((n + 36) / 37));
      EXPECT_EQ(0, std::memcmp(whole.data(), sliced.data(), whole.size() * sizeof(float)))
          << model->name << (mc ? " with MONTE_CARLO polygon" : "");
      double positive = 0;
      for (float v : whole) positive += v > 0;
      EXPECT_GT(positive, 0) << model->name;  // the comparison is not between two zero arrays
    }
  }
}

TEST_P(SlicedEval, StopIsCheckedBeforeEverySliceTheFirstIncluded) {
  const v1::EvaluateRequest r = Request(v1::SMOOTH, false);
  const glint::EvalPlan plan = glint::MakeEvalPlan(r, r.queries());
  const uint32_t n = r.queries().count();
  for (int stop_at : {0, 3}) {  // the check before slice 0 (expired work), before slice 3
    std::vector<float> out(size_t(n) * 3, -7.0f);
    int checks = 0;
    glint::SliceOptions o;
    o.max_slice_queries = 100;
    // Slices of exactly 100: with the default target a slow first slice (the process's first
    // launch, a loaded machine) makes the measured rate ask for smaller ones, and the stop
    // would then fall after fewer than stop_at * 100 queries.
    o.target_ms = 1e12;
    o.stop = [&]() -> glint::Status {
      return checks++ == stop_at ? glint::Status::DeadlineExceeded("deadline") : glint::Status();
    };
    // The abandoned-work hook (server/abandoned_work.h): once, with the stop's status and the
    // queries from the slice not started to the end, by the explicit count of slices run.
    int reported = 0;
    uint32_t not_run = 0;
    o.on_stop = [&](const glint::Status &stop, uint32_t queries) {
      ++reported;
      not_run = queries;
      EXPECT_EQ(stop.code(), glint::Status::Code::kDeadlineExceeded);
    };
    glint::Status s = glint::EvaluateSliced(engine(), 0, plan, r.queries(), out.data(), o);
    EXPECT_EQ(s.code(), glint::Status::Code::kDeadlineExceeded);
    EXPECT_EQ(checks, stop_at + 1);
    EXPECT_EQ(reported, 1);
    EXPECT_EQ(not_run, n - uint32_t(stop_at) * 100);
    // Slices before the stop wrote their queries; nothing after it was evaluated.
    const size_t written = size_t(stop_at) * 100 * 3;
    for (size_t i = 0; i < out.size(); ++i) {
      if (i < written) {
        ASSERT_NE(out[i], -7.0f) << "query " << i / 3 << " should have been evaluated";
      } else {
        ASSERT_EQ(out[i], -7.0f) << "query " << i / 3 << " evaluated after the stop";
      }
    }
  }
}

std::string PathName(const ::testing::TestParamInfo<bool> &p) {
  return p.param ? "Device" : "Host";
}
INSTANTIATE_TEST_SUITE_P(DeviceAndHost, SlicedEval, ::testing::Values(true, false), PathName);

}  // namespace
