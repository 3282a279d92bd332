// kernels/area/area_lecocq.h (Lecocq et al. 2015 analytic polygon lights, LECOCQ and
// LECOCQ_PEARSON): both methods against the REFERENCE quadrature of kernels/area/area_lights.h per
// region (roughness band x view band, GGX and Beckmann), the identities the construction
// guarantees (hemisphere-filling light = albedo, additive contour sums under light subdivision,
// facing and horizon rules), and fp32 extremes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

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
V3 Cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double Dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

struct Mat {
  int ndf = GLINT_NDF_GGX;
  double ax = 0.3, ay = 0.3;
  double f0 = 1.0;  // grey Schlick
};

const float *Table(int ndf) {
  return glint::ltc_table::table(ndf == GLINT_NDF_BECKMANN ? Ndf::kBeckmann : Ndf::kGgx);
}

template <typename M, typename T>
M Material(const Mat &mat) {
  M m;
  m.ndf = mat.ndf;
  m.alpha_x = T(mat.ax);
  m.alpha_y = T(mat.ay);
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a.x = m.fresnel.a.y = m.fresnel.a.z = T(mat.f0);
  m.fresnel.b.x = m.fresnel.b.y = m.fresnel.b.z = T(0);
  return m;
}

enum Method { kLorentz = 0, kPearson = 1, kReference = 2, kLtc = 3 };

// Red channel in double. wo need not be normalised.
double Eval64(const Mat &mat, V3 wo, const std::vector<V3> &poly, Method method, int samples = 96) {
  using namespace k64;
  SmoothMaterial m = Material<SmoothMaterial, double>(mat);
  real3 v[GLINT_POLYGON_MAX_VERTICES];
  for (size_t i = 0; i < poly.size(); ++i) v[i] = make_real3(poly[i].x, poly[i].y, poly[i].z);
  int n = int(poly.size());
  real3 w = r3_normalize(make_real3(wo.x, wo.y, wo.z));
  switch (method) {
    case kReference:
      return area_reference_polygon(m, w, v, n, samples).x;
    case kLtc:
      return area_ltc_polygon(m, Table(mat.ndf), w, v, n).x;
    default:
      return area_lecocq_polygon(m, Table(mat.ndf), w, v, n, method == kPearson).x;
  }
}

k32::real3 Lecocq32(const Mat &mat, V3 wo, const std::vector<V3> &poly, int pearson) {
  using namespace k32;
  SmoothMaterial m = Material<SmoothMaterial, float>(mat);
  real3 v[GLINT_POLYGON_MAX_VERTICES];
  for (size_t i = 0; i < poly.size(); ++i)
    v[i] = make_real3(float(poly[i].x), float(poly[i].y), float(poly[i].z));
  real3 w = r3_normalize(make_real3(float(wo.x), float(wo.y), float(wo.z)));
  return area_lecocq_polygon(m, Table(mat.ndf), w, v, int(poly.size()), pearson);
}

