// The smooth model's host pass with lanes (models/smooth/host_lanes.cpp, `real` = GLINT_HOST_LANES
// queries, kernels/host_lanes.h) against the scalar host pass (models/smooth/host_passes.cpp):
// the same kernel headers and, with FMA contraction off, the same rounding of every operation, so
// the outputs must be bit-identical, for every specialisation, fp32 and fp64, batch sizes that
// are not multiples of the lane count, with accumulation, under any chunking, and at extreme
// directions (grazing, tiny cosines, wi = -wo). The physics of those headers is tested against
// independent references in tests/kernels; device against host in engine_test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "server/eval_plan.h"
#include "server/host_pass.h"
#include "test_queries.h"

GLINT_DECLARE_HOST_PASS(SmoothLights)
GLINT_DECLARE_HOST_PASS(SmoothLightsLanes)

namespace glint {
namespace {

v1::EvaluateRequest Settings(v1::Ndf ndf, int fresnel, bool lights, bool fp64) {
  v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::SMOOTH);
  m->set_ndf(ndf);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.08f);
  if (fresnel == 0) {
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  } else if (fresnel == 1) {
    for (float e : {0.2f, 0.4f, 1.4f}) m->mutable_conductor()->add_eta(e);
    for (float k : {3.9f, 2.4f, 1.8f}) m->mutable_conductor()->add_k(k);
  } else {
    m->mutable_dielectric()->set_ior(1.5f);
  }
  if (lights) {
    auto *d = r.add_lights()->mutable_directional();
    for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
    for (float v : {1.0f, 2.0f, 3.0f}) d->add_irradiance(v);
    auto *p = r.add_lights()->mutable_point();
    for (float v : {-1.0f, 2.0f, 3.0f}) p->add_position(v);
    for (float v : {5.0f, 5.0f, 4.0f}) p->add_intensity(v);
  }
  r.set_precision(fp64 ? v1::FP64 : v1::FP32);
  return r;
}

// The probe / light inputs of the pass (server/host_path.cpp fills the same fields), queries
// [first, first + count) of `q`.
HostInputs Inputs(const EvalPlan &plan, const v1::QueryBatch &q, uint32_t first, uint32_t count) {
  HostInputs in;
  in.ndf = plan.spec.ndf;
  in.fresnel = plan.spec.fresnel;
  in.probe = plan.spec.probe;
  in.has_frame = plan.spec.has_frame;
  in.has_directional = plan.spec.has_directional;
  in.has_point = plan.spec.has_point;
  in.n = count;
  auto at = [&](const auto &field) { return field.empty() ? nullptr : field.data() + 3 * first; };
  in.wo = at(q.wo());
  in.wi = at(q.wi());
  in.position = at(q.position());
  in.normal = at(q.normal());
  in.tangent = at(q.tangent());
  in.material = plan.material.data();
  in.directional = plan.directional.data();
  in.n_directional = plan.n_directional;
  in.point = plan.point.data();
  in.n_point = plan.n_point;
  return in;
}

// Appends probe pairs at the extremes: grazing and tiny cosines (down to subnormal), wi = -wo in
// the plane, normal incidence.
void AddExtremes(v1::QueryBatch *q, bool framed) {
  const float cosines[] = {1.0f, 0.5f, 1e-3f, 1e-12f, 1e-30f, 1e-38f, 1e-41f, 0.0f};
  uint32_t added = 0;
  for (float co : cosines)
    for (float ci : cosines) {
      const float so = std::sqrt(1.0f - co * co), si = std::sqrt(1.0f - ci * ci);
      for (float v : {so, 0.0f, co}) q->add_wo(v);
      for (float v : {-si, 0.0f, ci}) q->add_wi(v);
      ++added;
    }
  if (framed)
    for (uint32_t i = 0; i < added; ++i) {
      for (float v : {0.0f, 0.0f, 0.0f}) q->add_position(v);
      for (float v : {0.0f, 0.0f, 1.0f}) q->add_normal(v);
      for (float v : {1.0f, 0.0f, 0.0f}) q->add_tangent(v);
    }
  q->set_count(q->count() + added);
}

