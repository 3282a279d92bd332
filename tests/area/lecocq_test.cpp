// kernels/area/area_lecocq.h (Lecocq et al. 2015 analytic polygon lights, LECOCQ and
// LECOCQ_PEARSON): the fitted components against their stated accuracy (the Phong lobe's KS
// distance, the contour sums with the peak functions against the exact Phong-lobe mass), why
// tail-lit lights get about 0 (the Phong lobe itself), both methods against the REFERENCE
// quadrature of kernels/area/area_lights.h per region (a regression guard), the identities the
// construction guarantees (hemisphere-filling light = albedo, additive contour sums under light
// subdivision, facing and horizon rules), and fp32 against fp64.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <vector>

#include "data/ltc/ltc_table.h"
#include "tests/support/kernels_both_precisions.h"
#include "tests/support/plane_adaptive.h"

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

// Relative error, with a floor of 1% of the light-filling albedo scale (f0 = 1: albedo ~ 1),
// so that dim configurations (a glossy lobe missing a light) count by absolute error.
double RelErr(double x, double ref) {
  return std::fabs(x - ref) / std::max(ref, 1e-2);
}

// ---------------------------------------------------------------------------------------------
// The fitted accuracies the header states (its generated block, tools/lecocq/README.md):
//  H3, the Phong lobe (h.z)^N for the projected NDF D(h)(h.z): worst Kolmogorov-Smirnov distance
//     between the cap CDFs (fraction of the lobe within theta_h < beta), over alpha in [1e-3, 1];
constexpr double kKsGgx = 0.101898, kKsBeckmann = 0.0716842;
//  L1-L2 / P1-P3, the peak functions: worst sup_t |int_0^t model - int_0^t I| / int_0^(pi/2) I
//     over N in [1.05, 1e7] ([4, 1e7] for the Pearson mixture) and p = c^(N+1) in [0.02, 1].
constexpr double kSupLorentz = 0.0369229, kSupPearson = 0.0368025;

double Ks(int ndf) {
  return ndf == GLINT_NDF_BECKMANN ? kKsBeckmann : kKsGgx;
}

// What a KS distance guarantees for a light: the lobe mass of a region in (stretched) half-vector
// space is int p(theta) phi(theta) dtheta, phi(theta) in [0, 1] the fraction of the circle at
// polar angle theta inside the region. Integrating by parts, two lobes with cap CDFs F_1, F_2
// differ by |int (F_1 - F_2) dphi| <= KS * TV(phi), and TV(phi) <= 2 when phi rises once and
// falls once (a convex light). So the Phong lobe may misplace up to 2 KS of the albedo on any
// light. A light whose truth is below that is "tail-lit": the fit says nothing about it, and the
// Phong lobe, which has no GGX tail, indeed gives it about 0
// (TailLitLightsAreThePhongLobesMissingTail shows it is the lobe model itself, not its
// integration). Such cases are excluded from the relative-error statistics and asserted against the
// absolute 2 KS bound instead.
double TableAlbedo(const Mat &mat, V3 wo) {
  double e[GLINT_LTC_ENTRY];
  k64::area_ltc_lookup(Table(mat.ndf), std::sqrt(mat.ax * mat.ay), Normalize(wo).z, e);
  return e[4];  // f0 = 1: the magnitude
}
bool TailLit(const Mat &mat, V3 wo, double ref) {
  return ref < 2 * Ks(mat.ndf) * TableAlbedo(mat, wo);
}

