// The 16-lane pass of the binomial glint model (models/binomial/binomial_lanes.cl: 16 queries per
// work-item for directional, point and polygon lights by LTC; footprint grids, LTC clips and the
// count draws per lane with selects and masked search loops, models/binomial/binomial_count.h)
// on the OpenCL device:
//  - a query's result must not depend on which queries share its work-item: the same queries
//    after 1..15 copies of another query, reversed, and split into batches of odd sizes and of
//    multiples of the lane width give bit-identical results (a mask that let one lane's regime,
//    search length, clip or early exit leak into another would not);
//  - against the host path (the same functions on scalars, one query at a time) at the
//    extremes: alpha 1e-4 and 1, N_P from 4e-5 to 4e8, zero / rank-1 / huge footprints,
//    uv = 1e7, grazing views, tiny and huge lights and one crossing the horizon, in fp32 and
//    fp64; every value finite and >= 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "client/lib/glint_client.h"
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

class BinomialLanes : public test::DeviceEngineTest {
 protected:
  static std::vector<float> Device(const EvaluateRequest &settings, const v1::QueryBatch &q) {
    std::vector<float> out(3 * q.count(), -1.0f);
    Status s = engine_->Evaluate(0, MakeEvalPlan(settings, q), q, out.data());
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

// A sun, a sphere light, a softbox above, a tiny and a huge quad, and a two-sided pentagon
// standing across the horizon (lights in world space; the queries' random frames tilt them).
EvaluateRequest Settings(float alpha_x, float alpha_y, double density, bool fp64,
                         v1::FootprintInterpolation interpolation = v1::TRILINEAR) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::BINOMIAL);
  m->set_ndf(v1::GGX);
  m->set_alpha_x(alpha_x);
  m->set_alpha_y(alpha_y);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  m->mutable_binomial()->set_density(density);
  m->mutable_binomial()->set_footprint_interpolation(interpolation);
  auto *d = r.add_lights()->mutable_directional();
  for (float v : {0.28221626f, -0.18814417f, 0.94072087f}) d->add_direction(v);
  for (float v : {2.0f, 2.0f, 2.0f}) d->add_irradiance(v);
  d->set_cone_half_angle_deg(1.0f);
  auto *p = r.add_lights()->mutable_point();
  for (float v : {1.0f, 0.5f, 1.5f}) p->add_position(v);
  for (float v : {3.0f, 3.0f, 3.0f}) p->add_intensity(v);
  p->set_radius(0.2f);
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
  r.set_seed(0x5eed0000beefull);
  return r;
}

// Queries with a frame, uv and footprints of varied size (N_P over decades at one density), the
// first ones at the extremes: grazing views 1e-3 .. 1e-6 above the local horizon, zero, rank-1
// and huge footprints, uv = 1e7.
v1::QueryBatch Queries(uint32_t count, uint32_t seed) {
  v1::QueryBatch q = test::RandomQueries(count, false, true, seed);
  for (uint32_t i = 0; i < count; ++i) {
    const double scale = std::pow(10.0, -3.0 + 3.0 * double(i % 13) / 12.0);
    for (int k = 0; k < 4; ++k) q.set_footprint(4 * i + k, float(q.footprint(4 * i + k) * scale));
  }
  for (int i = 0; i < 24 && uint32_t(i) < count; ++i) {
    const float *n = q.normal().data() + 3 * i, *t = q.tangent().data() + 3 * i;
    const double up = std::pow(10.0, -3.0 - 3.0 * i / 23.0);
    double w[3], len = 0;
    for (int k = 0; k < 3; ++k) w[k] = t[k] + up * n[k], len += w[k] * w[k];
    for (int k = 0; k < 3; ++k) q.set_wo(3 * i + k, float(w[k] / std::sqrt(len)));
  }
  const float extremes[4][4] = {
      {0, 0, 0, 0}, {1e-3f, 2e-3f, 2e-3f, 4e-3f}, {30.0f, 0, 0, 30.0f}, {1e-12f, 0, 0, 1e-12f}};
  for (int e = 0; e < 4 && uint32_t(24 + e) < count; ++e)
    for (int k = 0; k < 4; ++k) q.set_footprint(4 * (24 + e) + k, extremes[e][k]);
  if (count > 30) {
    q.set_uv(2 * 29, 1e7f);
    q.set_uv(2 * 30 + 1, -1e7f);
  }
  return q;
}

