// LTC fitting for glint's smooth BRDF; see ltc_fit.h for the model and README.md for the
// procedure. The BRDF is kernels/smooth_brdf.h itself, compiled here in double precision.
#include "tools/ltc/ltc_fit.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <numbers>
#include <vector>

// As server/host_path.cpp: the kernel headers go into a namespace of our own, once per
// translation unit, after <cassert>/<cmath> so that their inclusion inside is a no-op, and after
// every other header, since compat.h defines the macro GLINT_R(x).
namespace glint_ltc_k {
#define GLINT_USE_DOUBLE 1
#include "kernels/smooth_brdf.h"
}  // namespace glint_ltc_k

namespace glint::ltc {
namespace {

namespace k = glint_ltc_k;
using V3 = k::real3;

constexpr double kPi = std::numbers::pi;

V3 v3(double x, double y, double z) {
  return k::make_real3(x, y, z);
}

// ------------------------------------------------------------------------------------------
// Gauss-Legendre rule on [0, 1] (Newton iteration on P_n from the Chebyshev-like initial guess;
// Abramowitz & Stegun 25.4.29). Accurate to ~1e-15 for the orders used here.

struct Rule {
  std::vector<double> x, w;
};

Rule gauss_legendre(int n) {
  Rule r;
  r.x.resize(n);
  r.w.resize(n);
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = 0;
      for (int j = 1; j <= n; ++j) {
        double p2 = p1;
        p1 = p0;
        p0 = ((2.0 * j - 1.0) * z * p1 - (j - 1.0) * p2) / j;
      }
      dp = n * (z * p0 - p1) / (z * z - 1.0);
      double dz = p0 / dp;
      z -= dz;
      if (std::fabs(dz) < 1e-16) break;
    }
    double w = 2.0 / ((1.0 - z * z) * dp * dp);
    // Map [-1, 1] -> [0, 1]: half the weight.
    r.x[i] = 0.5 * (1.0 - z);
    r.x[n - 1 - i] = 0.5 * (1.0 + z);
    r.w[i] = r.w[n - 1 - i] = 0.5 * w;
  }
  return r;
}

// ------------------------------------------------------------------------------------------
// The BRDF lobe for one (ndf, alpha, wo).

// Microfacet sampling h ~ D(h) cos(theta_h) (Walter et al. 2007 Eq. 28/35 for GGX and
// Beckmann): u is the CDF of the projected NDF in theta_h, which makes D cos dw_h = du dphi/2pi.
double tan2_from_cdf(Ndf ndf, double alpha, double u) {
  if (ndf == Ndf::kBeckmann) return -alpha * alpha * std::log1p(-u);
  return alpha * alpha * u / (1.0 - u);
}
double cdf_from_tan2(Ndf ndf, double alpha, double tan2) {
  if (ndf == Ndf::kBeckmann) return -std::expm1(-tan2 / (alpha * alpha));
  return tan2 / (alpha * alpha + tan2);
}

struct Lobe {
  Ndf ndf;
  double alpha;
  V3 wo;
  k::SmoothMaterial white;  // Schlick f0 = 1: F = 1
  k::SmoothMaterial black;  // Schlick f0 = 0: F = (1 - wo.h)^5

  Lobe(Ndf n, double a, double cos_theta) : ndf(n), alpha(a) {
    double s = std::sqrt((1.0 - cos_theta) * (1.0 + cos_theta));
    wo = v3(s, 0.0, cos_theta);
    white.ndf = static_cast<int>(n);
    white.alpha_x = white.alpha_y = a;
    white.fresnel.kind = GLINT_FRESNEL_SCHLICK;
    white.fresnel.a = v3(1, 1, 1);
    white.fresnel.b = v3(0, 0, 0);
    black = white;
    black.fresnel.a = v3(0, 0, 0);
  }

  double fcos(V3 wi) const { return k::smooth_reflect_cos(white, wi, wo).x; }
  double fcos_schlick_moment(V3 wi) const { return k::smooth_reflect_cos(black, wi, wo).x; }
  double D(V3 h) const { return k::ndf_D(static_cast<int>(ndf), h, alpha, alpha); }

  // Half vector from (tan^2 theta_h, phi_h).
  static V3 half(double tan2, double phi) {
    double c = 1.0 / std::sqrt(1.0 + tan2);
    double s = std::sqrt(tan2) * c;
    return v3(s * std::cos(phi), s * std::sin(phi), c);
  }
  V3 reflect(V3 h) const { return h * (2.0 * k::dot(wo, h)) - wo; }