// LECOCQ and LECOCQ_PEARSON against REFERENCE per region (roughness band x view band, GGX and
// Beckmann together). A REGRESSION GUARD, not an accuracy bound: the end-to-end error has no
// error analysis to bound it. Two of the method's steps have none: W taken at the lobe-weighted
// mean half vector (README Eq. N2, whose Jensen gap dominates at alpha >= 0.4: e.g. GGX alpha 1
// at normal view, where W = G2, the hemisphere normaliser W(h_H) = G2(n, n) = 1 while the lobe
// average of G2 is the albedo, 0.31; the medium light comes out 36% low) and the great-arc chords
// of step 1 (pi/16 pieces in wi space, whose h-images curve strongly near the lobe at grazing
// views: Beckmann alpha 0.05, view 85, a wall holding the whole lobe got 0.71 instead of 0.94;
// pi/64 pieces gave 0.935; since session 10 the pieces near wi = -wo are cut further by
// lecocq_subsplit, and a wall 2 m away at the mirror azimuth, 0 to 0.6 m high, holding that lobe
// gets 0.936 against REFERENCE 0.935 instead of 0.863). The components that do have a fitted
// accuracy are asserted against it below (PhongLobeWithinTheFittedKs,
// PeakFunctionsWithinTheFittedSupError, ContourSumsMatchThePhongLobeMassWithinTheFit). Bounds: the
// measured value's next round level (1, 1.5, 2, 3, 5, 7 x 10^k). Tail-lit cases (see TailLit) are
// left out of the relative statistics and checked against the KS bound on the absolute error, 2 KS
// x albedo.
TEST(AreaLecocq, AgreesWithReferencePerRegionRegressionGuard) {
  struct Region {
    const char *name;
    double a_lo, a_hi, view_lo, view_hi;
    // Guarded (mean, p95, max) for LECOCQ and LECOCQ_PEARSON.
    double lor[3], pea[3];
    Stats s[3];  // Lorentz, Pearson, LTC (LTC only printed, for comparison)
    int tail = 0;
  };
  std::vector<Region> regions = {
      // Measured (LECOCQ | PEARSON mean / p95 / max) in the comments.
      // Session 10 (lecocq_subsplit near wi = -wo, views beyond ~48 deg) moved the 50-85 deg
      // rows; before it: 0.034 / 0.147 / 0.231 | 0.035 / 0.159 / 0.243, 0.075 / 0.250 / 0.435 |
      // 0.077 / 0.261 / 0.443, 0.057 / 0.177 / 0.199 | 0.056 / 0.172 / 0.185, 0.079 / 0.482 /
      // 0.516 | 0.080 / 0.480 / 0.523, 0.101 / 0.249 / 0.293 | 0.102 / 0.250 / 0.293, 0.100 /
      // 0.266 / 0.320 | 0.101 / 0.266 / 0.327.
      // 0.023 / 0.130 / 0.190 | 0.023 / 0.117 / 0.184
      {"a 0.05-0.15, view < 50", 0.05, 0.15, 0, 50, {0.03, 0.15, 0.2}, {0.03, 0.15, 0.2}, {}},
      // 0.034 / 0.153 / 0.231 | 0.035 / 0.159 / 0.243
      {"a 0.05-0.15, view 50-75", 0.05, 0.15, 50, 75, {0.05, 0.2, 0.3}, {0.05, 0.2, 0.3}, {}},
      // 0.068 / 0.250 / 0.373 | 0.070 / 0.262 / 0.382
      {"a 0.05-0.15, view 75-85", 0.05, 0.15, 75, 86, {0.1, 0.3, 0.5}, {0.1, 0.3, 0.5}, {}},
      // 0.038 / 0.165 / 0.240 | 0.032 / 0.159 / 0.230
      {"a 0.15-0.4, view < 50", 0.15, 0.4, 0, 50, {0.05, 0.2, 0.3}, {0.05, 0.2, 0.3}, {}},
      // 0.058 / 0.177 / 0.196 | 0.058 / 0.172 / 0.181
      {"a 0.15-0.4, view 50-75", 0.15, 0.4, 50, 75, {0.07, 0.2, 0.2}, {0.07, 0.2, 0.2}, {}},
      // 0.084 / 0.436 / 0.495 | 0.086 / 0.436 / 0.501
      {"a 0.15-0.4, view 75-85", 0.15, 0.4, 75, 86, {0.1, 0.5, 0.7}, {0.1, 0.5, 0.7}, {}},
      // 0.113 / 0.319 / 0.342 | 0.112 / 0.313 / 0.342
      {"a 0.4-1, view < 50", 0.4, 1.01, 0, 50, {0.15, 0.5, 0.5}, {0.15, 0.5, 0.5}, {}},
      // 0.101 / 0.250 / 0.293 | 0.102 / 0.251 / 0.293
      {"a 0.4-1, view 50-75", 0.4, 1.01, 50, 75, {0.15, 0.3, 0.3}, {0.15, 0.3, 0.3}, {}},
      // 0.102 / 0.266 / 0.315 | 0.102 / 0.266 / 0.322
      {"a 0.4-1, view 75-85", 0.4, 1.01, 75, 86, {0.15, 0.3, 0.5}, {0.15, 0.3, 0.5}, {}},
  };
  double worst_tail_abs = 0;
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    for (double a : {0.05, 0.08, 0.12, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0}) {
      for (double view : {0.0, 25.0, 45.0, 55.0, 65.0, 75.0, 85.0}) {
        for (const Light &l : Lights()) {
          Mat m{ndf, a, a, 1.0};
          V3 wo = Wo(view, 20);
          double ref = Eval64(m, wo, l.poly, kReference, a < 0.15 ? 160 : 96);
          double x[3] = {Eval64(m, wo, l.poly, kLorentz), Eval64(m, wo, l.poly, kPearson),
                         Eval64(m, wo, l.poly, kLtc)};
          const bool tail = TailLit(m, wo, ref);
          if (tail) {
            const double bound = 2 * Ks(ndf) * TableAlbedo(m, wo);
            for (int k = 0; k < 2; ++k) {
              worst_tail_abs = std::max(worst_tail_abs, std::fabs(x[k] - ref) / bound);
              EXPECT_LT(std::fabs(x[k] - ref), bound)
                  << "tail-lit: ndf " << ndf << " alpha " << a << " view " << view << " " << l.name
                  << " method " << k << " ref " << ref << " got " << x[k];
            }
          }
          for (Region &g : regions) {
            if (a >= g.a_lo && a < g.a_hi && view >= g.view_lo && view < g.view_hi) {
              if (tail) {
                ++g.tail;
                continue;
              }
              for (int k = 0; k < 3; ++k) g.s[k].e.push_back(RelErr(x[k], ref));
            }
          }
        }
      }
    }
  }
  double lsum = 0, psum = 0;
  size_t count = 0;
  std::printf("%-26s %-8s %7s %7s %7s  (tail-lit cases left out)\n", "region (GGX+Beckmann)",
              "method", "mean", "p95", "max");
  for (const Region &g : regions) {
    const char *names[3] = {"LECOCQ", "PEARSON", "(LTC)"};
    for (int k = 0; k < 3; ++k) {
      std::printf("%-26s %-8s %7.3f %7.3f %7.3f  (n=%zu, %d tail-lit)\n", g.name, names[k],
                  g.s[k].Mean(), g.s[k].Pct(0.95), g.s[k].Max(), g.s[k].e.size(), g.tail);
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
  std::printf(
      "overall mean: LECOCQ %.4f PEARSON %.4f (n=%zu); tail-lit worst |x - ref| / "
      "(2 KS albedo) %.3f\n",
      lsum / double(count), psum / double(count), count, worst_tail_abs);
  // LSM15: Lorentzian + Pearson VII is the more accurate of the two. True here on average over
  // the whole sweep (not in every region: see tools/lecocq/README.md).
  EXPECT_LE(psum, lsum);
}

// The method's lobe model, integrated exactly: the kernel's BRDF with D replaced by the Phong
// lobe of step 3, (N + 1) / (2 pi) (h.z)^(N - 1) (isotropic alpha), W exact, by the adaptive
// plane quadrature of tests/support/plane_adaptive.h; normalised like the method (the albedo
// times the Phong-lobe share of the light, W included).
double FCos(const Mat &mat, V3 wi, V3 wo, bool phong) {
  using namespace k64;
  SmoothMaterial m = Material<SmoothMaterial, double>(mat);
  real3 i = make_real3(wi.x, wi.y, wi.z), o = r3_normalize(make_real3(wo.x, wo.y, wo.z));
  double f = smooth_reflect_cos(m, i, o).x;
  if (!phong || f == 0) return f;
  real3 h = r3_normalize(r3_add(i, o));
  double N = lecocq_phong_exponent(m.ndf, mat.ax);
  return f * (N + 1) / (2 * M_PI) * std::pow(h.z, N - 1) / ndf_D(m.ndf, h, mat.ax, mat.ay);
}
double Integrate(const Mat &mat, V3 wo, const std::vector<V3> &poly, bool phong) {
  using glint::test::plane::Vec;
  std::vector<Vec> p;
  for (V3 v : poly) p.push_back({v.x, v.y, v.z});
  return glint::test::plane::PlaneAdaptive(
      [&](Vec wi, Vec o) {
        return FCos(mat, {wi.x, wi.y, wi.z}, {o.x, o.y, o.z}, phong);
      },
      {wo.x, wo.y, wo.z}, p, 1e-7);
}

// Why some lit cases return about 0 (relative error ~1 against REFERENCE): GGX at low roughness
// or grazing views with a light off the highlight, which only the GGX tail reaches. The Phong
// lobe of step 3 decays like exp(-N theta^2 / 2) where GGX decays like theta^-4, so the method's
// lobe model, integrated EXACTLY (no contour sums, exact W), already holds less than 10% of the
// truth there: the limit is H3, not the peak functions or a bug. The method then returns the
// noise of its contour sums (the peak functions' error exceeds the tiny Phong mass, so even the
// sign of the light's contour sum can flip; lecocq_weight then sees a mean half vector below the
// horizon and returns exactly 0). Measured (truth / Phong model / LECOCQ / LECOCQ_PEARSON):
//   GGX 0.05, view 85, medium-mirror: 0.0871 / 0.0065 / 0      / 0.0083
//   GGX 0.12, view 85, pentagon:      0.0841 / 0.0017 / 2e-9   / 0
//   GGX 0.05, view 25, medium:        0.0096 / 1e-5   / 2.7e-5 / 9e-6
//   GGX 0.08, view 75, pentagon:      0.0306 / 1.1e-4 / 1.7e-3 / 6.6e-4
TEST(AreaLecocq, TailLitLightsAreThePhongLobesMissingTail) {
  const auto huge = Facing(Quad({0, 0, 1}, {1e4, 0, 0}, {0, 1e4, 0}));
  struct Case {
    double alpha, view;
    int light;
  };
  const Case cases[] = {{0.05, 85, 3}, {0.12, 85, 7}, {0.05, 25, 2}, {0.08, 75, 7}};
  for (const Case &c : cases) {
    {
      const int ndf = GLINT_NDF_GGX;
      Mat m{ndf, c.alpha, c.alpha, 1.0};
      V3 wo = Wo(c.view, 20);
      const Light &l = Lights()[size_t(c.light)];
      double truth = Integrate(m, wo, l.poly, false), albedo = Integrate(m, wo, huge, false);
      double phong = albedo * Integrate(m, wo, l.poly, true) / Integrate(m, wo, huge, true);
      double lor = Eval64(m, wo, l.poly, kLorentz), pea = Eval64(m, wo, l.poly, kPearson);
      std::printf(
          "%-8s alpha %.2f view %2.0f %-14s truth %.4e Phong model %.4e LECOCQ %.4e "
          "PEARSON %.4e (tail-lit: %s)\n",
          ndf == GLINT_NDF_GGX ? "GGX" : "Beckmann", c.alpha, c.view, l.name, truth, phong, lor,
          pea, TailLit(m, wo, truth) ? "yes" : "no");
      EXPECT_TRUE(TailLit(m, wo, truth)) << l.name;
      EXPECT_LT(phong, 0.1 * truth) << l.name << ": the Phong lobe misses the light";
      EXPECT_LT(std::max(lor, pea), 0.25 * truth) << l.name << ": the method returns ~0";
    }
  }
}

// H3: the kernel's Phong exponent (lecocq_phong_exponent) against the NDFs' projected cap CDFs in
// closed form (GGX tan^2 b / (alpha^2 + tan^2 b), Beckmann 1 - exp(-tan^2 b / alpha^2), Phong
// 1 - cos^(N+1) b), on an alpha grid (300 points) other than the fit's: the worst KS distance is
// the one the header states. Off the fit's grid the distance can only exceed the stated worst
// by its variation between grid points; allowed: 1e-3.
TEST(AreaLecocq, PhongLobeWithinTheFittedKs) {
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    double worst = 0, worst_alpha = 0;
    for (int i = 0; i < 300; ++i) {
      const double alpha = std::pow(10.0, -3.0 + 3.0 * (i + 0.37) / 300);
      const double N = k64::lecocq_phong_exponent(ndf, alpha);
      double ks = 0;
      for (int j = 0; j < 4000; ++j) {
        const double t2 = std::pow(alpha * std::pow(10.0, -3.0 + 6.0 * j / 4000.0), 2);
        const double cap =
            ndf == GLINT_NDF_GGX ? t2 / (alpha * alpha + t2) : -std::expm1(-t2 / (alpha * alpha));
        const double phong = -std::expm1(-0.5 * (N + 1) * std::log1p(t2));  // 1 - cos^(N+1)
        ks = std::max(ks, std::fabs(cap - phong));
      }
      if (ks > worst) {
        worst = ks;
        worst_alpha = alpha;
      }
    }
    std::printf("%-8s worst KS distance %.4f at alpha %.4f (stated %.4f)\n",
                ndf == GLINT_NDF_GGX ? "GGX" : "Beckmann", worst, worst_alpha, Ks(ndf));
    EXPECT_LT(worst, Ks(ndf) + 1e-3);
  }
}

