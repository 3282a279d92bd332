// DeviceEngineOptions::ltc_only_programs (bench_models --quick): an LTC polygon plan's programs
// built for LTC alone (-DGLINT_AREA_ONLY, kernels/kernel_args.h) instead of the one program with
// every area method behind the runtime switch that glintd builds.
//  - which spec each engine builds: glintd's (the option off) never specialises; with it on, an
//    LTC polygon plan gets area_only = LTC, every other method (AUTO, which picks per query in
//    the kernel, included) the shared program, and plans without polygons are unchanged;
//  - the specialised program gives the shared one's radiance bit for bit (the constant only
//    removes the branches the argument did not take; the reference is the shared program, which
//    the rest of the suite checks against host and quadrature), for SMOOTH's 8-lane LTC pass and
//    CHERMAIN's one-query-per-item representative-point pass, whose shared program also holds
//    every per-query integrator. bench_area_programs found the same for SMOOTH LECOCQ,
//    LECOCQ_PEARSON and MONTE_CARLO with programs of those methods alone (session 15).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/model_table.h"
#include "server/validation.h"
#include "test_queries.h"
#include "tests/support/device_engine_fixture.h"

namespace glint {
namespace {

using glint::v1::EvaluateRequest;

class AreaOnly : public test::DeviceEngineTest {
 protected:
  static void SetUpTestSuite() {
    CreateEngine(1);
    DeviceEngineOptions o;
    const char *cache = std::getenv("GLINT_CACHE_DIR");
    o.cache_dir = cache ? cache : "";
    o.workers = 1;
    o.ltc_only_programs = true;
    Status s = DeviceEngine::Create(o, &specialised_);
    ASSERT_TRUE(s.ok()) << s.message();
  }
  static void TearDownTestSuite() {
    specialised_.reset();
    DeviceEngineTest::TearDownTestSuite();
  }
  static inline std::unique_ptr<DeviceEngine> specialised_;
};

void AddQuad(EvaluateRequest *r, const std::vector<float> &xyz) {
  auto *p = r->add_lights()->mutable_polygon();
  for (float v : xyz) p->add_vertices(v);
  for (float v : {1.0f, 0.7f, 0.4f}) p->add_radiance(v);
  p->set_two_sided(true);
}

// A validated request of `model` (its example material) under two two-sided quads, one overhead and
// one low to the side, on random queries without a frame (as bench_models).
EvaluateRequest Request(v1::Model model, v1::AreaMethod method, uint32_t samples) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(model);
  m->set_ndf(v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  v1::QueryBatch unused;
  if (const Model *entry = FindModel(model); entry && entry->example) entry->example(m, &unused);
  *r.mutable_queries() = test::RandomQueries(512, false, false, 7);
  AddQuad(&r, {-1, -1, 3, 1, -1, 3, 1, 1, 3, -1, 1, 3});
  AddQuad(&r, {2.5f, -1, 0.2f, 2.5f, 1, 0.2f, 2.5f, 1, 1.5f, 2.5f, -1, 1.5f});
  r.set_area_method(method);
  if (samples) r.set_area_samples(samples);
  if (method == v1::AUTO) r.set_max_relative_error(0.05f);
  r.set_precision(v1::FP32);
  ValidationLimits limits;
  Status s = ValidateSettings(r, limits);
  if (s.ok()) s = ValidateQueries(r.queries(), true, limits);
  if (s.ok()) s = ValidateQueriesForModel(r.queries(), r);
  EXPECT_TRUE(s.ok()) << s.message();
  return r;
}

TEST_F(AreaOnly, OnlyTheLtcPolygonPlansOfTheSpecialisingEngineGetLtcOnlyPrograms) {
  for (v1::AreaMethod method :
       {v1::LTC, v1::LECOCQ, v1::LECOCQ_PEARSON, v1::MONTE_CARLO, v1::REFERENCE, v1::AUTO}) {
    const EvaluateRequest r = Request(v1::SMOOTH, method, 0);
    const EvalPlan plan = MakeEvalPlan(r, r.queries());
    ASSERT_TRUE(plan.spec.has_polygon);
    EXPECT_EQ(plan.spec.area_only, -1) << "MakeEvalPlan never specialises";
    EXPECT_EQ(engine_->ProgramSpec(plan), plan.spec) << "glintd's engine: " << int(method);
    const KernelSpec spec = specialised_->ProgramSpec(plan);
    EXPECT_EQ(spec.area_only, method == v1::LTC ? GLINT_AREA_LTC : -1) << int(method);
    EXPECT_EQ(spec.BuildOptions().find("-DGLINT_AREA_ONLY=1") != std::string::npos,
              method == v1::LTC)
        << int(method);
  }
  EvaluateRequest probes = Request(v1::SMOOTH, v1::LTC, 0);
  probes.clear_lights();
  *probes.mutable_queries() = test::RandomQueries(4, true, false);
  const EvalPlan plan = MakeEvalPlan(probes, probes.queries());
  EXPECT_EQ(specialised_->ProgramSpec(plan), plan.spec) << "no polygons: nothing to specialise";
}

TEST_F(AreaOnly, LtcOnlyProgramsGiveTheSharedProgramsRadianceBitForBit) {
  struct Case {
    v1::Model model;
    v1::AreaMethod method;
    uint32_t samples;
  };
  for (const Case &c : {Case{v1::SMOOTH, v1::LTC, 0}, Case{v1::CHERMAIN, v1::LTC, 0}}) {
    const EvaluateRequest r = Request(c.model, c.method, c.samples);
    EvalPlan plan = MakeEvalPlan(r, r.queries());
    ASSERT_TRUE(ResolveRequestTable(r.material(), &plan).ok());
    const size_t floats = 3 * size_t(r.queries().count());
    std::vector<float> generic(floats, -1.0f), only(floats, -2.0f);
    Status s = engine_->Evaluate(0, plan, r.queries(), generic.data());
    ASSERT_TRUE(s.ok()) << s.message();
    s = specialised_->Evaluate(0, plan, r.queries(), only.data());
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(std::memcmp(generic.data(), only.data(), floats * sizeof(float)), 0)
        << "model " << int(c.model) << ", area method " << int(c.method);
    double sum = 0;
    for (float v : generic) sum += v;
    EXPECT_GT(sum, 0.0) << "the lights must reach some queries, or the comparison shows nothing";
  }
}

}  // namespace
}  // namespace glint