// Queries [first, first + count) of q, after `pad` copies of query `pad_from`, optionally
// reversed.
v1::QueryBatch Slice(const v1::QueryBatch &q, int pad, int pad_from, int first, int count,
                     bool reversed = false) {
  v1::QueryBatch out;
  out.set_count(uint32_t(pad + count));
  auto copy = [&](int i) {
    for (int k = 0; k < 2; ++k) out.add_uv(q.uv(2 * i + k));
    for (int k = 0; k < 4; ++k) out.add_footprint(q.footprint(4 * i + k));
    for (int k = 0; k < 3; ++k) {
      out.add_wo(q.wo(3 * i + k));
      if (q.position_size() == 0) continue; /* queries in the local frame */
      out.add_position(q.position(3 * i + k));
      out.add_normal(q.normal(3 * i + k));
      out.add_tangent(q.tangent(3 * i + k));
    }
  };
  for (int i = 0; i < pad; ++i) copy(pad_from);
  for (int i = 0; i < count; ++i) copy(reversed ? first + count - 1 - i : first + i);
  return out;
}

// The comparisons below see a light only where it reaches a query: each one must, except the
// tiny quad (light 3, 1e-3 across at distance ~4, seen nearly edge-on), which is there as an
// extreme that must stay finite: its expected count N_P p is far below 1 in every footprint of
// these queries (at most ~4e4 facets, p ~ its solid angle ~1e-8 times D / D_H), so no query is
// expected to see a glint of it (none does, nor at 1e-2 across).
TEST_F(BinomialLanes, EveryLightOfTheSettingsReachesSomeQuery) {
  for (auto interpolation : {v1::TRILINEAR, v1::STOCHASTIC})
    EXPECT_EQ(test::LightsReachingNoQuery(Settings(0.2f, 0.05f, 1e8, false, interpolation),
                                          Queries(403, 23)),
              std::vector<int>{3})
        << "lights (indices) that no query sees, interpolation " << int(interpolation);
}

TEST_F(BinomialLanes, ResultDoesNotDependOnLaneNeighboursOrBatchSize) {
  for (auto interpolation : {v1::TRILINEAR, v1::TETRAHEDRAL, v1::STOCHASTIC})
    for (bool fp64 : {false, true}) {
      const EvaluateRequest settings = Settings(0.2f, 0.05f, 1e8, fp64, interpolation);
      const v1::QueryBatch q = Queries(403, 23);
      ASSERT_TRUE(ValidateSettings(settings, {}).ok());
      ASSERT_TRUE(ValidateQueriesForModel(q, settings).ok());
      ASSERT_EQ(MakeEvalPlan(settings, q).area_method, GLINT_AREA_LTC);
      const std::vector<float> whole = Device(settings, q);
      int lit = 0, dark = 0;
      for (float v : whole) lit += v > 0.0f, dark += v == 0.0f;
      // The comparisons below must see glints: many lit values next to many exact zeros.
      ASSERT_GT(lit, int(whole.size()) / 20);
      ASSERT_GT(dark, int(whole.size()) / 20);
      for (int pad = 1; pad < 16; ++pad) {
        // Padding with query 40 (above the horizon) and query 48 (below: RandomQueries puts every
        // 8th wo under the surface) changes every work-item's mix of lanes.
        for (int pad_from : {40, 48}) {
          const std::vector<float> shifted = Device(settings, Slice(q, pad, pad_from, 0, 403));
          ASSERT_EQ(
              0, std::memcmp(shifted.data() + 3 * pad, whole.data(), whole.size() * sizeof(float)))
              << "fp64 " << fp64 << " shifted by " << pad << " copies of query " << pad_from;
        }
      }
      const std::vector<float> reversed = Device(settings, Slice(q, 0, 0, 0, 403, true));
      for (int i = 0; i < 403; ++i)
        for (int c = 0; c < 3; ++c)
          ASSERT_EQ(reversed[size_t(3 * (402 - i) + c)], whole[size_t(3 * i + c)]) << "query " << i;
      // Batches of odd sizes, of the lane width and of its multiples (the last one partial).
      for (uint32_t chunk : {1u, 3u, 8u, 13u, 16u, 64u}) {
        std::vector<float> pieces;
        for (uint32_t first = 0; first < q.count(); first += chunk) {
          const v1::QueryBatch part =
              client::SliceQueries(q, first, first + std::min(chunk, q.count() - first));
          const std::vector<float> out = Device(settings, part);
          pieces.insert(pieces.end(), out.begin(), out.end());
        }
        ASSERT_EQ(pieces.size(), whole.size());
        EXPECT_EQ(0, std::memcmp(pieces.data(), whole.data(), whole.size() * sizeof(float)))
            << "fp64 " << fp64 << " batches of " << chunk;
      }
    }
}

