// Dynamic batching, evaluation half (server/batch_eval.h): requests of one batch key evaluated
// in one launch get, each, exactly the bits they get on their own (DESIGN.md "Determinism"),
// on the OpenCL device and on the host path, for every model and the stochastic area method;
// the scatter gives every request its own rows (the requests' queries differ, so a shifted or
// swapped range cannot match); one member's cancellation, before or during the launch, leaves
// the others' results whole; the launch stops early only when every member has stopped. The
// batch key separates every setting the kernels see.
#include "server/batch_eval.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "model_test_settings.h"
#include "server/model_table.h"
#include "test_queries.h"

namespace {

namespace v1 = glint::v1;

v1::EvaluateRequest Settings(v1::Model model, bool polygon_mc) {
  v1::EvaluateRequest r = glint::test::ModelTestSettings(model, polygon_mc);
  return r;
}

// Member k: its own queries (seed 100 + k) and its own count.
std::vector<v1::QueryBatch> MemberQueries(int members) {
  std::vector<v1::QueryBatch> q;
  for (int k = 0; k < members; ++k)
    q.push_back(glint::test::RandomQueries(uint32_t(37 + 29 * k), false, false, uint32_t(100 + k)));
  return q;
}

class BatchEval : public ::testing::TestWithParam<bool> {  // true: OpenCL device
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
std::unique_ptr<glint::DeviceEngine> BatchEval::engine_;

// Each member alone, one slice, as the unbatched server path does.
std::vector<float> Alone(glint::DeviceEngine *engine, const glint::EvalPlan &plan,
                         const v1::QueryBatch &q) {
  std::vector<float> out(size_t(q.count()) * 3);
  glint::SliceOptions one;
  one.per_query_cost = 1e-9;
  EXPECT_TRUE(glint::EvaluateSliced(engine, 0, plan, q, out.data(), one).ok());
  return out;
}

TEST_P(BatchEval, EveryMemberGetsTheBitsItGetsAlone) {
  for (const glint::Model *model : glint::Models()) {
    for (bool mc : {false, true}) {
      if (mc && model->id != v1::SMOOTH) continue;
      if (model->request_table) continue;  // NORMAL_MAP needs an uploaded map
      const v1::EvaluateRequest settings = Settings(model->id, mc);
      const std::vector<v1::QueryBatch> queries = MemberQueries(5);
      const glint::EvalPlan plan = glint::MakeEvalPlan(settings, queries[0]);
      std::vector<std::vector<float>> out(queries.size());
      std::vector<glint::BatchPart> parts;
      for (size_t k = 0; k < queries.size(); ++k) {
        out[k].assign(size_t(queries[k].count()) * 3, -1.0f);
        parts.push_back({&queries[k], out[k].data(), {}, glint::Status::Ok()});
      }
      for (uint32_t slice : {0u, 23u}) {  // one launch; and many slices across member bounds
        glint::SliceOptions slicing;
        slicing.max_slice_queries = slice;
        glint::BatchStats stats;
        ASSERT_TRUE(glint::EvaluateBatched(engine(), 0, plan, &parts, slicing, &stats).ok());
        EXPECT_EQ(stats.evaluated_parts, 5);
        EXPECT_EQ(stats.queries, 37u * 5 + 29u * 10);
        for (size_t k = 0; k < queries.size(); ++k) {
          ASSERT_TRUE(parts[k].status.ok()) << parts[k].status.message();
          const std::vector<float> alone = Alone(engine(), plan, queries[k]);
          ASSERT_EQ(std::memcmp(out[k].data(), alone.data(), alone.size() * sizeof(float)), 0)
              << model->name << (mc ? " MONTE_CARLO" : "") << " member " << k
              << " max_slice_queries " << slice;
        }
      }
    }
  }
}

// Member 1 is cancelled before the launch (never evaluated, output untouched); member 3 is
// cancelled after the first slice (its client is gone: no result); the others are whole.
TEST_P(BatchEval, OneMembersCancellationLeavesTheOthersWhole) {
  const v1::EvaluateRequest settings = Settings(v1::SMOOTH, false);
  const std::vector<v1::QueryBatch> queries = MemberQueries(5);
  const glint::EvalPlan plan = glint::MakeEvalPlan(settings, queries[0]);
  std::vector<std::vector<float>> out(queries.size());
  std::vector<glint::BatchPart> parts;
  std::atomic<int> checks{0};
  for (size_t k = 0; k < queries.size(); ++k) {
    out[k].assign(size_t(queries[k].count()) * 3, -1.0f);
    parts.push_back({&queries[k], out[k].data(), {}, glint::Status::Ok()});
  }
  parts[1].stop = [] { return glint::Status::Cancelled("member 1 cancelled"); };
  // OK at the launch's start, cancelled from the first slice boundary on.
  parts[3].stop = [&checks] {
    return ++checks > 1 ? glint::Status::Cancelled("member 3 cancelled") : glint::Status::Ok();
  };
  glint::SliceOptions slicing;
  slicing.max_slice_queries = 50;
  slicing.target_ms = 1e12;  // exactly 50 each: a slow slice must not shrink the next ones
  glint::BatchStats stats;
  ASSERT_TRUE(glint::EvaluateBatched(engine(), 0, plan, &parts, slicing, &stats).ok());
  EXPECT_EQ(stats.evaluated_parts, 4);
  const uint32_t launched = stats.queries;
  EXPECT_EQ(launched, 37u * 4 + 29u * 9);  // all but member 1 (66 queries)
  EXPECT_EQ(stats.slices, int((launched + 49) / 50)) << "the launch ran to its end";
  EXPECT_EQ(parts[1].status.code(), glint::Status::Code::kCancelled);
  EXPECT_EQ(parts[3].status.code(), glint::Status::Code::kCancelled);
  for (float v : out[1]) ASSERT_EQ(v, -1.0f);
  for (size_t k : {0, 2, 4}) {
    ASSERT_TRUE(parts[k].status.ok()) << k;
    const std::vector<float> alone = Alone(engine(), plan, queries[k]);
    ASSERT_EQ(std::memcmp(out[k].data(), alone.data(), alone.size() * sizeof(float)), 0) << k;
  }
}

// Every member stopped after the first slice: the launch stops there (one slice run, not nine).
TEST_P(BatchEval, TheLaunchStopsWhenEveryMemberHasStopped) {
  const v1::EvaluateRequest settings = Settings(v1::SMOOTH, false);
  const std::vector<v1::QueryBatch> queries = MemberQueries(3);
  const glint::EvalPlan plan = glint::MakeEvalPlan(settings, queries[0]);
  std::vector<std::vector<float>> out(queries.size());
  std::vector<glint::BatchPart> parts;
  std::atomic<bool> started{false};
  for (size_t k = 0; k < queries.size(); ++k) {
    out[k].assign(size_t(queries[k].count()) * 3, -1.0f);
    parts.push_back({&queries[k], out[k].data(),
                     [&started] {
                       return started ? glint::Status::DeadlineExceeded("deadline")
                                      : glint::Status::Ok();
                     },
                     glint::Status::Ok()});
  }
  glint::SliceOptions slicing;
  slicing.max_slice_queries = 20;
  // The server's own check runs first at every boundary: flips the members after slice 1.
  int boundaries = 0;
  slicing.stop = [&] {
    if (++boundaries == 2) started = true;
    return glint::Status::Ok();
  };
  glint::BatchStats stats;
  glint::Status s = glint::EvaluateBatched(engine(), 0, plan, &parts, slicing, &stats);
  EXPECT_EQ(s.code(), glint::Status::Code::kDeadlineExceeded);
  EXPECT_EQ(stats.slices, 1);
  for (const glint::BatchPart &p : parts)
    EXPECT_EQ(p.status.code(), glint::Status::Code::kDeadlineExceeded);
}

std::string PathName(const ::testing::TestParamInfo<bool> &p) {
  return p.param ? "device" : "host";
}
INSTANTIATE_TEST_SUITE_P(DeviceAndHost, BatchEval, ::testing::Values(true, false), PathName);

TEST(BatchKey, EqualForEqualSettingsDifferentForAnySettingTheKernelsSee) {
  v1::EvaluateRequest a = Settings(v1::SMOOTH, true);
  *a.mutable_queries() = glint::test::RandomQueries(10, false, false, 1);
  v1::EvaluateRequest b = a;
  *b.mutable_queries() = glint::test::RandomQueries(20, false, false, 2);
  EXPECT_EQ(glint::BatchKey(a), glint::BatchKey(b)) << "queries are not part of the key";
  const std::string key = glint::BatchKey(a);
  std::vector<std::pair<const char *, std::function<void(v1::EvaluateRequest *)>>> changes = {
      {"material.alpha_x",
       [](v1::EvaluateRequest *r) { r->mutable_material()->set_alpha_x(0.31f); }},
      {"material.model",
       [](v1::EvaluateRequest *r) { r->mutable_material()->set_model(v1::KEMPPINEN); }},
      {"material.ndf",
       [](v1::EvaluateRequest *r) { r->mutable_material()->set_ndf(v1::BECKMANN); }},
      {"lights",
       [](v1::EvaluateRequest *r) { r->mutable_lights(0)->mutable_point()->set_radius(0.3f); }},
      {"another light", [](v1::EvaluateRequest *r) { *r->add_lights() = r->lights(0); }},
      {"precision", [](v1::EvaluateRequest *r) { r->set_precision(v1::FP64); }},
      {"seed", [](v1::EvaluateRequest *r) { r->set_seed(12346); }},
      {"area_method", [](v1::EvaluateRequest *r) { r->set_area_method(v1::REFERENCE); }},
      {"area_samples", [](v1::EvaluateRequest *r) { r->set_area_samples(17); }},
      {"queries.wi present",
       [](v1::EvaluateRequest *r) {
         *r->mutable_queries() = glint::test::RandomQueries(10, true, false, 1);
       }},
      {"queries framed",
       [](v1::EvaluateRequest *r) {
         *r->mutable_queries() = glint::test::RandomQueries(10, false, true, 1);
       }},
      {"queries.uv absent", [](v1::EvaluateRequest *r) { r->mutable_queries()->clear_uv(); }},
  };
  for (const auto &[what, change] : changes) {
    v1::EvaluateRequest c = a;
    change(&c);
    EXPECT_NE(glint::BatchKey(c), key) << what;
  }
}

TEST(BatchKey, OnlySmallInlineRequestsAreBatchable) {
  v1::EvaluateRequest r = Settings(v1::SMOOTH, false);
  *r.mutable_queries() = glint::test::RandomQueries(64, false, false, 1);
  EXPECT_TRUE(glint::Batchable(r, 128));
  EXPECT_FALSE(glint::Batchable(r, 127)) << "more than half a batch";
  v1::EvaluateRequest empty = r;
  empty.mutable_queries()->set_count(0);
  empty.mutable_queries()->clear_wo();
  EXPECT_FALSE(glint::Batchable(empty, 128));
  v1::EvaluateRequest short_wo = r;
  short_wo.mutable_queries()->mutable_wo()->RemoveLast();
  EXPECT_FALSE(glint::Batchable(short_wo, 128)) << "left to validation, alone";
  v1::EvaluateRequest no_wo = r;
  no_wo.mutable_queries()->clear_wo();
  EXPECT_FALSE(glint::Batchable(no_wo, 128)) << "queries not inline";
}

}  // namespace