  // Density over the sphere of wi = reflect(wo, h), h ~ D cos: D h.z / (4 |wo.h|).
  double sampler_pdf(V3 wi) const {
    V3 h = wi + wo;
    double len = k::length(h);
    if (!(len > 0)) return 0.0;
    h = h / len;
    if (h.z < 0) h = -h;
    double c = std::fabs(k::dot(wo, h));
    return c > 0 ? D(h) * h.z / (4.0 * c) : 0.0;
  }
  V3 sample(double u1, double u2) const {
    return reflect(half(tan2_from_cdf(ndf, alpha, u1), 2.0 * kPi * u2));
  }
};

// Scaled complementary error function exp(x^2) erfc(x), x >= 0, without overflow: direct below
// 10 (erfc(10) ~ 2e-45 is still a normal double), asymptotic series above (A&S 7.1.23; the
// 6-term truncation error at x = 10 is ~1e-10 relative).
double erfcx(double x) {
  if (x < 10.0) return std::exp(x * x) * std::erfc(x);
  double inv2 = 1.0 / (2.0 * x * x), term = 1.0, sum = 1.0;
  for (int n = 1; n <= 6; ++n) {
    term *= -(2.0 * n - 1.0) * inv2;
    sum += term;
  }
  return sum / (x * std::sqrt(kPi));
}

// Total microfacet area D_H = int_H D(h) dw_h, Kneiphof & Klein 2024 Appendix B.
double total_ndf_area(Ndf ndf, double alpha) {
  if (ndf == Ndf::kBeckmann) {
    // Eq. 30: 1 + sqrt(pi)/2 alpha exp(1/alpha^2) erfc(1/alpha).
    return 1.0 + 0.5 * std::sqrt(kPi) * alpha * erfcx(1.0 / alpha);
  }
  // Eq. 29: 1 + alpha^2 ln((1 + s)/alpha) / s with s = sqrt(1 - alpha^2); ln(...) = atanh(s),
  // and atanh(s)/s = 1 + s^2/3 + s^4/5 + ... near alpha = 1 (where the quotient is 0/0).
  double s = std::sqrt(std::max(0.0, (1.0 - alpha) * (1.0 + alpha)));
  double q = s < 1e-4 ? 1.0 + s * s / 3.0 : std::atanh(s) / s;
  return 1.0 + alpha * alpha * q;
}

// ------------------------------------------------------------------------------------------
// Nelder & Mead 1965 downhill simplex, with the usual coefficients (reflection 1, expansion 2,
// contraction 1/2, shrink 1/2; Lagarias et al. 1998). Converged when every vertex is within
// `xtol` of the best one in every coordinate (the parameters below are all relative scales), or
// when the values agree to rounding. Then it restarts once from the best vertex with a fresh
// simplex, a standard remedy against a simplex that collapsed before reaching the minimum.
template <int N, class F>
std::array<double, N> nelder_mead(F &&f, std::array<double, N> x0, std::array<double, N> step,
                                  double xtol, int max_evals, double *f_best, int *evals) {
  using Pt = std::array<double, N>;
  int count = 0;
  auto eval = [&](const Pt &x) {
    ++count;
    return f(x);
  };
  Pt best = x0;
  double fbest = eval(best);
  for (int restart = 0; restart < 2 && count < max_evals; ++restart) {
    std::array<Pt, N + 1> s;
    std::array<double, N + 1> fs;
    s[0] = best;
    fs[0] = fbest;
    for (int i = 0; i < N; ++i) {
      s[i + 1] = best;
      s[i + 1][i] += step[i];
      fs[i + 1] = eval(s[i + 1]);
    }
    while (count < max_evals) {
      // Order: lo = best, hi = worst, nh = second worst.
      int lo = 0, hi = 0;
      for (int i = 1; i <= N; ++i) {
        if (fs[i] < fs[lo]) lo = i;
        if (fs[i] > fs[hi]) hi = i;
      }
      int nh = lo;
      for (int i = 0; i <= N; ++i)
        if (i != hi && fs[i] > fs[nh]) nh = i;
      double spread = 0;
      for (int i = 0; i <= N; ++i)
        for (int d = 0; d < N; ++d) spread = std::max(spread, std::fabs(s[i][d] - s[lo][d]));
      if (spread <= xtol || fs[hi] - fs[lo] <= 1e-15 * std::fabs(fs[lo])) break;
      Pt c{};
      for (int i = 0; i <= N; ++i)
        if (i != hi)
          for (int d = 0; d < N; ++d) c[d] += s[i][d] / N;
      auto along = [&](double t) {
        Pt p;
        for (int d = 0; d < N; ++d) p[d] = c[d] + t * (s[hi][d] - c[d]);
        return p;
      };
      Pt xr = along(-1.0);
      double fr = eval(xr);
      if (fr < fs[lo]) {
        Pt xe = along(-2.0);
        double fe = eval(xe);
        if (fe < fr) {
          s[hi] = xe, fs[hi] = fe;
        } else {
          s[hi] = xr, fs[hi] = fr;
        }
      } else if (fr < fs[nh]) {
        s[hi] = xr, fs[hi] = fr;
      } else {
        bool outside = fr < fs[hi];
        Pt xc = along(outside ? -0.5 : 0.5);
        double fc = eval(xc);
        if (fc < (outside ? fr : fs[hi])) {
          s[hi] = xc, fs[hi] = fc;
        } else {
          for (int i = 0; i <= N; ++i) {
            if (i == lo) continue;
            for (int d = 0; d < N; ++d) s[i][d] = s[lo][d] + 0.5 * (s[i][d] - s[lo][d]);
            fs[i] = eval(s[i]);
          }
        }
      }
    }
    int lo = 0;
    for (int i = 1; i <= N; ++i)
      if (fs[i] < fs[lo]) lo = i;
    if (fs[lo] < fbest) best = s[lo], fbest = fs[lo];
  }
  if (f_best) *f_best = fbest;
  if (evals) *evals = count;
  return best;
}