// Quads facing the receiver at the origin (counter-clockwise seen from it).
std::vector<V3> Quad(V3 c, V3 u, V3 v) {
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

struct Light {
  const char *name;
  std::vector<V3> poly;
};
// Lights of several sizes and places; wo is at azimuth 20 deg, so "mirror" lights sit around
// azimuth 200 deg.
const std::vector<Light> &Lights() {
  static const std::vector<Light> lights = {
      {"small", Facing(Quad({0.6, 0.2, 2.0}, {0.15, 0, 0}, {0, 0.15, 0}))},
      {"small-mirror", Facing(Quad({-0.9, -0.35, 1.5}, {0.2, 0, 0}, {0, 0.2, 0.05}))},
      {"medium", Facing(Quad({0.5, 0.0, 1.0}, {0.5, 0, 0}, {0, 0.5, 0}))},
      {"medium-mirror", Facing(Quad({-0.8, -0.3, 0.8}, {0, 0.5, 0}, {0.2, 0, 0.4}))},
      {"large", Facing(Quad({0.0, 0.0, 1.0}, {3, 0, 0}, {0, 3, 0}))},
      {"partly-below", Facing({{-1, -1, -0.5}, {-1, 1, -0.5}, {1, 1, 1.5}, {1, -1, 1.5}})},
      {"grazing-wall", Facing(Quad({-2, -0.5, 0.3}, {0, 1.5, 0}, {0, 0, 0.6}))},
      {"pentagon",
       Facing({{1, 0, 1}, {0.31, 0.95, 1}, {-0.81, 0.59, 1}, {-0.81, -0.59, 1}, {0.31, -0.95, 1}})},
  };
  return lights;
}

struct Stats {
  std::vector<double> e;
  double Mean() const {
    double s = 0;
    for (double x : e) s += x;
    return e.empty() ? 0 : s / double(e.size());
  }
  double Pct(double q) const {
    std::vector<double> v = e;
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v[std::min(v.size() - 1, size_t(q * double(v.size())))];
  }
  double Max() const { return e.empty() ? 0 : *std::max_element(e.begin(), e.end()); }
};

struct Region {
  const char *name;
  double a_lo, a_hi, view_lo, view_hi;
  // Asserted bounds (mean, p95, max) for LECOCQ and LECOCQ_PEARSON.
  double lor[3], pea[3];
  Stats s[3];  // Lorentz, Pearson, LTC (LTC only printed, for comparison)
};

// Relative error, with a floor of 1% of the light-filling albedo scale (f0 = 1: albedo ~ 1),
// so that dim configurations (a glossy lobe missing a light) count by absolute error.
double RelErr(double x, double ref) {
  return std::fabs(x - ref) / std::max(ref, 1e-2);
}

TEST(AreaLecocq, AgreesWithReferencePerRegion) {
  // Bounds: measured (this sweep, GGX + Beckmann, see the printed table) * 1.15 + 0.01, except
  // where the measurement did not improve on the previous version (lobe-average W; kept bounds
  // marked "kept"). The remaining error: at low roughness the Phong lobe's missing GGX tail (a
  // light off the highlight gets ~0: the max ~1 entries), at high roughness and grazing views
  // the curvature of W (G2 near the horizon) around the mean half vector of step 6 and the
  // Phong shape of Beckmann at alpha ~1 (tools/lecocq/README.md).
  std::vector<Region> regions = {
      {"a 0.05-0.15, view < 50", 0.05, 0.15, 0, 50, {0.14, 0.65, 1.11}, {0.14, 0.70, 1.12}, {}},
      {"a 0.05-0.15, view 50-75", 0.05, 0.15, 50, 75, {0.17, 0.88, 1.11}, {0.16, 0.93, 1.14}, {}},
      // p95 and max kept.
      {"a 0.05-0.15, view 75-85", 0.05, 0.15, 75, 86, {0.25, 1.12, 1.15}, {0.24, 1.13, 1.16}, {}},
      {"a 0.15-0.4, view < 50", 0.15, 0.4, 0, 50, {0.14, 0.53, 0.79}, {0.13, 0.53, 0.70}, {}},
      {"a 0.15-0.4, view 50-75", 0.15, 0.4, 50, 75, {0.15, 0.58, 0.87}, {0.14, 0.45, 0.96}, {}},
      // PEARSON max kept.
      {"a 0.15-0.4, view 75-85", 0.15, 0.4, 75, 86, {0.21, 0.89, 1.11}, {0.20, 0.89, 1.12}, {}},
      {"a 0.4-1, view < 50", 0.4, 1.01, 0, 50, {0.18, 0.42, 0.65}, {0.18, 0.42, 0.65}, {}},
      {"a 0.4-1, view 50-75", 0.4, 1.01, 50, 75, {0.17, 0.39, 0.71}, {0.17, 0.39, 0.71}, {}},
      {"a 0.4-1, view 75-85", 0.4, 1.01, 75, 86, {0.16, 0.38, 1.32}, {0.16, 0.38, 1.37}, {}},
  };
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    for (double a : {0.05, 0.08, 0.12, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0}) {
      for (double view : {0.0, 25.0, 45.0, 55.0, 65.0, 75.0, 85.0}) {
        for (const Light &l : Lights()) {
          Mat m{ndf, a, a, 1.0};
          V3 wo = Wo(view, 20);
          double ref = Eval64(m, wo, l.poly, kReference, a < 0.15 ? 160 : 96);
          double e[3] = {RelErr(Eval64(m, wo, l.poly, kLorentz), ref),
                         RelErr(Eval64(m, wo, l.poly, kPearson), ref),
                         RelErr(Eval64(m, wo, l.poly, kLtc), ref)};
          for (Region &g : regions) {
            if (a >= g.a_lo && a < g.a_hi && view >= g.view_lo && view < g.view_hi) {
              for (int k = 0; k < 3; ++k) g.s[k].e.push_back(e[k]);
            }
          }
        }
      }
    }
  }
  double lsum = 0, psum = 0;
  size_t count = 0;
  std::printf("%-26s %-8s %7s %7s %7s\n", "region (GGX+Beckmann)", "method", "mean", "p95", "max");
  for (const Region &g : regions) {
    const char *names[3] = {"LECOCQ", "PEARSON", "(LTC)"};
    for (int k = 0; k < 3; ++k) {
      std::printf("%-26s %-8s %7.3f %7.3f %7.3f\n", g.name, names[k], g.s[k].Mean(),
                  g.s[k].Pct(0.95), g.s[k].Max());
    }
    const double *bounds[2] = {g.lor, g.pea};
    for (int k = 0; k < 2; ++k) {
      EXPECT_LT(g.s[k].Mean(), bounds[k][0]) << g.name << " " << names[k];
      EXPECT_LT(g.s[k].Pct(0.95), bounds[k][1]) << g.name << " " << names[k];
      EXPECT_LT(g.s[k].Max(), bounds[k][2]) << g.name << " " << names[k];
    }
    lsum += g.s[0].Mean() * double(g.s[0].e.size());
    psum += g.s[1].Mean() * double(g.s[1].e.size());
    count += g.s[0].e.size();
  }
  std::printf("overall mean: LECOCQ %.4f PEARSON %.4f (n=%zu)\n", lsum / double(count),
              psum / double(count), count);
  // LSM15: Lorentzian + Pearson VII is the more accurate of the two. True here on average over
  // the whole sweep (not in every region: see tools/lecocq/README.md).
  EXPECT_LE(psum, lsum);
}