// One light and STOCHASTIC (one draw per query): the fp32 lane kernel evaluates 4 blocks of 16
// queries per work-item and draws their counts with the lanes regrouped by regime
// (models/binomial/binomial_lanes.cl binomial_lanes_regrouped), so a draw runs in a group with
// lanes of other blocks. Its count must be the one its query gets alone: the same queries whole,
// after 1..15 copies of another query (every lane moves to another place in its block and in the
// packed groups), reversed, and in batches of 1 and 16 (one block per work-item: nothing to
// regroup with) and of odd sizes give bit-identical results. The requests are
// bench/binomial_breakdown's (its queries, material, 6 x 6 quad, or a directional light with a
// 10 degree cone) at N_P = 1e2 and 1e3 in the mean footprint, where the draws of a work-item mix
// the exact and the approximated regimes (models/binomial/README.md "Quad throughput (session
// 12)"): a stage that mixed up two lanes' inputs or results would change counts.
TEST_F(BinomialLanes, RegroupedDrawsDoNotDependOnNeighboursOrBatchSize) {
  const v1::QueryBatch q = test::RandomQueries(403, false, false, 42);
  double area = 0;
  for (uint32_t i = 0; i < q.count(); ++i) {
    const float *f = q.footprint().data() + 4 * i;
    area += std::fabs(double(f[0]) * f[3] - double(f[2]) * f[1]);
  }
  area /= q.count();
  for (int light = 0; light < 2; ++light)
    for (double n_p : {1e2, 1e3}) {
      EvaluateRequest settings;
      auto *m = settings.mutable_material();
      m->set_model(v1::BINOMIAL);
      m->set_ndf(v1::GGX);
      m->set_alpha_x(0.3f);
      m->set_alpha_y(0.1f);
      for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
      m->mutable_binomial()->set_density(n_p / area);
      m->mutable_binomial()->set_footprint_interpolation(v1::STOCHASTIC);
      if (light == 0) {
        AddPolygon(&settings, {-3, -3, 3, 3, -3, 3, 3, 3, 3, -3, 3, 3}, true);
      } else {
        auto *d = settings.add_lights()->mutable_directional();
        for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
        for (float v : {2.0f, 2.0f, 2.0f}) d->add_irradiance(v);
        d->set_cone_half_angle_deg(10.0f);
      }
      settings.set_area_method(v1::LTC);
      settings.set_precision(v1::FP32);
      settings.set_seed(0x9e3779b97f4aull);
      ASSERT_TRUE(ValidateSettings(settings, {}).ok());
      ASSERT_TRUE(ValidateQueriesForModel(q, settings).ok());
      const std::vector<float> whole = Device(settings, q);
      int lit = 0;
      for (float v : whole) lit += v > 0.0f;
      std::printf("light %d N_P %g: %d of %zu values lit\n", light, n_p, lit, whole.size());
      // The comparisons must see glints.
      ASSERT_GT(lit, int(whole.size()) / 20) << "light " << light << " N_P " << n_p;
      for (int pad = 1; pad < 16; ++pad) {
        const std::vector<float> shifted = Device(settings, Slice(q, pad, 40, 0, 403));
        ASSERT_EQ(0,
                  std::memcmp(shifted.data() + 3 * pad, whole.data(), whole.size() * sizeof(float)))
            << "light " << light << " N_P " << n_p << " shifted by " << pad;
      }
      const std::vector<float> reversed = Device(settings, Slice(q, 0, 0, 0, 403, true));
      for (int i = 0; i < 403; ++i)
        for (int c = 0; c < 3; ++c)
          ASSERT_EQ(reversed[size_t(3 * (402 - i) + c)], whole[size_t(3 * i + c)]) << "query " << i;
      for (uint32_t chunk : {1u, 16u, 37u, 64u, 100u}) {
        std::vector<float> pieces;
        for (uint32_t first = 0; first < q.count(); first += chunk) {
          const std::vector<float> out = Device(
              settings, client::SliceQueries(q, first, first + std::min(chunk, q.count() - first)));
          pieces.insert(pieces.end(), out.begin(), out.end());
        }
        ASSERT_EQ(pieces.size(), whole.size());
        EXPECT_EQ(0, std::memcmp(pieces.data(), whole.data(), whole.size() * sizeof(float)))
            << "light " << light << " N_P " << n_p << " batches of " << chunk;
      }
    }
}

