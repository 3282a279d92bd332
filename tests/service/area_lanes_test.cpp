// The 8-lane LTC pass of the smooth model (models/smooth/smooth_area_lanes.cl: 8 queries per
// work-item, branch-free clipping with per-lane vertex counts, kernels/area/area_ltc.h) on the
// OpenCL device:
//  - a query's result must not depend on which queries share its work-item: the same queries
//    shifted by 1..7 places (other queries before them) and reversed give bit-identical results
//    (a mask that let one lane's vertex count, clip or early exit leak into another would not);
//  - against the host path (the same functions on scalars, one query at a time) at the
//    extremes: alpha 1e-4 and 1, lights from 1e-3 to 1e3 across, one crossing the horizon,
//    grazing views, in fp32 and fp64; every value finite and >= 0.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "light_reach.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/validation.h"
#include "test_queries.h"
#include "tests/support/device_engine_fixture.h"

namespace glint {
namespace {

using glint::v1::EvaluateRequest;

class AreaLanes : public test::DeviceEngineTest {
 protected:
  static std::vector<float> Device(const EvalPlan &plan, const v1::QueryBatch &q) {
    std::vector<float> out(3 * q.count(), -1.0f);
    Status s = engine_->Evaluate(0, plan, q, out.data());
    EXPECT_TRUE(s.ok()) << s.message();
    return out;
  }
};

void AddPolygon(EvaluateRequest *r, const std::vector<float> &xyz, bool two_sided) {
  auto *p = r->add_lights()->mutable_polygon();
  for (float v : xyz) p->add_vertices(v);
  for (float v : {1.0f, 0.7f, 0.4f}) p->add_radiance(v);
  p->set_two_sided(two_sided);
}

// A softbox above, a tiny and a huge quad, and a two-sided pentagon standing across the
// horizon (the lights are in world space; the queries' random frames tilt them).
EvaluateRequest Settings(float alpha_x, float alpha_y, bool fp64) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::SMOOTH);
  m->set_ndf(v1::GGX);
  m->set_alpha_x(alpha_x);
  m->set_alpha_y(alpha_y);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  // Counter-clockwise seen from below: one-sided polygons emit towards that side (glint.proto),
  // here down onto the shading points (positions in [-2, 2]^3).
  AddPolygon(&r, {-1, 1, 3, 1, 1, 3, 1, -1, 3, -1, -1, 3}, false);
  const float t = 5e-4f;
  AddPolygon(&r, {4 - t, -t, 0.5f, 4 + t, -t, 0.5f, 4 + t, t, 0.5f, 4 - t, t, 0.5f}, true);
  const float h = 500.0f;
  AddPolygon(&r, {-h, h, 20, h, h, 20, h, -h, 20, -h, -h, 20}, false);
  AddPolygon(&r, {2.5f, -1, -0.5f, 2.5f, 1, -0.5f, 2.5f, 1, 1.5f, 2.5f, 0, 2, 2.5f, -1, 1.5f},
             true);
  r.set_area_method(v1::LTC);
  r.set_precision(fp64 ? v1::FP64 : v1::FP32);
  return r;
}

// Queries [first, first + count) of q (wo and the frame), after `pad` copies of query `pad_from`.
v1::QueryBatch Slice(const v1::QueryBatch &q, int pad, int pad_from, int first, int count,
                     bool reversed = false) {
  v1::QueryBatch out;
  out.set_count(uint32_t(pad + count));
  auto copy = [&](int i) {
    for (int k = 0; k < 3; ++k) {
      out.add_wo(q.wo(3 * i + k));
      out.add_position(q.position(3 * i + k));
      out.add_normal(q.normal(3 * i + k));
      out.add_tangent(q.tangent(3 * i + k));
    }
  };
  for (int i = 0; i < pad; ++i) copy(pad_from);
  for (int i = 0; i < count; ++i) copy(reversed ? first + count - 1 - i : first + i);
  return out;
}

// The comparisons below see a light only where it reaches a query: each one must.
TEST_F(AreaLanes, EveryLightOfTheSettingsReachesSomeQuery) {
  EXPECT_EQ(test::LightsReachingNoQuery(Settings(0.2f, 0.05f, false),
                                        test::RandomQueries(403, false, true, 23)),
            std::vector<int>{})
      << "lights (indices) that no query sees";
}