// A light that fills the upper hemisphere returns the albedo (step 6 of the header: the
// hemisphere normaliser and the polygon go through the same approximation, W included), and the
// hemisphere integral of f cos is the albedo the REFERENCE gives too (up to table error).
TEST(AreaLecocq, HemisphereFillingLightGivesAlbedo) {
  const auto huge = Facing(Quad({0, 0, 1}, {1e5, 0, 0}, {0, 1e5, 0}));
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    for (double a : {0.1, 0.5, 1.0}) {
      for (double view : {0.0, 60.0}) {
        Mat m{ndf, a, a, 1.0};
        double ref = Eval64(m, Wo(view), huge, kReference, 128);
        for (Method method : {kLorentz, kPearson}) {
          EXPECT_NEAR(Eval64(m, Wo(view), huge, method), ref, 0.02 * ref)
              << "ndf " << ndf << " alpha " << a << " view " << view;
        }
      }
    }
  }
}

// Light subdivision: a quad and its two triangles. The contour sums (the Phong-lobe mass and
// the moments of step 6) are additive: interior edges are traversed both ways and cancel
// exactly (lecocq_edge is antisymmetric). The result is not: W is evaluated at each piece's own
// mean half vector (step 6), so whole and parts differ by W's variation (measured < 0.4%).
TEST(AreaLecocq, SubdivisionOfTheLight) {
  const auto q = Facing(Quad({0.3, -0.2, 1.0}, {0.6, 0, 0.1}, {0, 0.5, 0}));
  std::vector<V3> t1 = {q[0], q[1], q[2]}, t2 = {q[0], q[2], q[3]};
  for (double a : {0.05, 0.3, 0.9}) {
    for (Method method : {kLorentz, kPearson}) {
      Mat m{GLINT_NDF_GGX, a, a * 0.5, 1.0};
      double whole = Eval64(m, Wo(40, 200), q, method);
      double parts = Eval64(m, Wo(40, 200), t1, method) + Eval64(m, Wo(40, 200), t2, method);
      EXPECT_NEAR(whole, parts, 0.01 * whole) << "alpha " << a;
      using namespace k64;
      real3 wo = r3_normalize(make_real3(Wo(40, 200).x, Wo(40, 200).y, Wo(40, 200).z));
      double acc[3][4];
      const std::vector<V3> *polys[3] = {&q, &t1, &t2};
      for (int k = 0; k < 3; ++k) {
        real3 w[4];
        for (size_t i = 0; i < polys[k]->size(); ++i) {
          const V3 &p = (*polys[k])[i];
          w[i] = r3_normalize(make_real3(p.x, p.y, p.z));
        }
        lecocq_region(w, int(polys[k]->size()), wo, std::sqrt(0.5), std::sqrt(2.0), 1 / (a * a),
                      method == kPearson ? 1.0 : 0.0, acc[k]);
      }
      for (int j = 0; j < 4; ++j) {
        EXPECT_NEAR(acc[0][j], acc[1][j] + acc[2][j], 1e-12 + 1e-9 * std::fabs(acc[0][j]))
            << "alpha " << a << " moment " << j;
      }
    }
  }
}