double EdgeIHalf(double s2, double N) {
  // int_0^(pi/2) I(t) dt, I = (1 - x^(N+1)) / (1 - x^2), x = c cos t, c^2 = 1 - s^2 (Eq. E2).
  const double c = std::sqrt(1 - s2);
  auto I = [&](double t) {
    const double x = c * std::cos(t);
    if (x >= 1) return 0.5 * (N + 1);
    return -std::expm1((N + 1) * std::log(x)) / ((1 - x) * (1 + x));
  };
  std::vector<double> cuts = {-M_PI / 2, M_PI / 2};
  glint::test::plane::AddGradedCuts(0.0, -M_PI / 2, M_PI / 2, &cuts);
  std::sort(cuts.begin(), cuts.end());
  return 0.5 * glint::test::plane::Adaptive(I, cuts, 1e-10, 1e-300);
}

// L1-L2 / P1-P3: the kernel's peak-function integral (lecocq_peak_integral, closed forms of the
// Lorentzian and Pearson VII integrals with the generated widths) against quadrature of the exact
// edge integrand I of Eq. E2, as the fit measures it: sup over t in [0, pi/2] of
// |int_0^t model - int_0^t I| / int_0^(pi/2) I, over N in [1.05, 1e7] ([5, 1e7] for the Pearson
// mixture, fully blended in from N = 5) and p = c^(N+1) in [0.02, 1], on grids other than the
// fit's. Bound: the stated worst; off the fit's grid the error can exceed it only by its
// variation between grid points (allowed: 2e-3, i.e. 5% of the stated value).
TEST(AreaLecocq, PeakFunctionsWithinTheFittedSupError) {
  for (int pearson : {0, 1}) {
    const double stated = pearson ? kSupPearson : kSupLorentz;
    double worst = 0, worst_N = 0, worst_p = 0;
    for (int i = 0; i < 24; ++i) {
      const double N =
          pearson ? 5 * std::pow(2e6, (i + 0.3) / 24) : 1.05 * std::pow(9.5e6, (i + 0.3) / 24);
      for (double p : {0.021, 0.035, 0.07, 0.15, 0.25, 0.35, 0.45, 0.55, 0.65, 0.75, 0.85, 0.93,
                       0.98, 0.999}) {
        const double s2 = -std::expm1(2 * std::log(p) / (N + 1)), c = std::sqrt(1 - s2);
        auto I = [&](double t) {
          const double x = c * std::cos(t);
          return -std::expm1((N + 1) * std::log(x)) / ((1 - x) * (1 + x));
        };
        // t nodes: uniform in [0, pi/2] and geometric down to the peak's width ~ s.
        std::vector<double> ts;
        for (int k = 0; k <= 200; ++k) ts.push_back(M_PI / 2 * k / 200);
        for (int k = 0; k <= 200; ++k)
          ts.push_back(std::sqrt(s2) * std::pow(10.0, -2.0 + 4.0 * k / 200));
        std::sort(ts.begin(), ts.end());
        ts.erase(std::remove_if(ts.begin(), ts.end(), [](double t) { return t > M_PI / 2; }),
                 ts.end());
        // One Gauss-Kronrod rule per interval: the nodes resolve the peak, so each piece is
        // smooth; checked against the adaptive half-range integral.
        std::vector<double> F(ts.size(), 0.0);
        for (size_t k = 1; k < ts.size(); ++k)
          F[k] = F[k - 1] + glint::test::plane::Gk15(I, ts[k - 1], ts[k]).value;
        const double half = EdgeIHalf(s2, N);
        ASSERT_NEAR(F.back(), half, 1e-9 * half) << "N " << N << " p " << p;
        double sup = 0;
        for (size_t k = 0; k < ts.size(); ++k) {
          const double model = k64::lecocq_peak_integral(s2, N, pearson ? 1.0 : 0.0, 0, 1,
                                                         std::sin(ts[k]), std::cos(ts[k]));
          sup = std::max(sup, std::fabs(model - F[k]) / half);
        }
        if (sup > worst) {
          worst = sup;
          worst_N = N;
          worst_p = p;
        }
      }
    }
    std::printf("%-8s peak function: worst sup-error %.4f at N %.3g, p %.3f (stated %.4f)\n",
                pearson ? "PEARSON" : "LECOCQ", worst, worst_N, worst_p, stated);
    EXPECT_LT(worst, stated + 2e-3);
  }
}

