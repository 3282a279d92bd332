// LTC polygon lights far from (or very near to) the shading point: the polygon loader
// (area_polygon_load_n) rescales such polygons by a power of two before the products
// (kernels/area/polygon_scale.h; every other method: area_far_light_test.cpp);
// before that, fp32 dropped a quad beyond ~1e12 (the facing product overflowed to NaN) and gave
// 0 beyond ~1e19 (issue 13). Device and host, fp32 and fp64:
//  - a scale identity: a polygon's directions, hence LTC's integral, do not change when all its
//    vertices (relative to the shading point) are multiplied by 2^k, and that multiplication is
//    exact in floating point, so the lights scaled by 2^66 (~7e19), 2^100 (~1e30), 2^120 and
//    2^-60, 2^-100 must give the unscaled result bit for bit (every step of the pass is
//    homogeneous in the vertices; see polygon_scale.h);
//  - a closed form: a small square at d = 1e20 and 1e30 against the point limit of LTC's own
//    lobe, albedo x D_ltc(dir) x Omega with D_ltc(w) = D_cos(M^-1 w / |M^-1 w|) |det M^-1| /
//    |M^-1 w|^3 (Heitz et al. 2016 Eq. 2) from the table entry and Omega = A cos_l / d^2 of the
//    rounded polygon, within the point limit's error bound delta^2 (1 + 1 / alpha^2) (derived in
//    tests/area/area_lights_test.cpp, SmallFarPolygonMatchesPointLight) plus the fp32 edge sum's
//    cancellation: ~6 terms of size ~delta, each a few ulps off, summing to ~delta^2, i.e.
//    64 eps32 / delta relative.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "data/ltc/ltc_table.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/validation.h"
#include "test_queries.h"
#include "tests/support/device_engine_fixture.h"

namespace k64 {
#define GLINT_USE_DOUBLE 1
#include "kernels/area/ltc_lookup.h"
}  // namespace k64

namespace glint {
namespace {

using glint::v1::EvaluateRequest;

class LtcFarLight : public test::DeviceEngineTest {
 protected:
  // The radiance of `r` for `q` on the device or the host path, after the server's validation.
  static std::vector<float> Run(const EvaluateRequest &r, const v1::QueryBatch &q, bool device) {
    EXPECT_TRUE(ValidateSettings(r, {}).ok()) << ValidateSettings(r, {}).message();
    EXPECT_TRUE(ValidateQueries(q, true, {}).ok());
    const EvalPlan plan = MakeEvalPlan(r, q);
    std::vector<float> out(3 * q.count(), -1.0f);
    if (device) {
      Status s = engine_->Evaluate(0, plan, q, out.data());
      EXPECT_TRUE(s.ok()) << s.message();
    } else {
      HostEvaluate(plan, q, out.data());
    }
    return out;
  }
};

EvaluateRequest Settings(double alpha, bool fp64) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::SMOOTH);
  m->set_ndf(v1::GGX);
  m->set_alpha_x(float(alpha));
  m->set_alpha_y(float(alpha));
  for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(1.0f);
  r.set_area_method(v1::LTC);
  r.set_precision(fp64 ? v1::FP64 : v1::FP32);
  return r;
}

void AddPolygon(EvaluateRequest *r, const std::vector<double> &xyz, bool two_sided) {
  auto *p = r->add_lights()->mutable_polygon();
  for (double v : xyz) p->add_vertices(float(v));
  for (float v : {1.0f, 0.7f, 0.4f}) p->add_radiance(v);
  p->set_two_sided(two_sided);
}

TEST_F(LtcFarLight, PowerOfTwoScaledLightsGiveTheSameRadianceBitForBit) {
  // Queries without a frame: the lights are in the local frame and the shading point is the
  // origin, so scaling the vertices scales them relative to the shading point exactly.
  const v1::QueryBatch q = test::RandomQueries(203, false, false, 31);
  // A one-sided quad overhead (its facing test is where fp32 overflowed first) and a two-sided
  // quad standing across the horizon (the clip path of polygon_wedge.h).
  const std::vector<double> overhead = {-1, -1, 3, 1, -1, 3, 1, 1, 3, -1, 1, 3};
  const std::vector<double> across = {2.5, -1, -0.5, 2.5, 1, -0.5, 2.5, 1, 1.5, 2.5, -1, 1.5};
  for (bool fp64 : {false, true}) {
    for (bool device : {true, false}) {
      auto with_scale = [&](int k) {
        EvaluateRequest r = Settings(0.3, fp64);
        std::vector<double> a = overhead, b = across;
        for (double &v : a) v = std::ldexp(v, k);
        for (double &v : b) v = std::ldexp(v, k);
        AddPolygon(&r, a, false);
        AddPolygon(&r, b, true);
        return Run(r, q, device);
      };
      const std::vector<float> unscaled = with_scale(0);
      int lit = 0;
      for (float v : unscaled) lit += v > 0.0f;
      ASSERT_GT(lit, int(unscaled.size()) / 2) << "the comparison must see light";
      for (int k : {66, 100, 120, -60, -100}) {
        const std::vector<float> scaled = with_scale(k);
        for (size_t i = 0; i < scaled.size(); ++i)
          ASSERT_EQ(scaled[i], unscaled[i]) << "2^" << k << " fp64 " << fp64 << " device " << device
                                            << " query " << i / 3 << " channel " << i % 3;
      }
    }
  }
}