TEST(HostLanes, BitIdenticalToScalarHostPass) {
  uint32_t seed = 11;
  for (v1::Ndf ndf : {v1::GGX, v1::BECKMANN})
    for (int fresnel = 0; fresnel < 3; ++fresnel)
      for (bool probe : {true, false})
        for (bool framed : {false, true})
          for (bool fp64 : {false, true}) {
            v1::QueryBatch q = test::RandomQueries(1003, probe, framed, seed++);
            if (probe) AddExtremes(&q, framed);
            const v1::EvaluateRequest settings = Settings(ndf, fresnel, !probe, fp64);
            const EvalPlan plan = MakeEvalPlan(settings, q);
            const uint32_t n = q.count();
            const HostInputs in = Inputs(plan, q, 0, n);
            auto scalar_fn = fp64 ? SmoothLightsF64 : SmoothLightsF32;
            auto lanes_fn = fp64 ? SmoothLightsLanesF64 : SmoothLightsLanesF32;
            std::vector<float> scalar(3 * size_t(n), -1.0f), lanes(3 * size_t(n), -2.0f);
            scalar_fn(in, scalar.data(), false);
            lanes_fn(in, lanes.data(), false);
            const std::string what = plan.spec.Describe();
            int nonzero = 0;
            for (size_t i = 0; i < scalar.size(); ++i) {
              ASSERT_EQ(std::memcmp(&scalar[i], &lanes[i], sizeof(float)), 0)
                  << what << " query " << i / 3 << ": scalar " << scalar[i] << " lanes "
                  << lanes[i];
              nonzero += scalar[i] > 0.0f;
            }
            // Outputs of zeros everywhere would agree too: random frames put about half of the
            // lights behind the surface, hence the low bar.
            EXPECT_GT(nonzero, int(scalar.size()) / 20) << what;

            // Accumulation onto an earlier pass's output: the same float sums.
            std::vector<float> acc_s(scalar.size()), acc_l(scalar.size());
            for (size_t i = 0; i < acc_s.size(); ++i) acc_s[i] = acc_l[i] = 0.25f * float(i % 7);
            scalar_fn(in, acc_s.data(), true);
            lanes_fn(in, acc_l.data(), true);
            ASSERT_EQ(std::memcmp(acc_s.data(), acc_l.data(), 4 * acc_s.size()), 0) << what;

            // Chunks of sizes that are not multiples of the lane count (so every query sits in
            // another lane of another block): the same bits.
            std::vector<float> chunked(scalar.size(), -3.0f);
            for (uint32_t first = 0, k = 0; first < n; ++k) {
              const uint32_t count = std::min<uint32_t>(n - first, k % 2 ? 7 : 37);
              lanes_fn(Inputs(plan, q, first, count), chunked.data() + 3 * size_t(first), false);
              first += count;
            }
            ASSERT_EQ(std::memcmp(scalar.data(), chunked.data(), 4 * scalar.size()), 0) << what;
          }
}

// Batches smaller than one block and one past a block: the lanes past n are never stored.
TEST(HostLanes, OddSizesWriteExactlyTheirQueries) {
  for (bool fp64 : {false, true})
    for (uint32_t n : {1u, 2u, 7u, 8u, 9u, 15u, 16u, 17u, 33u}) {
      const v1::QueryBatch q = test::RandomQueries(n, true, false, 5 + n);
      const EvalPlan plan = MakeEvalPlan(Settings(v1::GGX, 1, false, fp64), q);
      const HostInputs in = Inputs(plan, q, 0, n);
      std::vector<float> scalar(3 * size_t(n) + 48, 7.0f), lanes(scalar.size(), 7.0f);
      (fp64 ? SmoothLightsF64 : SmoothLightsF32)(in, scalar.data(), false);
      (fp64 ? SmoothLightsLanesF64 : SmoothLightsLanesF32)(in, lanes.data(), false);
      ASSERT_EQ(std::memcmp(scalar.data(), lanes.data(), 4 * scalar.size()), 0) << n;
      for (size_t i = 3 * size_t(n); i < lanes.size(); ++i) ASSERT_EQ(lanes[i], 7.0f) << n;
    }
}

}  // namespace
}  // namespace glint