// Anisotropic alpha: the stretch of step 2 is exact for D, the albedo uses sqrt(ax ay); W of
// step 6 is evaluated with the true alpha_x, alpha_y.
TEST(AreaLecocq, AnisotropicAgreesWithReference) {
  double worst[2] = {0, 0};
  for (double ax : {0.1, 0.3}) {
    for (double ratio : {0.25, 0.5}) {
      for (double view : {0.0, 45.0}) {
        for (const Light &l : Lights()) {
          for (int swap = 0; swap < 2; ++swap) {
            Mat m{GLINT_NDF_GGX, swap ? ax * ratio : ax, swap ? ax : ax * ratio, 1.0};
            double ref = Eval64(m, Wo(view, 20), l.poly, kReference, 128);
            for (int k = 0; k < 2; ++k) {
              worst[k] =
                  std::max(worst[k], RelErr(Eval64(m, Wo(view, 20), l.poly, Method(k)), ref));
            }
          }
        }
      }
    }
  }
  std::printf("anisotropic (alpha_y/alpha_x 0.25, 0.5): worst LECOCQ %.3f PEARSON %.3f\n", worst[0],
              worst[1]);
  EXPECT_LT(worst[0], 1.16);  // measured 0.997 (1.66 with the lobe-average W)
  EXPECT_LT(worst[1], 1.16);  // measured 1.000 (1.75 with the lobe-average W)
}

TEST(AreaLecocq, HorizonAndFacing) {
  const Mat m{GLINT_NDF_GGX, 0.3, 0.3, 1.0};
  const auto below = Facing({{-1, -1, -1}, {-1, 1, -1}, {1, 1, -0.1}, {1, -1, -0.1}});
  const auto front = Lights()[2].poly;
  std::vector<V3> back(front.rbegin(), front.rend());
  for (Method method : {kLorentz, kPearson}) {
    EXPECT_EQ(Eval64(m, Wo(30), below, method), 0.0);
    EXPECT_EQ(Lecocq32(m, Wo(30), below, method == kPearson).x, 0.0f);
    double f = Eval64(m, Wo(30), front, method);
    EXPECT_GT(f, 0.0);
    // The facing rule is the caller's (area_polygon_weight); the integral itself is unsigned.
    EXPECT_NEAR(Eval64(m, Wo(30), back, method), f, 1e-12 * f);
    EXPECT_EQ(Eval64(m, Wo(95), front, method), 0.0) << "view below the horizon";
    EXPECT_EQ(Eval64(m, {0, 0.3, 0}, front, method), 0.0) << "view in the horizon";
  }
}

// fp32: alpha 1e-4 and 1, grazing view, huge and tiny lights: finite and non-negative.
TEST(AreaLecocq, ExtremesAreFiniteAndNonNegativeInFp32) {
  const std::vector<std::vector<V3>> polys = {
      Facing(Quad({0, 0, 1}, {1e6, 0, 0}, {0, 1e6, 0})),                   // fills the hemisphere
      Facing(Quad({0.3, 0.1, 1}, {1e-4, 0, 0}, {0, 1e-4, 0})),             // tiny
      Facing(Quad({-0.3, -0.1, 1}, {1e-6, 0, 0}, {0, 1e-6, 0})),           // tiny, at the highlight
      Facing(Quad({3e3, 1e3, 2e3}, {0, 1, 0}, {-0.5, 0, 0.8})),            // far
      Facing(Quad({1, 0, 1e-3}, {0, 1, 0}, {0, 0, 1e-3})),                 // grazing sliver
      Facing({{-1, -1, -0.5}, {-1, 1, -0.5}, {1, 1, 1.5}, {1, -1, 1.5}}),  // partly below
      Facing({{0, 0, 1}, {1, 0, 1}, {2, 0, 1}}),                           // degenerate (collinear)
  };
  for (double ax : {1e-4, 1e-2, 0.3, 1.0}) {
    for (double ay : {1e-4, 1.0}) {
      for (double view : {0.0, 17.0, 60.0, 89.9, 89.999}) {
        for (size_t k = 0; k < polys.size(); ++k) {
          for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
            for (int pearson : {0, 1}) {
              Mat m{ndf, ax, ay, 0.5};
              k32::real3 v = Lecocq32(m, Wo(view, 200), polys[k], pearson);
              for (float c : {v.x, v.y, v.z}) {
                EXPECT_TRUE(std::isfinite(c) && c >= 0.0f && c <= 1.0f)
                    << "alpha " << ax << "," << ay << " view " << view << " polygon " << k
                    << " ndf " << ndf << " pearson " << pearson << " -> " << c;
              }
            }
          }
        }
      }
    }
  }
}

}  // namespace
