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
#include "tests/support/plane_adaptive.h"

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
// views: Beckmann alpha 0.05, view 85, a wall holding the whole lobe gets 0.71 instead of 0.94;
// pi/64 pieces give 0.935). The components that do have a fitted accuracy are asserted against it
// below (PhongLobeWithinTheFittedKs, PeakFunctionsWithinTheFittedSupError,
// ContourSumsMatchThePhongLobeMassWithinTheFit). Bounds: the measured value's next round level
// (1, 1.5, 2, 3, 5, 7 x 10^k). Tail-lit cases (see TailLit) are left out of the relative
// statistics and checked against the KS bound on the absolute error, 2 KS x albedo.
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
      // 0.023 / 0.130 / 0.190 | 0.023 / 0.117 / 0.184
      {"a 0.05-0.15, view < 50", 0.05, 0.15, 0, 50, {0.03, 0.15, 0.2}, {0.03, 0.15, 0.2}, {}},
      // 0.034 / 0.147 / 0.231 | 0.035 / 0.159 / 0.243
      {"a 0.05-0.15, view 50-75", 0.05, 0.15, 50, 75, {0.05, 0.2, 0.3}, {0.05, 0.2, 0.3}, {}},
      // 0.074 / 0.250 / 0.435 | 0.076 / 0.261 / 0.443
      {"a 0.05-0.15, view 75-85", 0.05, 0.15, 75, 86, {0.1, 0.3, 0.5}, {0.1, 0.3, 0.5}, {}},
      // 0.038 / 0.165 / 0.240 | 0.032 / 0.159 / 0.230
      {"a 0.15-0.4, view < 50", 0.15, 0.4, 0, 50, {0.05, 0.2, 0.3}, {0.05, 0.2, 0.3}, {}},
      // 0.057 / 0.177 / 0.199 | 0.056 / 0.172 / 0.185
      {"a 0.15-0.4, view 50-75", 0.15, 0.4, 50, 75, {0.07, 0.2, 0.2}, {0.07, 0.2, 0.2}, {}},
      // 0.079 / 0.482 / 0.516 | 0.080 / 0.480 / 0.523
      {"a 0.15-0.4, view 75-85", 0.15, 0.4, 75, 86, {0.1, 0.5, 0.7}, {0.1, 0.5, 0.7}, {}},
      // 0.113 / 0.319 / 0.342 | 0.112 / 0.313 / 0.342
      {"a 0.4-1, view < 50", 0.4, 1.01, 0, 50, {0.15, 0.5, 0.5}, {0.15, 0.5, 0.5}, {}},
      // 0.101 / 0.249 / 0.293 | 0.102 / 0.250 / 0.293
      {"a 0.4-1, view 50-75", 0.4, 1.01, 50, 75, {0.15, 0.3, 0.3}, {0.15, 0.3, 0.3}, {}},
      // 0.100 / 0.266 / 0.320 | 0.101 / 0.266 / 0.327
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
// with the pieces of lecocq_region, in double. Rounding errors of size u in each term move the
// sum by ~u sum |term|, i.e. by u kappa relative.
double ContourKappa(const k64::real3 *w, int n, k64::real3 wo, double N, double pw) {
  using namespace k64;
  double sum = 0, abs_sum = 0;
  for (int i = 0; i < n; ++i) {
    real3 a = w[i], b = w[(i + 1) % n];
    real theta = atan2(r3_length(r3_cross(a, b)), r3_dot(a, b));
    int pieces = std::min((int)(theta / GLINT_LECOCQ_SPLIT - 1e-3) + 1, GLINT_LECOCQ_MAX_SPLIT);
    real3 prev = lecocq_to_h(a, wo, 1, 1);
    for (int k = 1; k <= pieces; ++k) {
      real u = (real)k / (real)pieces;
      real3 next = lecocq_to_h(r3_normalize(r3_add(r3_scale(a, 1 - u), r3_scale(b, u))), wo, 1, 1);
      double acc[4] = {0, 0, 0, 0};
      lecocq_edge(prev, next, N, pw, acc);
      sum += acc[0];
      abs_sum += std::fabs(acc[0]);
      prev = next;
    }
  }
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

}  // namespace