// ------------------------------------------------------------------------------------------
// The LTC with M = [X Y Z] S, S = [[m11, 0, m13], [0, m22, 0], [0, 0, 1]].

struct Ltc {
  V3 X, Y, Z;
  double m11, m22, m13;
  double det_inv;  // det M^-1 = 1 / (m11 m22) (det [X Y Z] = 1)

  Ltc(const LtcParams &p, double avg_x, double avg_z) : m11(p.m11), m22(p.m22), m13(p.m13) {
    double n = std::hypot(avg_x, avg_z);
    Z = v3(avg_x / n, 0, avg_z / n);
    X = v3(Z.z, 0, -Z.x);
    Y = v3(0, 1, 0);
    det_inv = 1.0 / (m11 * m22);
  }
  // M w_o (not normalised).
  V3 forward(V3 o) const { return X * (m11 * o.x + m13 * o.z) + Y * (m22 * o.y) + Z * o.z; }
  // Density (HDHN16 Eq. 3) at w = M o / |M o| for a cosine sample o:
  // D_o(o) |det M^-1| / |M^-1 w|^3 = (o.z / pi) |det M^-1| |M o|^3.
  double density_of_sample(V3 o, double len_mo) const {
    return o.z / kPi * det_inv * len_mo * len_mo * len_mo;
  }
  // Density at an arbitrary unit w: o = M^-1 w, D = max(0, o.z) |det M^-1| / (pi |o|^4).
  double density(V3 w) const {
    double lx = k::dot(X, w), ly = k::dot(Y, w), lz = k::dot(Z, w);
    V3 o = v3((lx - m13 * lz) / m11, ly / m22, lz);
    double l2 = k::dot(o, o);
    return o.z > 0 ? o.z * det_inv / (kPi * l2 * l2) : 0.0;
  }
};

// Cosine-distributed direction from (u1, u2) (Malley: uniform disk, lifted).
V3 cosine_sample(double u1, double u2) {
  double r = std::sqrt(u1), phi = 2.0 * kPi * u2;
  return v3(r * std::cos(phi), r * std::sin(phi), std::sqrt(1.0 - u1));
}

