// kernels/area_lights.h (polygon lights for the smooth model): the REFERENCE quadrature against an
// independent brute-force integration, LTC against REFERENCE per region, horizon and facing
// rules, the point-light limit, and fp32 extremes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "tools/ltc/ltc_table.h"

namespace k64 {
#define GLINT_USE_DOUBLE 1
#include "kernels/area_lights.h"
}  // namespace k64

namespace k32 {
#undef GLINT_COMPAT_H
#undef GLINT_FRAME_H
#undef GLINT_POLYGON_H
#undef GLINT_SMOOTH_BRDF_H
#undef GLINT_FRESNEL_H
#undef GLINT_NDF_H
#undef GLINT_AREA_LIGHTS_H
#undef GLINT_RNG_H
#undef GLINT_LTC_LOOKUP_H
#undef GLINT_AREA_LECOCQ_H
#undef GLINT_AREA_MONTE_CARLO_H
#undef GLINT_USE_DOUBLE
#undef R
#define GLINT_USE_DOUBLE 0
#include "kernels/area_lights.h"
}  // namespace k32

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

// LTC against REFERENCE over roughness x view x light, per region (reported, and asserted
// against bounds set from the measured errors with margin).
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
  };
  struct Region {
    const char *name;
    double r_lo, r_hi, view_lo, view_hi, bound_mean, bound_max;
    double sum = 0, max = 0;
    int n = 0;
  };
  std::vector<Region> regions = {
      // Measured (GGX, this sweep): mean / max 0.040 / 0.279, 0.028 / 0.218, 0.342 / 0.940,
      // 0.090 / 0.353. Grazing low roughness is the LTC's known weak spot (the horizon-cut
      // lobe, tools/ltc/README.md "Fit quality"); bounds are the measured values + ~25%.
      {"r 0.3-0.6, view < 60", 0.3, 0.6, 0, 60, 0.06, 0.35},
      {"r 0.6-1.0, view < 60", 0.6, 1.01, 0, 60, 0.04, 0.28},
      {"r 0.3-0.6, view 60-85", 0.3, 0.6, 60, 86, 0.45, 0.97},
      {"r 0.6-1.0, view 60-85", 0.6, 1.01, 60, 86, 0.12, 0.45},
  };
  for (int ndf : {GLINT_NDF_GGX}) {
    for (double r : {0.3, 0.45, 0.6, 0.8, 1.0}) {
      for (double view : {0.0, 30.0, 50.0, 70.0, 85.0}) {
        for (const Light &l : lights) {
          Mat m{ndf, r * r, r * r, 1.0};
          V3 wo = Wo(view, 20);
          double ref = Shade64(m, wo, l.poly, false, GLINT_AREA_REFERENCE, 64);
          double ltc = Shade64(m, wo, l.poly, false, GLINT_AREA_LTC);
          // Relative to the larger of the value and 1% of the light's albedo-scale irradiance.
          double err = std::fabs(ltc - ref) / std::max(ref, 1e-3);
          for (Region &g : regions) {
            if (r >= g.r_lo && r < g.r_hi && view >= g.view_lo && view < g.view_hi) {
              g.sum += err;
              g.max = std::max(g.max, err);
              ++g.n;
            }
          }
        }
      }
    }
  }
  for (const Region &g : regions) {
    ASSERT_GT(g.n, 0);
    double mean = g.sum / g.n;
    std::printf("LTC vs REFERENCE (GGX) %-24s mean %.3f max %.3f (n=%d)\n", g.name, mean, g.max,
                g.n);
    EXPECT_LT(mean, g.bound_mean) << g.name;
    EXPECT_LT(g.max, g.bound_max) << g.name;
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
