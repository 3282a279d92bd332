// kernels/area/area_lights.h (polygon lights for the smooth model): the REFERENCE quadrature against an
// independent brute-force integration, LTC against REFERENCE per region, horizon and facing
// rules, the point-light limit, and fp32 extremes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "tests/support/plane_adaptive.h"
#include "data/ltc/ltc_table.h"

#include "tests/support/kernels_both_precisions.h"

namespace {

using glint::ltc_table::Ndf;

struct V3 {
  double x, y, z;
};
V3 Add(V3 a, V3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
V3 Sub(V3 a, V3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3 Scale(V3 a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
V3 Cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double Dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
V3 Normalize(V3 a) {
  return Scale(a, 1.0 / std::sqrt(Dot(a, a)));
}

struct Mat {
  int ndf = GLINT_NDF_GGX;
  double ax = 0.3, ay = 0.3;
  double f0 = 1.0;  // grey Schlick
};

// Packs one polygon record exactly as server/eval_plan.cpp does.
std::vector<float> Record(const std::vector<V3> &poly, bool two_sided, double L = 1.0) {
  std::vector<float> r(GLINT_POLYGON_FLOATS, 0.0f);
  r[0] = float(poly.size());
  r[1] = two_sided ? 1.0f : 0.0f;
  r[2] = r[3] = r[4] = float(L);
  for (size_t i = 0; i < poly.size(); ++i) {
    r[GLINT_POLYGON_VERTEX_OFFSET + 3 * i + 0] = float(poly[i].x);
    r[GLINT_POLYGON_VERTEX_OFFSET + 3 * i + 1] = float(poly[i].y);
    r[GLINT_POLYGON_VERTEX_OFFSET + 3 * i + 2] = float(poly[i].z);
  }
  return r;
}

const float *Table(int ndf) {
  return glint::ltc_table::table(ndf == GLINT_NDF_BECKMANN ? Ndf::kBeckmann : Ndf::kGgx);
}

// Red channel of area_shade in double (k64) or float (k32).
double Shade64(const Mat &mat, V3 wo, const std::vector<V3> &poly, bool two_sided, int method,
               int samples = 64) {
  using namespace k64;
  SmoothMaterial m;
  m.ndf = mat.ndf;
  m.alpha_x = mat.ax;
  m.alpha_y = mat.ay;
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a = make_real3(mat.f0, mat.f0, mat.f0);
  m.fresnel.b = make_real3(0, 0, 0);
  ShadingFrame f{};
  std::vector<float> rec = Record(poly, two_sided);
  real3 w = r3_normalize(make_real3(wo.x, wo.y, wo.z));
  return area_shade(m, Table(mat.ndf), method, samples, w, 0, f, make_real3(0, 0, 0), rec.data(), 1)
      .x;
}

k32::real3 Shade32(const Mat &mat, V3 wo, const std::vector<V3> &poly, bool two_sided, int method,
                   int samples = 64) {
  using namespace k32;
  SmoothMaterial m;
  m.ndf = mat.ndf;
  m.alpha_x = float(mat.ax);
  m.alpha_y = float(mat.ay);
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a = make_real3(float(mat.f0), float(mat.f0), float(mat.f0));
  m.fresnel.b = make_real3(0, 0, 0);
  ShadingFrame f{};
  std::vector<float> rec = Record(poly, two_sided);
  real3 w = r3_normalize(make_real3(float(wo.x), float(wo.y), float(wo.z)));
  return area_shade(m, Table(mat.ndf), method, samples, w, 0, f, make_real3(0, 0, 0), rec.data(),
                    1);
}

// f cos_i of the kernel (double), red channel.
double BrdfCos(const Mat &mat, V3 wi, V3 wo) {
  using namespace k64;
  SmoothMaterial m;
  m.ndf = mat.ndf;
  m.alpha_x = mat.ax;
  m.alpha_y = mat.ay;
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a = make_real3(mat.f0, mat.f0, mat.f0);
  m.fresnel.b = make_real3(0, 0, 0);
  return smooth_reflect_cos(m, make_real3(wi.x, wi.y, wi.z),
                            r3_normalize(make_real3(wo.x, wo.y, wo.z)))
      .x;
}

// Does the ray from the origin along d hit the planar convex polygon (either side)?
bool Hit(const std::vector<V3> &poly, V3 d) {
  V3 n = Cross(Sub(poly[1], poly[0]), Sub(poly[2], poly[0]));
  double denom = Dot(n, d);
  if (std::fabs(denom) < 1e-15) return false;
  double t = Dot(n, poly[0]) / denom;
  if (t <= 0) return false;
  V3 p = Scale(d, t);
  int sign = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    V3 e = Sub(poly[(i + 1) % poly.size()], poly[i]);
    int si = Dot(Cross(e, Sub(p, poly[i])), n) > 0 ? 1 : -1;
    if (sign == 0)
      sign = si;
    else if (si != sign)
      return false;
  }
  return true;
}

// Independent scheme: midpoint rule on an (cos^2 theta, phi) grid over the whole hemisphere
// (cos dw = d(cos^2)/2 dphi, so the integrand is f = f cos / cos), with a ray-polygon test
// per node. Different parameterisation, no clipping, no triangulation.
double BruteForce(const Mat &mat, V3 wo, const std::vector<V3> &poly, int n) {
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    double c2 = (i + 0.5) / n, ct = std::sqrt(c2), st = std::sqrt(1 - c2);
    for (int j = 0; j < 2 * n; ++j) {
      double phi = (j + 0.5) / (2 * n) * 2 * M_PI;
      V3 wi = {st * std::cos(phi), st * std::sin(phi), ct};
      if (Hit(poly, wi)) sum += BrdfCos(mat, wi, wo) / ct;
    }
  }
  // (1/2) d(c^2) dphi with cells of 1/n and pi/n.
  return sum * 0.5 * (1.0 / n) * (M_PI / n);
}

// Second independent scheme, for sharp lobes: tests/support/plane_adaptive.h.
double PlaneAdaptive(const Mat &mat, V3 wo, const std::vector<V3> &poly, double rel_tol = 1e-8) {
  using glint::test::plane::Vec;
  std::vector<Vec> p;
  for (V3 v : poly) p.push_back({v.x, v.y, v.z});
  return glint::test::plane::PlaneAdaptive(
      [&](Vec wi, Vec o) {
        return BrdfCos(mat, {wi.x, wi.y, wi.z}, {o.x, o.y, o.z});
      },
      {wo.x, wo.y, wo.z}, p, rel_tol);
}

// Quads facing the receiver at the origin (counter-clockwise seen from it).
std::vector<V3> Quad(V3 c, V3 u, V3 v) {
  // u x v must point at the origin for a front face.
  return {Sub(Sub(c, u), v), Sub(Add(c, u), v), Add(Add(c, u), v), Add(Sub(c, u), v)};
}
std::vector<V3> Facing(std::vector<V3> p) {
  V3 n = Cross(Sub(p[1], p[0]), Sub(p[2], p[0]));
  if (Dot(n, p[0]) > 0) std::reverse(p.begin(), p.end());
  return p;
}

V3 Wo(double theta_deg, double phi_deg = 0) {
  double t = theta_deg * M_PI / 180, p = phi_deg * M_PI / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

const std::vector<std::vector<V3>> &TestPolygons() {
  static const std::vector<std::vector<V3>> polys = {
      Facing({{-1, -1, 1}, {-1, 1, 1}, {1, 1, 1}, {1, -1, 1}}),            // overhead
      Facing({{0.5, -1, 0.5}, {0.5, 1, 0.5}, {2, 1, 1.5}, {2, -1, 1.5}}),  // tilted, off-axis
      Facing({{-1, -1, -0.5}, {-1, 1, -0.5}, {1, 1, 1.5}, {1, -1, 1.5}}),  // partly below horizon
      Facing({{-0.8, 0.2, 2}, {-0.3, 0.1, 2}, {-0.5, 0.9, 2}}),            // small triangle
      Facing({{1, 0, 1}, {0.31, 0.95, 1}, {-0.81, 0.59, 1}, {-0.81, -0.59, 1}, {0.31, -0.95, 1}}),
  };
  return polys;
}

TEST(AreaReference, MatchesIndependentBruteForce) {
  const Mat mats[] = {{GLINT_NDF_GGX, 0.1, 0.1, 1.0},
                      {GLINT_NDF_GGX, 0.3, 0.3, 0.04},
                      {GLINT_NDF_GGX, 1.0, 1.0, 1.0},
                      {GLINT_NDF_BECKMANN, 0.3, 0.3, 1.0},
                      {GLINT_NDF_GGX, 0.4, 0.15, 1.0}};
  const V3 wos[] = {Wo(0), Wo(40, 30), Wo(75, 180)};
  double worst = 0;
  for (const Mat &m : mats) {
    for (V3 wo : wos) {
      for (size_t k = 0; k < TestPolygons().size(); ++k) {
        const auto &poly = TestPolygons()[k];
        double ref = Shade64(m, wo, poly, false, GLINT_AREA_REFERENCE, 64);
        double bf = BruteForce(m, wo, poly, 700);
        double err = std::fabs(ref - bf) / std::max(std::fabs(bf), 1e-3);
        worst = std::max(worst, err);
        EXPECT_LT(err, 1e-3) << "alpha " << m.ax << "," << m.ay << " ndf " << m.ndf << " wo ("
                             << wo.x << "," << wo.y << "," << wo.z << ") polygon " << k << " ref "
                             << ref << " brute " << bf;
      }
    }
  }
  std::printf("REFERENCE vs brute force: worst relative error %.2e\n", worst);
}

TEST(AreaReference, ConvergesWithSamples) {
  const Mat m{GLINT_NDF_GGX, 0.1, 0.1, 1.0};
  for (const auto &poly : TestPolygons()) {
    double a = Shade64(m, Wo(30), poly, false, GLINT_AREA_REFERENCE, 64);
    double b = Shade64(m, Wo(30), poly, false, GLINT_AREA_REFERENCE, 256);
    EXPECT_NEAR(a, b, 1e-4 * std::fabs(b) + 1e-9);
  }
}

TEST(AreaLights, HorizonAndFacing) {
  const Mat m{GLINT_NDF_GGX, 0.3, 0.3, 1.0};
  auto below = Facing({{-1, -1, -1}, {-1, 1, -1}, {1, 1, -0.1}, {1, -1, -0.1}});
  auto front = TestPolygons()[1];
  std::vector<V3> back(front.rbegin(), front.rend());
  for (int method : {GLINT_AREA_LTC, GLINT_AREA_REFERENCE}) {
    EXPECT_EQ(Shade64(m, Wo(30), below, false, method), 0.0);
    EXPECT_EQ(Shade64(m, Wo(30), below, true, method), 0.0);
    EXPECT_EQ(Shade32(m, Wo(30), below, true, method).x, 0.0f);
    double f = Shade64(m, Wo(30), front, false, method);
    EXPECT_GT(f, 0.0);
    EXPECT_EQ(Shade64(m, Wo(30), back, false, method), 0.0) << "one-sided seen from behind";
    EXPECT_NEAR(Shade64(m, Wo(30), back, true, method), f, 1e-12 * f) << "two-sided";
    EXPECT_EQ(Shade64(m, Wo(95), front, false, method), 0.0) << "view below the horizon";
  }
}

// A small far polygon of radiance L, area A, seen at cos_l acts as a point light of intensity
// I = L A cos_l: L_o -> f cos_i I / d^2.
TEST(AreaLights, SmallFarPolygonMatchesPointLight) {
  const Mat m{GLINT_NDF_GGX, 0.5, 0.5, 1.0};
  const double d = 20, side = 0.02, cl = 0.8, sl = 0.6;
  const V3 dir = Normalize({0.5, 0.2, 0.8});
  V3 c = Scale(dir, d);
  // Light plane tilted by acos(cl) away from facing the receiver.
  V3 t1 = Normalize(Cross(dir, {0, 0, 1})), t2 = Cross(dir, t1);
  V3 u = Scale(t1, side / 2), v = Add(Scale(t2, cl * side / 2), Scale(dir, sl * side / 2));
  auto poly = Facing(Quad(c, u, v));
  const double I = side * side * cl;
  const V3 wo = Wo(30, 200);
  const double point = BrdfCos(m, dir, wo) * I / (d * d);
  EXPECT_NEAR(Shade64(m, wo, poly, false, GLINT_AREA_REFERENCE), point, 1e-4 * point);
  // LTC: the fitted lobe's density instead of f cos; bounded by the fit's shape error.
  EXPECT_NEAR(Shade64(m, wo, poly, false, GLINT_AREA_LTC), point, 0.25 * point);
}

// LTC against REFERENCE over roughness x view x light, per region, for GGX and Beckmann (both
// have their own fitted table). Reported, and asserted against bounds set from the measured
// errors plus a modest margin, so a regression in the fit or the lookup shows up. Error of a
// case: |LTC - REF| / max(REF, 1e-3) with radiance 1 and f0 = 1 (1e-3 ~ a thousandth of the
// light-filling albedo, so cases where the lobe misses the light are not divided by ~0).
TEST(AreaLtc, AgreesWithReferencePerRegion) {
  struct Light {
    const char *name;
    std::vector<V3> poly;
  };
  const std::vector<Light> lights = {
      {"small", Facing(Quad({0.6, 0.2, 2.0}, {0.15, 0, 0}, {0, 0.15, 0}))},
      {"medium", Facing(Quad({0.5, 0.0, 1.0}, {0.5, 0, 0}, {0, 0.5, 0}))},
      {"large", Facing(Quad({0.0, 0.0, 1.0}, {3, 0, 0}, {0, 3, 0}))},
      {"partly-below", TestPolygons()[2]},
      {"pentagon", TestPolygons()[4]},
  };
  struct Region {
    const char *name;
    double a_lo, a_hi, view_lo, view_hi;
    double bound_mean[2], bound_max[2];  // GGX, Beckmann
    double sum[2] = {0, 0}, max[2] = {0, 0}, abs_max[2] = {0, 0};
    int n[2] = {0, 0};
  };
  // Measured mean / max relative error, GGX | Beckmann (REFERENCE at 128 nodes as the truth):
  //   alpha 0.1-0.3, view < 60:  0.045 / 0.373 | 0.624 / 19.2
  //   alpha 0.3-0.6, view < 60:  0.041 / 0.306 | 0.099 / 1.46
  //   alpha 0.6-1.0, view < 60:  0.016 / 0.088 | 0.033 / 0.242
  //   alpha 0.1-0.3, view 60-85: 0.338 / 0.925 | 2.67  / 24.5
  //   alpha 0.3-0.6, view 60-85: 0.138 / 0.502 | 0.489 / 9.06
  //   alpha 0.6-1.0, view 60-85: 0.051 / 0.204 | 0.101 / 0.267
  // Grazing views are the LTC's known weak spot (the horizon-cut lobe, tools/ltc/README.md
  // "Fit quality"). Beckmann at alpha < 0.6 is worse by design, not by a bug: the LTC of a
  // cosine has GGX's heavy tails, the Gaussian lobe has none, so a light 10-40 deg off the
  // mirror direction gets ~2% of the albedo from the LTC where the truth is 1e-5..1e-3 (e.g.
  // alpha 0.1, view 70, pentagon: LTC 0.0247 vs 0.0002): large relative, small absolute error
  // (max |LTC - REF| is printed too). Bounds: measured + ~20%.
  std::vector<Region> regions = {
      {"alpha 0.1-0.3, view < 60", 0.1, 0.3, 0, 60, {0.055, 0.75}, {0.45, 23.0}},
      {"alpha 0.3-0.6, view < 60", 0.3, 0.6, 0, 60, {0.05, 0.12}, {0.37, 1.75}},
      {"alpha 0.6-1.0, view < 60", 0.6, 1.01, 0, 60, {0.02, 0.04}, {0.11, 0.29}},
      {"alpha 0.1-0.3, view 60-85", 0.1, 0.3, 60, 86, {0.41, 3.2}, {1.11, 29.5}},
      {"alpha 0.3-0.6, view 60-85", 0.3, 0.6, 60, 86, {0.17, 0.59}, {0.61, 10.9}},
      {"alpha 0.6-1.0, view 60-85", 0.6, 1.01, 60, 86, {0.062, 0.12}, {0.25, 0.32}},
  };
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    const int k = ndf == GLINT_NDF_GGX ? 0 : 1;
    for (double alpha : {0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0}) {
      for (double view : {0.0, 20.0, 40.0, 55.0, 60.0, 70.0, 78.0, 85.0}) {
        for (double phi : {20.0, 200.0}) {
          for (const Light &l : lights) {
            Mat m{ndf, alpha, alpha, 1.0};
            V3 wo = Wo(view, phi);
            double ref = Shade64(m, wo, l.poly, false, GLINT_AREA_REFERENCE, 128);
            double ltc = Shade64(m, wo, l.poly, false, GLINT_AREA_LTC);
            double err = std::fabs(ltc - ref) / std::max(ref, 1e-3);
            for (Region &g : regions) {
              if (alpha >= g.a_lo && alpha < g.a_hi && view >= g.view_lo && view < g.view_hi) {
                g.sum[k] += err;
                g.max[k] = std::max(g.max[k], err);
                g.abs_max[k] = std::max(g.abs_max[k], std::fabs(ltc - ref));
                ++g.n[k];
              }
            }
          }
        }
      }
    }
  }
  for (int k = 0; k < 2; ++k) {
    for (const Region &g : regions) {
      ASSERT_GT(g.n[k], 0);
      double mean = g.sum[k] / g.n[k];
      std::printf("LTC vs REFERENCE (%-8s) %-26s mean %.3f max %.3f (n=%d), max |LTC - REF| %.4f\n",
                  k == 0 ? "GGX" : "Beckmann", g.name, mean, g.max[k], g.n[k], g.abs_max[k]);
      EXPECT_LT(mean, g.bound_mean[k]) << g.name << (k == 0 ? " GGX" : " Beckmann");
      EXPECT_LT(g.max[k], g.bound_max[k]) << g.name << (k == 0 ? " GGX" : " Beckmann");
    }
  }
}

// The adaptive plane integration (second independent scheme) against the midpoint brute force
// (first one) where both are cheap: they share nothing but the BRDF, so their agreement checks
// the adaptive scheme itself before it is used as the truth for sharp lobes below.
TEST(AreaReference, AdaptivePlaneIntegrationMatchesBruteForce) {
  const Mat m{GLINT_NDF_GGX, 0.3, 0.3, 1.0};
  for (size_t k = 0; k < TestPolygons().size(); ++k) {
    double a = PlaneAdaptive(m, Wo(40, 30), TestPolygons()[k]);
    double b = BruteForce(m, Wo(40, 30), TestPolygons()[k], 700);
    // The midpoint brute force is the coarse one (its edge cells): ~5e-4 on the small triangle.
    EXPECT_NEAR(a, b, 1e-3 * std::max(b, 1e-3)) << "polygon " << k;
  }
}

// REFERENCE for smooth (sharp) lobes, alpha 0.01-0.1, against the adaptive plane integration,
// small (0.017 sr) and medium (0.6 sr) lights, views 0-80 deg with the mirror direction inside,
// across the edge of, and away from the light. The default 64 nodes per dimension is not enough
// for sharp lobes (measured worst relative error, GGX / Beckmann):
//   alpha  n=64        n=128       n=256       n=512       n=1024
//   0.01   2.7 / 4.3   1.1 / 1.4   9e-2/1e-1   1.7e-3/8e-3 3.1e-4/6.3e-7
//   0.03   0.48/0.37   8e-2/4.7e-2 1.0e-3/4e-4 2.3e-5/2e-8 7e-8
//   0.05   9e-2/4.5e-2 8.8e-3/1.6e-3 6e-5/3e-5 7e-8
//   0.1    6.9e-3/8e-3 1.6e-4      2e-6        5e-8
// (nodes have to resolve the lobe, of width ~alpha, across the triangle; the worst case is the
// lobe 10 deg above the horizon inside the partly-below light, next to the clipped triangles'
// horizon edge). Asserted: 1e-3 with the counts below (achieved: ~1e-7 on the small and medium
// lights, 3e-4 / 2e-5 / 6e-5 / 1.6e-4 on the large ones); alpha 0.01 needs 1024, the
// validation maximum.
TEST(AreaReference, SmoothLobesMatchAdaptivePlaneIntegration) {
  const std::vector<std::vector<V3>> lights = {
      Facing(Quad({0.6, 0.2, 2.0}, {0.15, 0, 0}, {0, 0.15, 0})),  // small, 0.017 sr
      Facing(Quad({0.5, 0.0, 1.0}, {0.5, 0, 0}, {0, 0.5, 0})),    // medium, 0.6 sr
      TestPolygons()[4],                                          // pentagon, 1.6 sr
      TestPolygons()[2],                                          // large, partly below
  };
  struct Case {
    double alpha;
    int samples;
    double bound_small_medium, bound_large;
  };
  const Case cases[] = {{0.01, 1024, 1e-3, 1e-3},
                        {0.03, 512, 1e-3, 1e-3},
                        {0.05, 256, 1e-3, 1e-3},
                        {0.1, 128, 1e-3, 1e-3}};
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    for (const Case &c : cases) {
      double worst[2] = {0, 0};
      for (size_t k = 0; k < lights.size(); ++k) {
        const int large = k >= 2 ? 1 : 0;
        // Mirror direction at the small light's centre (17 deg, phi 198), at the medium light's
        // centre (26.6 deg, phi 180), on its edge (0 deg), away from both, and 10 deg above the
        // horizon inside the partly-below light (80 deg, phi 20: the hardest case, where the
        // lobe meets the clipped triangles' horizon edge).
        for (V3 wo : {Wo(0), Wo(17, 198), Wo(26.6, 180), Wo(60, 180), Wo(80, 200), Wo(30, 20),
                      Wo(80, 20)}) {
          Mat m{ndf, c.alpha, c.alpha, 1.0};
          double truth = PlaneAdaptive(m, wo, lights[k]);
          double ref = Shade64(m, wo, lights[k], false, GLINT_AREA_REFERENCE, c.samples);
          double err = std::fabs(ref - truth) / std::max(truth, 1e-3);
          worst[large] = std::max(worst[large], err);
          EXPECT_LT(err, large ? c.bound_large : c.bound_small_medium)
              << "ndf " << ndf << " alpha " << c.alpha << " light " << k << " wo (" << wo.x << ", "
              << wo.y << ", " << wo.z << ") ref " << ref << " adaptive " << truth;
        }
      }
      std::printf(
          "REFERENCE-%d vs adaptive, %-8s alpha %.2f: worst relative error small/medium "
          "%.2e, large %.2e\n",
          c.samples, ndf == GLINT_NDF_GGX ? "GGX" : "Beckmann", c.alpha, worst[0], worst[1]);
    }
  }
}

// fp32: alpha 1e-4 and 1, grazing view, huge and tiny lights: finite and non-negative.
TEST(AreaLights, ExtremesAreFiniteAndNonNegativeInFp32) {
  const std::vector<std::vector<V3>> polys = {
      Facing(Quad({0, 0, 1}, {1e6, 0, 0}, {0, 1e6, 0})),         // fills the hemisphere
      Facing(Quad({0.3, 0.1, 1}, {1e-4, 0, 0}, {0, 1e-4, 0})),   // tiny
      Facing(Quad({3e3, 1e3, 2e3}, {0, 1, 0}, {-0.5, 0, 0.8})),  // far
      Facing(Quad({1, 0, 1e-3}, {0, 1, 0}, {0, 0, 1e-3})),       // grazing sliver
      TestPolygons()[2],                                         // partly below
  };
  for (double alpha : {1e-4, 1e-2, 1.0}) {
    for (double view : {0.0, 60.0, 89.9}) {
      for (size_t k = 0; k < polys.size(); ++k) {
        for (int method : {GLINT_AREA_LTC, GLINT_AREA_REFERENCE}) {
          Mat m{GLINT_NDF_GGX, alpha, alpha, 0.5};
          for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
            m.ndf = ndf;
            k32::real3 v = Shade32(m, Wo(view, 10), polys[k], true, method, 16);
            for (float c : {v.x, v.y, v.z}) {
              EXPECT_TRUE(std::isfinite(c) && c >= 0.0f)
                  << "alpha " << alpha << " view " << view << " polygon " << k << " method "
                  << method << " ndf " << ndf << " -> " << c;
            }
          }
        }
      }
    }
  }
}

}  // namespace