// The regrouped draws against the plain loop over the blocks, bit for bit. The test above only
// sees errors that depend on how lanes are grouped: every one of its runs takes the regrouped
// path (batches of 1 and 16 too: one block, regrouped alone), so an error alike in every group
// would pass it. Here the same requests get a second directional light from below the horizon,
// (0, 0, -1) with the queries in the local frame (RandomQueries without a frame): two lights, so
// the kernel loops over its 4 blocks with each draw in place (binomial_lanes.cl
// glint_binomial_lanes). That light changes no bit of the first one's result: it lights no
// query (smooth_reflect_cos_view is 0 for wi.z <= 0), so binomial_shade skips it before its
// key, p or draw (`continue`) and adds nothing; it is the last punctual light, so the first
// keeps its index (punctual_light, directional lights in request order), hence its hash key;
// the polygon's key has its own index among polygons, and its LTC entry is looked up again
// when punctual lights are present, the same entry (binomial_polygon_ltc). The sum is then 0 +
// the first light's term in both (binomial_deferred_finish does binomial_shade's operations).
TEST_F(BinomialLanes, RegroupedDrawsEqualTheDrawsInPlace) {
  // Many queries (a few ms per evaluation): a wrong count shows only where a draw's u lies
  // within the error of a CDF step, so the chance to see a small error grows with the draws.
  const v1::QueryBatch q = test::RandomQueries(65536, false, false, 42);
  ASSERT_EQ(q.position_size(), 0);  // local frame: (0, 0, -1) is below every query's horizon
  double area = 0;
  for (uint32_t i = 0; i < q.count(); ++i) {
    const float *f = q.footprint().data() + 4 * i;
    area += std::fabs(double(f[0]) * f[3] - double(f[2]) * f[1]);
  }
  area /= q.count();
  for (int light = 0; light < 2; ++light)
    for (double n_p : {1e2, 1e3}) {
      EvaluateRequest settings;
      auto *m = settings.mutable_material();
      m->set_model(v1::BINOMIAL);
      m->set_ndf(v1::GGX);
      m->set_alpha_x(0.3f);
      m->set_alpha_y(0.1f);
      for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
      m->mutable_binomial()->set_density(n_p / area);
      m->mutable_binomial()->set_footprint_interpolation(v1::STOCHASTIC);
      if (light == 0) {
        AddPolygon(&settings, {-3, -3, 3, 3, -3, 3, 3, 3, 3, -3, 3, 3}, true);
      } else {
        auto *d = settings.add_lights()->mutable_directional();
        for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
        for (float v : {2.0f, 2.0f, 2.0f}) d->add_irradiance(v);
        d->set_cone_half_angle_deg(10.0f);
      }
      settings.set_area_method(v1::LTC);
      settings.set_precision(v1::FP32);
      settings.set_seed(0x9e3779b97f4aull);
      EvaluateRequest in_place = settings;
      auto *below = in_place.add_lights()->mutable_directional();
      for (float v : {0.0f, 0.0f, -1.0f}) below->add_direction(v);
      for (float v : {2.0f, 2.0f, 2.0f}) below->add_irradiance(v);
      below->set_cone_half_angle_deg(10.0f);
      ASSERT_TRUE(ValidateSettings(settings, {}).ok());
      ASSERT_TRUE(ValidateSettings(in_place, {}).ok());
      ASSERT_TRUE(ValidateQueriesForModel(q, in_place).ok());
      const std::vector<float> regrouped = Device(settings, q);
      const std::vector<float> plain = Device(in_place, q);
      int lit = 0;
      for (float v : regrouped) lit += v > 0.0f;
      // The comparison must see glints.
      ASSERT_GT(lit, int(regrouped.size()) / 20) << "light " << light << " N_P " << n_p;
      int differ = 0;
      for (size_t i = 0; i < regrouped.size(); ++i)
        differ += std::memcmp(&regrouped[i], &plain[i], sizeof(float)) != 0;
      EXPECT_EQ(differ, 0) << "light " << light << " N_P " << n_p << ": " << differ << " of "
                           << regrouped.size() << " values differ";
    }
}