TEST_F(LtcFarLight, FarSmallSquareMatchesThePointLimitOfItsLobe) {
  const double alpha = 0.5, delta = 0.02, cl = 0.8, sl = 0.6;
  const double deg = M_PI / 180;
  const double views[][2] = {{0, 0}, {30, 200}, {60, 45}};
  v1::QueryBatch q;
  q.set_count(3);
  for (const auto &v : views) {
    const double t = v[0] * deg, p = v[1] * deg;
    for (double c : {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)})
      q.add_wo(float(c));
  }
  for (double d : {1e20, 1e30}) {
    // A square of side delta d at distance d along `axis`, its plane tilted by acos(cl) away
    // from facing the receiver, counter-clockwise seen from the receiver (it emits towards it).
    const double an[3] = {0.5, 0.2, 0.8};
    const double al = std::sqrt(an[0] * an[0] + an[1] * an[1] + an[2] * an[2]);
    const double axis[3] = {an[0] / al, an[1] / al, an[2] / al};
    double t1[3] = {axis[1], -axis[0], 0};  // axis x z
    const double tl = std::hypot(t1[0], t1[1]);
    t1[0] /= tl, t1[1] /= tl;
    const double t2[3] = {axis[1] * t1[2] - axis[2] * t1[1], axis[2] * t1[0] - axis[0] * t1[2],
                          axis[0] * t1[1] - axis[1] * t1[0]};
    const double h = delta * d / 2;
    double u[3], w[3];
    for (int k = 0; k < 3; ++k) u[k] = h * t1[k], w[k] = h * (cl * t2[k] + sl * axis[k]);
    std::vector<double> poly;
    const double corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (const auto &s : corners)
      for (int k = 0; k < 3; ++k)
        poly.push_back(double(float(d * axis[k] + s[0] * u[k] + s[1] * w[k])));
    // Facing the receiver: the right-hand normal points at the origin (n . v0 < 0).
    double nrm[3] = {0, 0, 0}, cen[3] = {0, 0, 0};
    for (int i = 0; i < 4; ++i) {
      const double *a = &poly[3 * i], *b = &poly[3 * ((i + 1) % 4)];
      nrm[0] += 0.5 * (a[1] * b[2] - a[2] * b[1]);
      nrm[1] += 0.5 * (a[2] * b[0] - a[0] * b[2]);
      nrm[2] += 0.5 * (a[0] * b[1] - a[1] * b[0]);
      for (int k = 0; k < 3; ++k) cen[k] += a[k] / 4;
    }
    if (nrm[0] * poly[0] + nrm[1] * poly[1] + nrm[2] * poly[2] > 0) {
      std::swap_ranges(poly.begin() + 3, poly.begin() + 6, poly.begin() + 9);
      for (double &c : nrm) c = -c;
    }
    // Omega = (vector area . -centroid) / |centroid|^3 of the rounded polygon.
    const double dist = std::sqrt(cen[0] * cen[0] + cen[1] * cen[1] + cen[2] * cen[2]);
    const double omega =
        -(nrm[0] * cen[0] + nrm[1] * cen[1] + nrm[2] * cen[2]) / (dist * dist * dist);
    // The test's own construction: A cos_l / d^2 = delta^2 cl, up to the float rounding of the
    // vertices (2^-24 of d each, i.e. ~2^-24 / delta of the area).
    ASSERT_NEAR(omega, delta * delta * cl, 1e-4 * delta * delta);
    const double dir[3] = {cen[0] / dist, cen[1] / dist, cen[2] / dist};
    for (bool fp64 : {false, true}) {
      EvaluateRequest r = Settings(alpha, fp64);
      AddPolygon(&r, poly, false);
      for (bool device : {true, false}) {
        const std::vector<float> out = Run(r, q, device);
        for (int i = 0; i < 3; ++i) {
          // LTC's lobe at dir in the view-aligned frame (area_ltc.h), from the same table.
          const double wo[3] = {q.wo(3 * i), q.wo(3 * i + 1), q.wo(3 * i + 2)};
          double e[GLINT_LTC_ENTRY];
          k64::area_ltc_lookup(glint::ltc_table::table(glint::ltc_table::Ndf::kGgx), alpha, wo[2],
                               e);
          const double sxy = std::hypot(wo[0], wo[1]);
          const double tx = sxy > 1e-7 ? wo[0] / sxy : 1, ty = sxy > 1e-7 ? wo[1] / sxy : 0;
          const double x = dir[0] * tx + dir[1] * ty, y = -dir[0] * ty + dir[1] * tx, z = dir[2];
          const double o[3] = {e[0] * x + e[1] * z, y, e[2] * x + e[3] * z};
          const double len = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
          const double det = std::fabs(e[0] * e[3] - e[1] * e[2]);
          const double d_ltc = std::max(o[2] / len, 0.0) / M_PI * det / (len * len * len);
          const double expected = e[4] * d_ltc * omega;  // f0 = 1: the albedo is the magnitude
          const double tol =
              delta * delta * (1 + 1 / (alpha * alpha)) + (fp64 ? 0.0 : 64 * 0x1p-24 / delta);
          ASSERT_GT(expected, 0.0);
          for (int c = 0; c < 3; ++c) {
            const double L = c == 0 ? 1.0 : c == 1 ? 0.7 : 0.4;
            EXPECT_NEAR(out[3 * i + c], L * expected, tol * L * expected)
                << "d " << d << " fp64 " << fp64 << " device " << device << " view " << i;
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace glint