// The fit's error: E = int |p - q|^3 dw over the sphere, p = f cos / magnitude (the normalised
// BRDF lobe, 0 below the horizon), q = the LTC; an L3 norm weights the peak, where the BRDF is
// largest, as in the public fitting code. Estimated by multiple importance sampling (balance
// heuristic, Veach 1997) over fixed stratified samples of the BRDF sampler and of the LTC, so
// the objective is a smooth deterministic function of the parameters (common random numbers).
class Objective {
 public:
  Objective(const Lobe &lobe, const Moments &m, int n) : lobe_(lobe), m_(m), n_(n) {
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        double u1 = (i + 0.5) / n, u2 = (j + 0.5) / n;
        BrdfSample b;
        b.w = lobe.sample(u1, u2);
        b.p = b.w.z > 0 ? lobe.fcos(b.w) / m.magnitude : 0.0;
        b.s = lobe.sampler_pdf(b.w);
        brdf_.push_back(b);
        cos_.push_back(cosine_sample(u1, u2));
      }
    }
  }

  double operator()(const LtcParams &params) const {
    Ltc ltc(params, m_.avg_x, m_.avg_z);
    double sum = 0;
    for (const BrdfSample &b : brdf_) {
      double q = ltc.density(b.w);
      double d = std::fabs(b.p - q);
      sum += d * d * d / (b.s + q);
    }
    for (const V3 &o : cos_) {
      V3 mo = ltc.forward(o);
      double len = k::length(mo);
      V3 w = mo / len;
      double q = ltc.density_of_sample(o, len);
      double p = w.z > 0 ? lobe_.fcos(w) / m_.magnitude : 0.0;
      double s = lobe_.sampler_pdf(w);
      double d = std::fabs(p - q);
      sum += d * d * d / (s + q);
    }
    return sum / (static_cast<double>(n_) * n_);
  }

 private:
  struct BrdfSample {
    V3 w;
    double p, s;
  };
  const Lobe &lobe_;
  Moments m_;
  int n_;
  std::vector<BrdfSample> brdf_;
  std::vector<V3> cos_;
};

}  // namespace

// ------------------------------------------------------------------------------------------

const char *ndf_name(Ndf ndf) {
  return ndf == Ndf::kBeckmann ? "beckmann" : "ggx";
}

double grid_roughness(int a) {
  return a / double(kGridSize - 1);
}
double grid_alpha(int a) {
  double r = grid_roughness(a);
  return std::max(r * r, kAlphaMin);
}
double grid_cos_theta(int t) {
  double x = t / double(kGridSize - 1);
  return std::max(1.0 - x * x, kCosThetaMin);
}