// Device against host at the extremes. A glint is a discrete event: where the device's and the
// host's libm differ by an ulp at a cell boundary (the floor of a rotated uv) or at a CDF step of
// the count, a query gets another count. The chance is the rounding error over the spacing of
// those steps: in fp64 (~1e-16 against steps of 1e-3 .. 1) it is nil, so every value must agree
// to the LTC integral's own device-host difference, 4e-6 relative as in area_lanes_test (the
// edge terms' libm differences, far below float's 6e-8, after the rounding to float); in fp32
// (~1e-7 per step) some queries may flip, so 99% must agree to 1e-3 relative (area_lanes_test's
// fp32 bound for the cancelling edge sum) plus an absolute 1e-7 of the radiance, and every
// value must be finite and >= 0.
TEST_F(BinomialLanes, MatchesHostPathAtExtremes) {
  const float alphas[][2] = {{1e-4f, 1e-4f}, {1.0f, 1.0f}, {0.3f, 1e-4f}};
  int lit_total = 0, values_total = 0;
  for (auto interpolation : {v1::TRILINEAR, v1::TETRAHEDRAL, v1::STOCHASTIC})
    for (const auto &alpha : alphas)
      for (double density : {1e5, 1e8, 1e12})
        for (bool fp64 : {false, true}) {
          const EvaluateRequest settings =
              Settings(alpha[0], alpha[1], density, fp64, interpolation);
          const v1::QueryBatch q = Queries(301, 29);
          ASSERT_TRUE(ValidateQueriesForModel(q, settings).ok());
          const EvalPlan plan = MakeEvalPlan(settings, q);
          const std::vector<float> dev = Device(settings, q);
          std::vector<float> host(dev.size());
          HostEvaluate(plan, q, host.data());
          const double rel = fp64 ? 4e-6 : 1e-3;
          int agree = 0, lit = 0;
          for (size_t i = 0; i < dev.size(); ++i) {
            ASSERT_TRUE(std::isfinite(dev[i]) && dev[i] >= 0.0f)
                << "alpha " << alpha[0] << " density " << density << " query " << i / 3 << " value "
                << dev[i];
            const bool ok = std::fabs(dev[i] - host[i]) <= rel * std::fabs(host[i]) + 1e-7;
            if (fp64) {
              ASSERT_TRUE(ok) << "alpha " << alpha[0] << " density " << density << " query "
                              << i / 3 << ": device " << dev[i] << " host " << host[i];
            }
            agree += ok;
            lit += dev[i] > 0.0f;
          }
          std::printf(
              "interpolation %d alpha %g density %g fp64 %d: %d of %zu values agree, %d lit\n",
              int(interpolation), alpha[0], density, int(fp64), agree, dev.size(), lit);
          EXPECT_GE(agree, int(dev.size()) * 99 / 100)
              << "alpha " << alpha[0] << " density " << density << " fp64 " << fp64;
          EXPECT_GT(lit, 0) << "alpha " << alpha[0] << " density " << density;
          lit_total += lit;
          values_total += int(dev.size());
        }
  // The agreement above must have been tested on glints, not only on zeros.
  EXPECT_GT(lit_total, values_total / 20);
}

}  // namespace
}  // namespace glint