TEST_F(AreaLanes, LtcResultDoesNotDependOnLaneNeighbours) {
  for (bool fp64 : {false, true}) {
    EvaluateRequest settings = Settings(0.2f, 0.05f, fp64);
    v1::QueryBatch q = test::RandomQueries(403, false, true, 23);
    ASSERT_TRUE(ValidateSettings(settings, {}).ok());
    ASSERT_TRUE(ValidateQueries(q, true, {}).ok());
    const EvalPlan plan = MakeEvalPlan(settings, q);
    const std::vector<float> whole = Device(plan, q);
    int nonzero = 0;
    for (float v : whole) nonzero += v > 0.0f;
    ASSERT_GT(nonzero, int(whole.size()) / 5);  // the comparisons below must see light
    for (int pad = 1; pad < 8; ++pad) {
      // Padding with query 0 (above the horizon) and query 8 (below: RandomQueries puts every
      // 8th wo under the surface) changes every work-item's mix of lanes.
      for (int pad_from : {0, 8}) {
        const std::vector<float> shifted = Device(plan, Slice(q, pad, pad_from, 0, int(q.count())));
        ASSERT_EQ(0,
                  std::memcmp(shifted.data() + 3 * pad, whole.data(), whole.size() * sizeof(float)))
            << "fp64 " << fp64 << " shifted by " << pad << " copies of query " << pad_from;
      }
    }
    const std::vector<float> reversed = Device(plan, Slice(q, 0, 0, 0, int(q.count()), true));
    const int n = int(q.count());
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(reversed[3 * (n - 1 - i) + c], whole[3 * i + c]) << "query " << i;
  }
}

// Device against host at the extremes. fp64: both sides compute in double and round once to
// float; they differ by libm (the device's vector atan2 and sqrt, the host's scalar ones), a
// few ulps of double in the edge terms, far below float's 6e-8: 4e-6 relative as in
// engine_test's polygon test. fp32: libm differences in the edge terms, amplified by the
// cancellation of the edge sum where a light is seen almost edge-on: 1e-3 relative as there,
// plus an absolute 1e-7 of the light's radiance for the cancelled ones.
TEST_F(AreaLanes, LtcMatchesHostPathAtExtremes) {
  const float alphas[][2] = {{1e-4f, 1e-4f}, {1.0f, 1.0f}, {0.3f, 1e-4f}};
  for (const auto &alpha : alphas)
    for (bool fp64 : {false, true}) {
      EvaluateRequest settings = Settings(alpha[0], alpha[1], fp64);
      v1::QueryBatch q = test::RandomQueries(301, false, true, 29);
      // Grazing views: the first 40 queries 1e-3 .. 1e-6 above the local horizon, in world
      // terms a wo tilted into the surface's tangent plane.
      for (int i = 0; i < 40; ++i) {
        const float *n = q.normal().data() + 3 * i, *t = q.tangent().data() + 3 * i;
        const double up = std::pow(10.0, -3.0 - 3.0 * i / 39.0);
        double w[3], len = 0;
        for (int k = 0; k < 3; ++k) w[k] = t[k] + up * n[k], len += w[k] * w[k];
        for (int k = 0; k < 3; ++k) q.set_wo(3 * i + k, float(w[k] / std::sqrt(len)));
      }
      ASSERT_TRUE(ValidateQueries(q, true, {}).ok());
      const EvalPlan plan = MakeEvalPlan(settings, q);
      const std::vector<float> dev = Device(plan, q);
      std::vector<float> host(dev.size());
      HostEvaluate(plan, q, host.data());
      const double rel = fp64 ? 4e-6 : 1e-3;
      int nonzero = 0;
      for (size_t i = 0; i < dev.size(); ++i) {
        ASSERT_TRUE(std::isfinite(dev[i]) && dev[i] >= 0.0f)
            << "alpha " << alpha[0] << " query " << i / 3 << " value " << dev[i];
        ASSERT_NEAR(dev[i], host[i], rel * std::fabs(host[i]) + 1e-7)
            << "alpha " << alpha[0] << " fp64 " << fp64 << " query " << i / 3;
        nonzero += dev[i] > 0.0f;
      }
      EXPECT_GT(nonzero, int(dev.size()) / 5) << "alpha " << alpha[0];
    }
}

}  // namespace
}  // namespace glint