// Half-vector space: h = (sin th cos ph, sin th sin ph, cos th), wo = (s_o, 0, c_o). The
// reflected wi = 2 (wo.h) h - wo is above the horizon iff 2 (wo.h) cos th > c_o, i.e.
//   cos ph > K(th) = -(c_o / s_o) cot(2 th),
// K increasing from -inf to +inf on (0, pi/2). So every phi is valid for th < th1 = pi/4 - th_o/2,
// none for th > th2 = pi/4 + th_o/2, and |ph| < acos K in between. (wi.z > 0 with c_o > 0 also
// gives wo.h > 0.) Integrating over exactly that region leaves integrands that are smooth on each
// piece: f cos_i goes to 0 continuously at the horizon (G2 -> 0), so no jump is left for the
// quadrature to resolve; the remaining steep parts (f cos_i ~ wi.z / (A wi.z + B) near the
// horizon, phi_max(th) ~ square root near th1 and th2, on the scale of c_o at grazing views) get
// clustered nodes.
//
// Pieces in theta_h:
//   [0, th1]     all phi; variable u = projected-NDF CDF (D cos dw_h = du dphi / 2pi), so the
//                peak of D is resolved at every roughness;
//   [th1, pi/4]  |phi| < phi_max; variable u again (the peak of D can lie here at grazing views);
//   [pi/4, th2]  |phi| < phi_max; variable theta itself: D's tail is smooth in theta, while u
//                squeezes this piece into 1 - u ~ alpha^2 cos^2(theta_o).
Moments compute_moments(Ndf ndf, double alpha, double cos_theta, int order) {
  Lobe lobe(ndf, alpha, cos_theta);
  const double c_o = cos_theta, s_o = lobe.wo.x;
  const double th_o = std::acos(c_o);
  const double th1 = 0.25 * kPi - 0.5 * th_o, th2 = 0.25 * kPi + 0.5 * th_o;
  const double U1 = cdf_from_tan2(ndf, alpha, std::pow(std::tan(th1), 2));
  const double Um = cdf_from_tan2(ndf, alpha, 1.0);  // th = pi/4
  const Rule g = gauss_legendre(order);

  Moments m;
  double sx = 0, sz = 0;
  auto phi_max_of = [&](double tan_th) {
    double cot2 = (1.0 - tan_th * tan_th) / (2.0 * tan_th);
    return std::acos(std::clamp(-(c_o / s_o) * cot2, -1.0, 1.0));
  };
  // One theta_h line with projected-NDF measure wu (= du): integrate phi over [0, phi_max]
  // (x2 for phi < 0 by symmetry).
  auto line = [&](double tan2, double wu, double phi_max) {
    // Empty pieces (th1 = pi/4 at normal view), and nodes where u rounds to 1 in the far tail
    // of a narrow lobe (tan2 = inf, where D = 0 anyway), contribute nothing.
    if (!(wu > 0) || !std::isfinite(tan2)) return;
    double inv_cos = std::sqrt(1.0 + tan2);
    // D_PR (Eq. 19) in h space is int D dw_h over the valid set: D dw_h = du dphi / (2 pi cos),
    // and the valid phi measure is 2 phi_max.
    m.d_pr += wu * phi_max / kPi * inv_cos;
    for (int j = 0; j < order; ++j) {
      // phi = phi_max sin(pi x / 2) clusters nodes at phi_max, where wi meets the horizon.
      double phi = phi_max * std::sin(0.5 * kPi * g.x[j]);
      double dphi = phi_max * 0.5 * kPi * std::cos(0.5 * kPi * g.x[j]);
      double wgt = wu * dphi * g.w[j] / kPi;  // du dphi / 2pi, twice
      V3 h = Lobe::half(tan2, phi);
      V3 wi = lobe.reflect(h);
      // f cos dw_i = f cos |dw_i/dw_h| dw_h = f cos 4 (wo.h) / (D cos th) du dphi / 2pi.
      double jac = 4.0 * k::dot(lobe.wo, h) / (lobe.D(h) * h.z);
      if (!(jac > 0) || !std::isfinite(jac)) continue;
      double f = lobe.fcos(wi) * jac;
      m.magnitude += wgt * f;
      m.fresnel += wgt * lobe.fcos_schlick_moment(wi) * jac;
      sx += wgt * f * wi.x;
      sz += wgt * f * wi.z;
    }
  };
  for (int i = 0; i < order; ++i) {
    // [0, th1]: u = U1 sin(pi x / 2) clusters nodes at th1, where the reflection of the phi = pi
    // half vectors reaches the horizon.
    double x = 0.5 * kPi * g.x[i];
    line(tan2_from_cdf(ndf, alpha, U1 * std::sin(x)), U1 * 0.5 * kPi * std::cos(x) * g.w[i], kPi);
  }
  if (th2 > th1) {
    for (int i = 0; i < order; ++i) {
      // [th1, pi/4]: u = U1 + (Um - U1)(1 - cos(pi x))/2 clusters nodes at both ends.
      double x = kPi * g.x[i];
      double u = U1 + (Um - U1) * 0.5 * (1.0 - std::cos(x));
      double wu = g.w[i] * (Um - U1) * 0.5 * kPi * std::sin(x);
      double tan2 = tan2_from_cdf(ndf, alpha, u);
      line(tan2, wu, phi_max_of(std::sqrt(tan2)));
    }
    for (int i = 0; i < order; ++i) {
      // [pi/4, th2] in theta, clustered at both ends; du = 2 pi D(th) cos(th) sin(th) dth.
      double x = kPi * g.x[i];
      double th = 0.25 * kPi + (th2 - 0.25 * kPi) * 0.5 * (1.0 - std::cos(x));
      double dth = g.w[i] * (th2 - 0.25 * kPi) * 0.5 * kPi * std::sin(x);
      double c = std::cos(th), s = std::sin(th);
      double wu = 2.0 * kPi * lobe.D(v3(s, 0.0, c)) * c * s * dth;
      line((s / c) * (s / c), wu, phi_max_of(s / c));
    }
  }
  m.avg_x = sx / m.magnitude;
  m.avg_z = sz / m.magnitude;
  m.d_h = total_ndf_area(ndf, alpha);
  return m;
}

std::array<double, 4> normalized_inverse(const LtcParams &p, double avg_x, double avg_z) {
  Ltc l(p, avg_x, avg_z);
  // Rows of M^-1 = S^-1 [X Y Z]^T: (X - m13 Z) / m11, Y / m22, Z; times m22 so the middle
  // element is 1.
  return {p.m22 * (l.X.x - p.m13 * l.Z.x) / p.m11, p.m22 * (l.X.z - p.m13 * l.Z.z) / p.m11,
          p.m22 * l.Z.x, p.m22 * l.Z.z};
}

double ltc_density(const std::array<double, 4> &inv, const double w[3]) {
  double ox = inv[0] * w[0] + inv[1] * w[2], oy = w[1], oz = inv[2] * w[0] + inv[3] * w[2];
  double det = std::fabs(inv[0] * inv[3] - inv[1] * inv[2]);
  double l2 = ox * ox + oy * oy + oz * oz;
  return oz > 0 ? oz * det / (kPi * l2 * l2) : 0.0;
}