// Steps 4-5 (README Eq. E1-E3 with the peak functions L1-L2 / P1-P3) on spherical polygons given
// directly in (stretched) half-vector space: the contour sum of lecocq_edge against the Phong
// lobe mass (N + 1) int_Q (u.z)^N du by the adaptive plane quadrature (a spherical polygon with
// great-arc edges is the central projection of a planar one), and the moment of step 6 (Eq. M1,
// exponent N + 1) likewise. Bound from the fit, per edge: the peak function's integral over any
// [t0, t1] is within 2 x sup-error x int_0^(pi/2) I of the exact one (the fit bounds the error
// of int_0^t for every t), so |sum - mass| <= sum_e |s_e| 2 sup int_0^(pi/2) I_e (computed by
// quadrature of Eq. E2). The exact identity E1-E3 itself is checked too: with a peak function
// replaced by quadrature of I it would be exact; here it is exact up to the fitted error.
TEST(AreaLecocq, ContourSumsMatchThePhongLobeMassWithinTheFit) {
  auto dir = [](double theta, double phi) {
    return V3{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
  };
  // Counter-clockwise seen from outside the sphere (like the hemisphere of step 6).
  const std::vector<std::vector<V3>> polys = {
      {dir(0.3, 0), dir(0.3, 2.1), dir(0.3, 4.2)},                 // around the pole
      {dir(0.05, 0.4), dir(0.2, 1.0), dir(0.12, 2.5)},             // small, around the pole
      {dir(0.4, 0), dir(0.8, 0.1), dir(0.8, 0.6), dir(0.4, 0.5)},  // off the pole
      {dir(1.0, 1), dir(1.4, 1.2), dir(1.2, 1.6)},                 // far from the pole
      {dir(M_PI / 2, -0.5), dir(M_PI / 2, 0.5), dir(1.2, 0.3), dir(1.2, -0.3)},  // on the horizon
      {dir(0.02, 3.0), dir(0.6, 0.2), dir(0.61, 0.25)},  // sliver from the pole
  };
  double worst_ratio = 0;
  for (double N : {1.0, 1.5, 5.0, 30.0, 300.0, 3000.0, 1e5}) {
    for (int pearson : {0, 1}) {
      if (pearson && N < 5) continue;  // the Pearson fit covers N >= 4; blended in from N = 3
      const double sup = pearson ? kSupPearson : kSupLorentz;
      for (size_t k = 0; k < polys.size(); ++k) {
        const auto &q = polys[k];
        double acc[4] = {0, 0, 0, 0}, bound[2] = {0, 0};
        for (size_t i = 0; i < q.size(); ++i) {
          V3 a = q[i], b = q[(i + 1) % q.size()];
          k64::lecocq_edge(k64::make_real3(a.x, a.y, a.z), k64::make_real3(b.x, b.y, b.z), N,
                           pearson ? 1.0 : 0.0, acc);
          V3 n = Normalize(Cross(a, b));
          for (int j = 0; j < 2; ++j)
            bound[j] += std::fabs(n.z) * 2 * sup * EdgeIHalf(n.z * n.z, N + j);
        }
        // The polygon's central projection onto the plane through its mean direction.
        V3 c = Normalize(std::accumulate(q.begin(), q.end(), V3{0, 0, 0}, Add));
        std::vector<glint::test::plane::Vec> planar;
        for (V3 v : q) planar.push_back({v.x / Dot(c, v), v.y / Dot(c, v), v.z / Dot(c, v)});
        for (int j = 0; j < 2; ++j) {
          const double e = N + j;
          const double mass = glint::test::plane::PlaneAdaptive(
              [&](glint::test::plane::Vec u, glint::test::plane::Vec) {
                return (e + 1) * std::pow(std::max(u.z, 0.0), e);
              },
              {0, 0, 1}, planar, 1e-10);
          // Counter-clockwise from outside: the E3 sum is minus the mass (the hemisphere's
          // orientation, for which area_lecocq_polygon's step 6 gives -2 pi).
          const double err = std::fabs(-acc[j] - mass);
          worst_ratio = std::max(worst_ratio, err / bound[j]);
          EXPECT_LE(err, bound[j] + 1e-9 * mass)
              << "polygon " << k << " N " << e << " pearson " << pearson << " sum " << -acc[j]
              << " mass " << mass;
        }
      }
    }
  }
  std::printf("contour sums vs Phong mass: worst error / fitted bound %.3f\n", worst_ratio);
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

// ---------------------------------------------------------------------------------------------
// Grazing views (wo.z -> 0): the session 9 probe found LECOCQ / LECOCQ_PEARSON up to 10x the
// REFERENCE value at wo.z < 0.01, and a quad split into two triangles giving twice the quad.
// Root cause: the hemisphere normaliser's contour (step 6) crosses the half-vector map's singular
// point wi = -wo, where a uniform wi-space piece has nearly antipodal h-images and its great arc
// missed the lobe (lecocq_subsplit in kernels/area/area_lecocq.h). Views in wo's azimuth plane
// and 200 deg away hit a hemisphere vertex or not; 20 and 333 deg are generic.
V3 GrazingWo(double woz, double phi_deg) {
  const double s = std::sqrt(1 - woz * woz), p = phi_deg * M_PI / 180;
  return {s * std::cos(p), s * std::sin(p), woz};
}
// int_{-pi/2}^{pi/2} cos^k = sqrt(pi) Gamma((k + 1) / 2) / Gamma(k / 2 + 1).
double CosPowerIntegral(double k) {
  return std::sqrt(M_PI) * std::exp(std::lgamma((k + 1) / 2) - std::lgamma(k / 2 + 1));
}

// The hemisphere normaliser tau(H) against its closed-form limit. h = normalize(wi + wo) halves
// the polar angle about wo, so as wo.z = eps -> 0 the h-image of the upper hemisphere (wi.z >= 0
// <=> 2 (wo.h) h.z >= eps) tends to the quarter sphere {h.x' > 0, h.z > 0} (x' along wo's
// azimuth): exactly half of the Phong lobe, tau(H) -> (1/2) (N + 1) int_{h.z>0} (h.z)^N = pi
// (isotropic, no stretch). To first order in eps the image also holds the strip 0 > h.x' >
// -eps (h.z - 1 / (2 h.z)) beyond the great semicircle x' = 0 through the lobe, of Phong mass
// eps (N + 1) (C_{N+1} - C_{N-1} / 2), C_k = int cos^k over the semicircle.
// Tolerance: that first-order term again (the remainder is O(eps^2) with a constant of the same
// kind) plus the peak functions' fitted error. On the limit lune the contour sum is exact (the
// horizon edge has s = 1, where I = 1 and both peak functions are exact; the edge through the
// lobe has s = 0 and contributes nothing); at finite eps the pieces leaving its two corners
// (0, +-1, 0) carry a fitted error of at most 2 sup int_0^(pi/2) |s| I dt <= pi sup each
// (|s| I <= |s| / (s^2 + c^2 sin^2 t), whose half-range integral is pi / 2): 2 pi sup in all.
// Before the fix tau(H) was 0.0017 instead of 3.27 (GGX alpha 0.1, wo.z 0.01, azimuth 20) and
// 0.71 instead of 3.18 (alpha 0.3): half the lobe or more lost.
TEST(AreaLecocq, GrazingViewsHemisphereNormaliserIsHalfTheLobe) {
  using namespace k64;
  real3 hemi[8];
  for (int k = 0; k < 8; ++k)
    hemi[k] = make_real3(std::cos(k * M_PI / 4), std::sin(k * M_PI / 4), 0);
  double worst = 0;
  for (double woz : {1e-2, 1e-3, 3e-4}) {
    for (double phi : {0.0, 20.0, 200.0, 333.0}) {
      for (double a : {0.05, 0.1, 0.3, 0.6, 1.0}) {
        for (int pearson : {0, 1}) {
          const double N = lecocq_phong_exponent(GLINT_NDF_GGX, a);
          const double pw = pearson ? std::clamp((N - 3) / 2, 0.0, 1.0) : 0.0;
          const V3 o = GrazingWo(woz, phi);
          double acc[4];
          lecocq_region(hemi, 8, make_real3(o.x, o.y, o.z), 1, 1, N, pw, acc);
          const double first =
              woz * (N + 1) * (CosPowerIntegral(N + 1) - CosPowerIntegral(N - 1) / 2);
          const double tol = std::fabs(first) + 2 * M_PI * (pearson ? kSupPearson : kSupLorentz);
          const double err = std::fabs(-acc[0] - (M_PI + first));
          worst = std::max(worst, err / tol);
          EXPECT_LT(err, tol) << "wo.z " << woz << " azimuth " << phi << " alpha " << a
                              << " pearson " << pearson << " tau(H) " << -acc[0] << " limit "
                              << M_PI + first;
        }
      }
    }
  }
  std::printf("grazing tau(H) vs pi + O(wo.z): worst error / tolerance %.3f\n", worst);
}

// Light subdivision at grazing views: a tilted quad overhead (the probe's case) and its two
// triangles. The contour sums are additive (interior edges cancel, as in SubdivisionOfTheLight),
// so with C = albedo / (W(h_H) tau(H)) the quad gives C tau W(h_Q) and the triangles
// C (tau_1 W(h_1) + tau_2 W(h_2)), tau = tau_1 + tau_2. h_Q is the direction of the summed
// moments, on the arc between h_1 and h_2, where acc_t = (1 - t) acc_1 + t acc_2 sweeps it;
// both results lie in C tau [min W, max W] over that arc, so they differ by at most
// C tau (max W - min W): the bound asserted, computed from the kernel's own W (lecocq_weight)
// on 1001 points of the arc. Before the fix the triangles gave 2.2x the quad at wo.z 1e-3 (each
// clamped to the albedo), far outside it.
TEST(AreaLecocq, GrazingViewsSubdivisionOfTheLight) {
  using namespace k64;
  const auto q = Facing(Quad({0.2, 0.1, 1.0}, {0.5, 0, 0.15}, {0, 0.5, 0}));
  const std::vector<V3> t1 = {q[0], q[1], q[2]}, t2 = {q[0], q[2], q[3]};
  double worst = 0, max_share = 0;
  for (double woz : {0.05, 0.01, 1e-3, 3e-4}) {
    for (double phi : {20.0, 200.0}) {
      for (double a : {0.1, 0.3, 0.6}) {
        for (double aniso : {1.0, 0.5}) {
          for (Method method : {kLorentz, kPearson}) {
            const Mat mat{GLINT_NDF_GGX, a, a * aniso, 1.0};
            const V3 o = GrazingWo(woz, phi);
            const double whole = Eval64(mat, o, q, method);
            const double parts = Eval64(mat, o, t1, method) + Eval64(mat, o, t2, method);
            // The pieces of the bound, as area_lecocq_polygon forms them.
            SmoothMaterial m = Material<SmoothMaterial, double>(mat);
            const real3 wo = make_real3(o.x, o.y, o.z);
            const double alpha = std::sqrt(mat.ax * mat.ay), sx = alpha / mat.ax,
                         sy = alpha / mat.ay;
            const double N = lecocq_phong_exponent(m.ndf, alpha);
            const double pw = method == kPearson ? std::clamp((N - 3) / 2, 0.0, 1.0) : 0.0;
            double acc[4][4];  // quad, t1, t2, hemisphere
            const std::vector<V3> *polys[3] = {&q, &t1, &t2};
            for (int k = 0; k < 3; ++k) {
              real3 w[4];
              for (size_t i = 0; i < polys[k]->size(); ++i) {
                const V3 &p = (*polys[k])[i];
                w[i] = r3_normalize(make_real3(p.x, p.y, p.z));
              }
              lecocq_region(w, int(polys[k]->size()), wo, sx, sy, N, pw, acc[k]);
            }
            real3 hemi[8];
            for (int k = 0; k < 8; ++k)
              hemi[k] = make_real3(std::cos(k * M_PI / 4), std::sin(k * M_PI / 4), 0);
            lecocq_region(hemi, 8, wo, sx, sy, N, pw, acc[3]);
            for (int j = 0; j < 4; ++j) {
              EXPECT_NEAR(acc[0][j], acc[1][j] + acc[2][j], 1e-12 + 1e-9 * std::fabs(acc[0][j]))
                  << "wo.z " << woz << " moment " << j;
            }
            // The argument needs the albedo clamp of area_lecocq_polygon inactive: the quad is a
            // small part of the hemisphere, so its Phong-lobe share tau / tau(H) is well below 1
            // (measured <= 0.22; asserted < 0.5). Before the fix tau(H) had lost the lobe and
            // the share reached 1e14: whole and parts were both clamped to the albedo.
            max_share = std::max(max_share, std::fabs(acc[0][0] / acc[3][0]));
            EXPECT_LT(std::fabs(acc[0][0]), 0.5 * std::fabs(acc[3][0]))
                << "wo.z " << woz << " azimuth " << phi << " alpha " << a;
            double wmin = 1e300, wmax = 0;
            for (int i = 0; i <= 1000; ++i) {
              const double t = i / 1000.0;
              double at[4];
              for (int j = 0; j < 4; ++j) at[j] = (1 - t) * acc[1][j] + t * acc[2][j];
              const double wt = lecocq_weight(m, mat.ax, mat.ay, wo, at, 0.0).x;
              wmin = std::min(wmin, wt);
              wmax = std::max(wmax, wt);
            }
            const double albedo = TableAlbedo(mat, o);
            const double wh = lecocq_weight(m, mat.ax, mat.ay, wo, acc[3], 0.0).x;
            const double bound =
                albedo / (wh * std::fabs(acc[3][0])) * std::fabs(acc[0][0]) * (wmax - wmin);
            worst = std::max(worst, std::fabs(whole - parts) / bound);
            EXPECT_LE(std::fabs(whole - parts), bound + 1e-12 * whole)
                << "wo.z " << woz << " azimuth " << phi << " alpha " << a << "," << a * aniso
                << " method " << method << " quad " << whole << " triangles " << parts;
          }
        }
      }
    }
  }
  std::printf(
      "grazing quad vs two triangles: worst |difference| / bound %.3f, largest share %.3f\n", worst,
      max_share);
}

// Both methods against REFERENCE at grazing views, wo.z 0.05 / 0.01 / 1e-3 / 3e-4 (87.1 to 89.98
// deg), the lights of the sweep above plus the probe's tilted quad overhead. A REGRESSION GUARD
// like AgreesWithReferencePerRegionRegressionGuard (no error analysis bounds the end-to-end
// error; bounds at the next round level above the measured value), with the tail-lit cases left
// out the same way. What it guards: before the fix, LECOCQ's mean / p95 / max relative error
// was 0.70 / 2.9 / 4.2 (alpha 0.05-0.15), 0.51 / 1.6 / 2.0 (0.15-0.4), 0.43 / 1.0 / 1.8 (0.4-1).
// Now what is left is the method's own approximations (H3 and N2, as at 75-85 deg), converged: a
// split fine enough to be exact (pi/256 pieces, pi/64 sub-pieces) gives the same statistics to
// 0.01. The errors grow from 85 deg to the horizon and then stop changing (band means at wo.z
// 1e-3 and 3e-4 agree to 0.002): W of Eq. N2, taken at the mean half vector, is what degrades
// (G2 and wo.h vary most across the lobe there). LTC is better at alpha >= 0.15 (printed).
// alpha < 0.15: as at 85 deg, the Phong lobe misses GGX's tail, and a few lit cases return ~0.
TEST(AreaLecocq, GrazingViewsAgreeWithReferenceRegressionGuard) {
  struct Band {
    const char *name;
    double a_lo, a_hi;
    double bound[2][3];  // (mean, p95, max) for LECOCQ and LECOCQ_PEARSON; 0: not asserted
    Stats s[3];
    int tail = 0;
  };
  std::vector<Band> bands = {
      // Measured (LECOCQ | PEARSON mean / p95 / max) in the comments.
      // 0.215 / 0.753 / 1.000 | 0.215 / 0.757 / 0.978 (max: a lit light returned 0; see above)
      {"a 0.05-0.15", 0.05, 0.15, {{0.3, 1.0, 0}, {0.3, 1.0, 0}}, {}},
      // 0.131 / 0.595 / 0.759 | 0.131 / 0.600 / 0.764
      {"a 0.15-0.4", 0.15, 0.4, {{0.15, 0.7, 1.0}, {0.15, 0.7, 1.0}}, {}},
      // 0.158 / 0.462 / 0.605 | 0.159 / 0.462 / 0.605
      {"a 0.4-1", 0.4, 1.01, {{0.2, 0.5, 0.7}, {0.2, 0.5, 0.7}}, {}},
  };
  std::vector<Light> lights = Lights();
  lights.push_back({"tilted-overhead", Facing(Quad({0.2, 0.1, 1.0}, {0.5, 0, 0.15}, {0, 0.5, 0}))});
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    for (double a : {0.05, 0.08, 0.12, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0}) {
      for (double woz : {0.05, 0.01, 1e-3, 3e-4}) {
        for (const Light &l : lights) {
          const Mat m{ndf, a, a, 1.0};
          const V3 wo = GrazingWo(woz, 20);
          const double ref = Eval64(m, wo, l.poly, kReference, a < 0.15 ? 160 : 96);
          for (Band &b : bands) {
            if (a < b.a_lo || a >= b.a_hi) continue;
            if (TailLit(m, wo, ref)) {
              ++b.tail;
              continue;
            }
            const double x[3] = {Eval64(m, wo, l.poly, kLorentz), Eval64(m, wo, l.poly, kPearson),
                                 Eval64(m, wo, l.poly, kLtc)};
            for (int k = 0; k < 3; ++k) b.s[k].e.push_back(RelErr(x[k], ref));
          }
        }
      }
    }
  }
  const char *names[3] = {"LECOCQ", "PEARSON", "(LTC)"};
  for (const Band &b : bands) {
    for (int k = 0; k < 3; ++k) {
      std::printf("grazing %-12s %-8s %7.3f %7.3f %7.3f  (n=%zu, %d tail-lit)\n", b.name, names[k],
                  b.s[k].Mean(), b.s[k].Pct(0.95), b.s[k].Max(), b.s[k].e.size(), b.tail);
    }
    for (int k = 0; k < 2; ++k) {
      EXPECT_LT(b.s[k].Mean(), b.bound[k][0]) << b.name << " " << names[k];
      if (b.bound[k][1] > 0) {
        EXPECT_LT(b.s[k].Pct(0.95), b.bound[k][1]) << b.name << " " << names[k];
      }
      if (b.bound[k][2] > 0) {
        EXPECT_LT(b.s[k].Max(), b.bound[k][2]) << b.name << " " << names[k];
      }
    }
  }
}

// Anisotropic alpha: the stretch of step 2 is exact for D, the albedo uses sqrt(ax ay); W of
// step 6 is evaluated with the true alpha_x, alpha_y. A REGRESSION GUARD (no error bound, as for
// the isotropic sweep); tail-lit cases are left out as there (TailLit: the KS argument holds in
// the stretched space, where the lobe is isotropic).
TEST(AreaLecocq, AnisotropicAgreesWithReferenceRegressionGuard) {
  Stats s[2];
  int tail = 0;
  for (double ax : {0.1, 0.3}) {
    for (double ratio : {0.25, 0.5}) {
      for (double view : {0.0, 45.0}) {
        for (const Light &l : Lights()) {
          for (int swap = 0; swap < 2; ++swap) {
            Mat m{GLINT_NDF_GGX, swap ? ax * ratio : ax, swap ? ax : ax * ratio, 1.0};
            double ref = Eval64(m, Wo(view, 20), l.poly, kReference, 128);
            if (TailLit(m, Wo(view, 20), ref)) {
              ++tail;
              continue;
            }
            for (int k = 0; k < 2; ++k)
              s[k].e.push_back(RelErr(Eval64(m, Wo(view, 20), l.poly, Method(k)), ref));
          }
        }
      }
    }
  }
  std::printf(
      "anisotropic (alpha_y/alpha_x 0.25, 0.5; %zu cases, %d tail-lit left out): "
      "LECOCQ mean %.3f max %.3f, PEARSON mean %.3f max %.3f\n",
      s[0].e.size(), tail, s[0].Mean(), s[0].Max(), s[1].Mean(), s[1].Max());
  // Measured: mean 0.041 / 0.040, max 0.145 / 0.134.
  for (int k = 0; k < 2; ++k) {
    EXPECT_LT(s[k].Mean(), 0.05) << k;
    EXPECT_LT(s[k].Max(), 0.15) << k;
  }
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

// Condition number of a contour sum: sum over edge pieces of |term| / |sum| (acc[0], Eq. E3),
// with the pieces of lecocq_region (uniform pieces, and sub-pieces near wi = -wo), in double.
// Rounding errors of size u in each term move the sum by ~u sum |term|, i.e. by u kappa
// relative. Also returns in *amplified that kappa divided by the smallest of 1, |wi + wo| and w
// over the pieces: the half vector normalize(wi + wo) of a point near -wo carries a rounding
// error amplified by 1 / |wi + wo| (cancellation in the sum), and the points of a sub-split
// piece (lecocq_subsplit) are placed from w and theta_c, themselves dot products of unit
// vectors with absolute error ~u, so a point at offset |theta - theta_c| <= |wi + wo| moves by
// ~u |theta - theta_c| / w and its half vector by up to ~u / w. (Amplifying only the terms of
// the pieces near -wo undercounts: lights clipped at the horizon near -wo came out up to 4x
// over that finer estimate, for reasons not traced; this coarser one holds.) The replica is
// checked against lecocq_region.
double ContourKappa(const k64::real3 *w, int n, k64::real3 wo, double N, double pw,
                    double *amplified = nullptr) {
  using namespace k64;
  double sum = 0, abs_sum = 0, nearest = 1, check[4] = {0, 0, 0, 0};
  double sub_w = 1;  // w of lecocq_subsplit for the current piece's sub-pieces, else 1
  auto edge = [&](real3 wa, real3 wb) {
    double acc[4] = {0, 0, 0, 0};
    lecocq_edge(lecocq_to_h(wa, wo, 1, 1), lecocq_to_h(wb, wo, 1, 1), N, pw, acc);
    for (int j = 0; j < 4; ++j) check[j] += acc[j];
    sum += acc[0];
    abs_sum += std::fabs(acc[0]);
    const double near = std::min({1.0, r3_length(r3_add(wa, wo)), r3_length(r3_add(wb, wo))});
    nearest = std::min({nearest, near, sub_w});
  };
  for (int i = 0; i < n; ++i) {
    real3 a = w[i], b = w[(i + 1) % n];
    real theta = atan2(r3_length(r3_cross(a, b)), r3_dot(a, b));
    int pieces = std::min((int)(theta / GLINT_LECOCQ_SPLIT - 1e-3) + 1, GLINT_LECOCQ_MAX_SPLIT);
    real3 prev = a;
    for (int k = 1; k <= pieces; ++k) {
      real u = (real)k / (real)pieces;
      real3 next = r3_normalize(r3_add(r3_scale(a, 1 - u), r3_scale(b, u)));
      real3 e;
      real par[4];
      const int m = lecocq_subsplit(prev, next, wo, &e, par);
      sub_w = m > 1 ? par[1] : 1.0;
      real3 sub = prev;
      for (int j = 1; j < m; ++j) {
        real psi = par[2] + j * par[3];
        real t = par[0] + par[1] * std::sin(psi) / std::cos(psi);
        real3 wj = r3_add(r3_scale(prev, std::cos(t)), r3_scale(e, std::sin(t)));
        edge(sub, wj);
        sub = wj;
      }
      edge(sub, next);
      prev = next;
    }
  }
  double acc[4];
  lecocq_region(w, n, wo, 1, 1, N, pw, acc);
  for (int j = 0; j < 4; ++j) EXPECT_EQ(acc[j], check[j]) << "ContourKappa's pieces, moment " << j;
  if (amplified) *amplified = abs_sum / nearest / std::fabs(sum);
  return abs_sum / std::fabs(sum);
}

// fp32 against fp64 on identical (float-rounded) inputs where the value is well conditioned:
// isotropic alpha 0.05-1, views up to 60 deg, lights that are not tail-lit (a tail-lit light's
// contour sum is the cancellation of terms far larger than it, see TailLit). The result is
// albedo * tau(P) / tau(H) * W(h_P) / W(h_H); tau(P) and tau(H) are sums whose condition numbers
// kappa_P, kappa_H (ContourKappa) are computed here, and W is a smooth product of a few
// well-conditioned factors. Tolerance: 64 eps_32 (kappa_P + kappa_H), the 64 being the roundings
// along one edge term (normalise, cross, atan2, sin, cos, expm1, log1p, sqrt, each <= 2 ulp in
// glibc's float libm) and through W, all amplified by the sums' cancellation.
TEST(AreaLecocq, Fp32MatchesFp64WhereWellConditioned) {
  const double eps32 = std::ldexp(1.0, -24);
  double worst = 0, worst_kappa = 0;
  int compared = 0;
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    for (double a : {0.05, 0.1, 0.3, 0.6, 1.0}) {
      for (double view : {0.0, 30.0, 60.0}) {
        for (const Light &l : Lights()) {
          Mat m{ndf, double(float(a)), double(float(a)), 1.0};
          V3 wo = Wo(view, 20);
          wo = {double(float(wo.x)), double(float(wo.y)), double(float(wo.z))};
          std::vector<V3> poly;
          for (V3 v : l.poly)
            poly.push_back({double(float(v.x)), double(float(v.y)), double(float(v.z))});
          const double ref = Eval64(m, wo, poly, kReference, a < 0.15 ? 160 : 96);
          if (TailLit(m, wo, ref)) continue;
          // kappa of tau(P) and tau(H) as area_lecocq_polygon forms them.
          using namespace k64;
          real3 v[GLINT_POLYGON_MAX_VERTICES], w[GLINT_POLYGON_MAX_CLIPPED], hemi[8];
          for (size_t i = 0; i < poly.size(); ++i)
            v[i] = make_real3(poly[i].x, poly[i].y, poly[i].z);
          int nc = polygon_clip_to_horizon(v, int(poly.size()), w);
          for (int i = 0; i < nc; ++i) w[i] = r3_normalize(w[i]);
          for (int k = 0; k < 8; ++k)
            hemi[k] = make_real3(std::cos(k * M_PI / 4), std::sin(k * M_PI / 4), 0);
          real3 w64 = r3_normalize(make_real3(wo.x, wo.y, wo.z));
          const double N = lecocq_phong_exponent(ndf, m.ax);
          for (int pearson : {0, 1}) {
            const double pw = pearson ? std::clamp((N - 3) / 2, 0.0, 1.0) : 0.0;
            const double kappa =
                ContourKappa(w, nc, w64, N, pw) + ContourKappa(hemi, 8, w64, N, pw);
            const double x64 = Eval64(m, wo, poly, Method(pearson));
            const double x32 = Lecocq32(m, wo, poly, pearson).x;
            const double rel = std::fabs(x32 - x64) / x64;
            worst = std::max(worst, rel / (eps32 * kappa));
            worst_kappa = std::max(worst_kappa, kappa);
            ++compared;
            EXPECT_LT(rel, 64 * eps32 * kappa)
                << "ndf " << ndf << " alpha " << a << " view " << view << " " << l.name
                << " pearson " << pearson << " fp64 " << x64 << " fp32 " << x32 << " kappa "
                << kappa;
          }
        }
      }
    }
  }
  std::printf(
      "fp32 vs fp64 (%d values): worst |x32 - x64| / x64 = %.1f eps_32 kappa "
      "(largest kappa %.1f)\n",
      compared, worst, worst_kappa);
}

// fp32 against fp64 at grazing views (wo.z 0.05 to 3e-4) on identical float-rounded inputs, lights
// that are not tail-lit. The tolerance of Fp32MatchesFp64WhereWellConditioned, 64 eps_32
// (kappa_P + kappa_H), with each contour term's share of kappa amplified by the cancellation in
// wi + wo near the singular point and by the placing of sub-split points (ContourKappa's
// `amplified`: the sub-pieces of
// lecocq_subsplit come within ~wo.z of -wo), plus W's own amplification 1 / wi.z (below). Both
// exactly 0 (a lit GGX alpha 0.05 light whose
// tiny Phong mass lost its sign, see TailLitLightsAreThePhongLobesMissingTail) counts as equal.
TEST(AreaLecocq, GrazingViewsFp32MatchesFp64) {
  const double eps32 = std::ldexp(1.0, -24);
  double worst = 0;
  int compared = 0;
  std::vector<Light> lights = Lights();
  lights.push_back({"tilted-overhead", Facing(Quad({0.2, 0.1, 1.0}, {0.5, 0, 0.15}, {0, 0.5, 0}))});
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    for (double a : {0.05, 0.1, 0.3, 0.6, 1.0}) {
      for (double woz : {0.05, 0.01, 1e-3, 3e-4}) {
        for (const Light &l : lights) {
          Mat m{ndf, double(float(a)), double(float(a)), 1.0};
          V3 wo = GrazingWo(woz, 20);
          wo = {double(float(wo.x)), double(float(wo.y)), double(float(wo.z))};
          std::vector<V3> poly;
          for (V3 v : l.poly)
            poly.push_back({double(float(v.x)), double(float(v.y)), double(float(v.z))});
          const double ref = Eval64(m, wo, poly, kReference, a < 0.15 ? 160 : 96);
          if (TailLit(m, wo, ref)) continue;
          using namespace k64;
          real3 v[GLINT_POLYGON_MAX_VERTICES], w[GLINT_POLYGON_MAX_CLIPPED], hemi[8];
          for (size_t i = 0; i < poly.size(); ++i)
            v[i] = make_real3(poly[i].x, poly[i].y, poly[i].z);
          int nc = polygon_clip_to_horizon(v, int(poly.size()), w);
          for (int i = 0; i < nc; ++i) w[i] = r3_normalize(w[i]);
          for (int k = 0; k < 8; ++k)
            hemi[k] = make_real3(std::cos(k * M_PI / 4), std::sin(k * M_PI / 4), 0);
          real3 w64 = r3_normalize(make_real3(wo.x, wo.y, wo.z));
          const double N = lecocq_phong_exponent(ndf, m.ax);
          for (int pearson : {0, 1}) {
            const double pw = pearson ? std::clamp((N - 3) / 2, 0.0, 1.0) : 0.0;
            double amp_p = 0, amp_h = 0;
            ContourKappa(w, nc, w64, N, pw, &amp_p);
            ContourKappa(hemi, 8, w64, N, pw, &amp_h);
            // W (Eq. N2) at wi = reflect(wo, h) of the mean half vector: wi.z = 2 (wo.h) h.z -
            // wo.z cancels for a light near the horizon, and G2 follows wi.z, so W's rounding is
            // amplified by 1 / wi.z (isotropic here: h is the direction of the moments).
            auto wi_z = [&](const real3 *poly_w, int count) {
              double acc[4];
              lecocq_region(poly_w, count, w64, 1, 1, N, pw, acc);
              const double sg = acc[0] < 0 ? -1 : 1;
              real3 h =
                  r3_normalize(make_real3(sg * acc[2], sg * acc[3], std::max(sg * acc[1], 0.0)));
              return std::max(2 * std::max(r3_dot(w64, h), 0.0) * h.z - w64.z, 1e-6);
            };
            const double kappa =
                amp_p + amp_h + 1 / std::min(1.0, wi_z(w, nc)) + 1 / std::min(1.0, wi_z(hemi, 8));
            const double tol = 64 * eps32 * kappa;
            const double x64 = Eval64(m, wo, poly, Method(pearson));
            const double x32 = Lecocq32(m, wo, poly, pearson).x;
            const double rel = x64 == x32 ? 0.0 : std::fabs(x32 - x64) / x64;
            worst = std::max(worst, rel / tol);
            ++compared;
            EXPECT_LT(rel, tol) << "ndf " << ndf << " alpha " << a << " wo.z " << woz << " "
                                << l.name << " pearson " << pearson << " fp64 " << x64 << " fp32 "
                                << x32 << " kappa " << kappa;
          }
        }
      }
    }
  }
  std::printf("grazing fp32 vs fp64 (%d values): worst |x32 - x64| / x64 / tolerance %.3f\n",
              compared, worst);
}

}  // namespace