FitEntry fit_entry(Ndf ndf, int a, int t, const LtcParams *warm) {
  FitEntry e;
  e.a = a;
  e.t = t;
  e.alpha = grid_alpha(a);
  e.cos_theta = grid_cos_theta(t);
  e.moments = compute_moments(ndf, e.alpha, e.cos_theta);
  Lobe lobe(ndf, e.alpha, e.cos_theta);
  if (!warm) {
    // Normal view: the lobe is symmetric about the normal, so Z = n and M = diag(m, m, 1).
    e.moments.avg_x = 0;
    e.moments.avg_z = 1;
  }
  Objective obj(lobe, e.moments, kFitSamples);
  // Convergence in the parameters, which are all relative scales (log m11, log m22, m13/m11):
  // 1e-7 leaves the table reproducible to ~1e-7 whatever path the simplex took.
  constexpr double kXTol = 1e-7;
  constexpr int kMaxEvals = 4000;
  if (!warm) {
    // At normal incidence wi deviates from the mirror direction by ~2x the half-vector angle,
    // so the lobe is about as wide as GGX with 2 alpha: start there (capped at a cosine).
    std::array<double, 1> x0{std::log(std::min(2.0 * e.alpha, 1.0))}, step{0.1};
    auto f = [&](const std::array<double, 1> &x) {
      double m = std::exp(x[0]);
      return obj(LtcParams{m, m, 0.0});
    };
    auto x = nelder_mead<1>(f, x0, step, kXTol, kMaxEvals, &e.objective, &e.evaluations);
    double m = std::exp(x[0]);
    e.params = LtcParams{m, m, 0.0};
  } else {
    // log m11, log m22 keep the scales positive and make steps relative; m13 (the tangent of the
    // tilt of the lobe's peak off Z) is taken relative to the lobe width m11.
    auto params = [](const std::array<double, 3> &x) {
      double m11 = std::exp(x[0]);
      return LtcParams{m11, std::exp(x[1]), m11 * x[2]};
    };
    std::array<double, 3> x0{std::log(warm->m11), std::log(warm->m22), warm->m13 / warm->m11};
    std::array<double, 3> step{0.05, 0.05, 0.05};
    auto f = [&](const std::array<double, 3> &x) { return obj(params(x)); };
    e.params = params(nelder_mead<3>(f, x0, step, kXTol, kMaxEvals, &e.objective, &e.evaluations));
  }
  e.inv = normalized_inverse(e.params, e.moments.avg_x, e.moments.avg_z);
  return e;
}

std::vector<FitEntry> fit_row(Ndf ndf, int a, int t_last) {
  std::vector<FitEntry> row;
  for (int t = 0; t <= t_last; ++t)
    row.push_back(fit_entry(ndf, a, t, t ? &row.back().params : nullptr));
  return row;
}

FitEntry refit_entry(Ndf ndf, int a, int t) {
  return fit_row(ndf, a, t).back();
}

LobeError lobe_error(Ndf ndf, double alpha, double cos_theta, const std::array<double, 4> &inv,
                     double magnitude, int n) {
  Lobe lobe(ndf, alpha, cos_theta);
  // M = (M^-1)^-1 for the 2x2 (x, z) block; the y scale is 1.
  double det = inv[0] * inv[3] - inv[1] * inv[2];
  double f00 = inv[3] / det, f02 = -inv[1] / det, f20 = -inv[2] / det, f22 = inv[0] / det;
  LobeError err;
  auto add = [&](V3 w, double s) {
    double wa[3] = {w.x, w.y, w.z};
    double q = ltc_density(inv, wa);
    double p = w.z > 0 ? lobe.fcos(w) / magnitude : 0.0;
    double mis = 1.0 / (s + q);
    if (!std::isfinite(mis)) return;
    err.l1 += std::fabs(p - q) * mis;
    if (w.z <= 0) err.leak += q * mis;
  };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      double u1 = (i + 0.5) / n, u2 = (j + 0.5) / n;
      add(lobe.sample(u1, u2), lobe.sampler_pdf(lobe.sample(u1, u2)));
      V3 o = cosine_sample(u1, u2);
      V3 w = k::normalize(v3(f00 * o.x + f02 * o.z, o.y, f20 * o.x + f22 * o.z));
      add(w, lobe.sampler_pdf(w));
    }
  }
  err.l1 /= double(n) * n;
  err.leak /= double(n) * n;
  return err;
}

}  // namespace glint::ltc
