// Independent double-precision references for the smooth BRDF tests: closed forms written from
// the papers in a different algebraic form than kernels/*.h (spherical angles and trigonometric
// functions rather than vector components; std::complex amplitudes rather than the Lazanyi
// real form), plus the quadrature rules and the deterministic RNG the tests share. Nothing here
// includes or calls the kernel headers.
#ifndef GLINT_TESTS_KERNELS_REFERENCE_H
#define GLINT_TESTS_KERNELS_REFERENCE_H

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <numbers>
#include <vector>

#include "kernel_api.h"

namespace glint_test::ref {

inline constexpr double kPi = std::numbers::pi;

// ---------------------------------------------------------------------------------------------
// Vectors and angles (local frame: +z normal, +x tangent = alpha_x axis).

inline Vec3 add(Vec3 a, Vec3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline Vec3 scale(Vec3 a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
inline double dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double norm(Vec3 a) {
  return std::sqrt(dot(a, a));
}
inline Vec3 normalized(Vec3 a) {
  return scale(a, 1.0 / norm(a));
}

inline Vec3 from_angles(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}
// Unit vector with the given cos(theta), built without going through theta so that cos values
// like 1e-7 are represented exactly.
inline Vec3 from_cos(double cos_theta, double phi) {
  double s = std::sqrt((1.0 - cos_theta) * (1.0 + cos_theta));
  return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}
inline double theta_of(Vec3 w) {
  return std::atan2(std::hypot(w.x, w.y), w.z);
}
inline double phi_of(Vec3 w) {
  return std::atan2(w.y, w.x);
}

// Rounds to float, so the fp32 and fp64 kernel builds see identical inputs. The volatile store is
// load-bearing: GCC 12.2 at -O2 SLP-vectorises the x/y pair of
// {(double)(float)v.x, (double)(float)v.y, ...} and drops the round trip (wrong code, observed:
// cvtpd2ps/cvtps2pd vanish and the doubles are copied through unrounded).
inline double round_to_float(double x) {
  volatile float f = static_cast<float>(x);
  return static_cast<double>(f);
}
inline Vec3 round_to_float(Vec3 v) {
  return {round_to_float(v.x), round_to_float(v.y), round_to_float(v.z)};
}

// ---------------------------------------------------------------------------------------------
// Normal distributions, in (theta, phi) form.

// 1 / s(phi)^2 = cos^2 phi / ax^2 + sin^2 phi / ay^2: both NDFs depend on h only through
// tan^2(theta_h) / s(phi_h)^2, so s(phi) is the lobe's angular scale (in tan theta) along phi.
inline double inv_lobe_scale2(double phi, double ax, double ay) {
  double c = std::cos(phi), s = std::sin(phi);
  return c * c / (ax * ax) + s * s / (ay * ay);
}
inline double lobe_scale(double phi, double ax, double ay) {
  return 1.0 / std::sqrt(inv_lobe_scale2(phi, ax, ay));
}

// GGX, Heitz 2014 Eq. 85 in its trigonometric form:
//   D = 1 / (pi ax ay cos^4(theta) (1 + tan^2(theta) (cos^2 phi/ax^2 + sin^2 phi/ay^2))^2).
inline double D_ggx(double theta, double phi, double ax, double ay) {
  if (!(theta < kPi / 2)) return 0.0;
  double c2 = std::pow(std::cos(theta), 2);
  double e = 1.0 + std::pow(std::tan(theta), 2) * inv_lobe_scale2(phi, ax, ay);
  return 1.0 / (kPi * ax * ay * c2 * c2 * e * e);
}

// The Beckmann exponent tan^2(theta) (cos^2 phi/ax^2 + sin^2 phi/ay^2).
inline double beckmann_exponent(double theta, double phi, double ax, double ay) {
  return std::pow(std::tan(theta), 2) * inv_lobe_scale2(phi, ax, ay);
}

// Beckmann, Heitz 2014 Eq. 84: D = exp(-exponent) / (pi ax ay cos^4(theta)).
inline double D_beckmann(double theta, double phi, double ax, double ay) {
  if (!(theta < kPi / 2)) return 0.0;
  return std::exp(-beckmann_exponent(theta, phi, ax, ay)) /
         (kPi * ax * ay * std::pow(std::cos(theta), 4));
}

inline double D(int ndf, Vec3 h, double ax, double ay) {
  double theta = theta_of(h), phi = phi_of(h);
  return ndf == kNdfBeckmann ? D_beckmann(theta, phi, ax, ay) : D_ggx(theta, phi, ax, ay);
}

// ---------------------------------------------------------------------------------------------
// Smith Lambda.

// Roughness seen along azimuth phi, Heitz 2014 Eq. 80: alpha_o = sqrt(cos^2 ax^2 + sin^2 ay^2).
inline double alpha_along(double phi, double ax, double ay) {
  double c = std::cos(phi), s = std::sin(phi);
  return std::sqrt(c * c * ax * ax + s * s * ay * ay);
}

// GGX, Heitz 2014 Eq. 86 with alpha_o: Lambda = (-1 + sqrt(1 + alpha_o^2 tan^2 theta)) / 2.
inline double lambda_ggx(double theta, double phi, double ax, double ay) {
  double at = alpha_along(phi, ax, ay) * std::tan(theta);
  return 0.5 * (-1.0 + std::sqrt(1.0 + at * at));
}

// Beckmann, Heitz 2014 Eq. 83 (Walter et al. 2007 Eq. 27, exact erf form) with
// a = 1 / (alpha_o tan theta): Lambda = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)).
// The erf(a) - 1 form cancels for a >~ 4; callers compare it with an absolute floor there.
inline double lambda_beckmann(double theta, double phi, double ax, double ay) {
  double a = 1.0 / (alpha_along(phi, ax, ay) * std::tan(theta));
  if (std::isinf(a)) return 0.0;
  return 0.5 * (std::erf(a) - 1.0) + std::exp(-a * a) / (2.0 * a * std::sqrt(kPi));
}

inline double lambda(int ndf, Vec3 w, double ax, double ay) {
  double theta = theta_of(w), phi = phi_of(w);
  return ndf == kNdfBeckmann ? lambda_beckmann(theta, phi, ax, ay) : lambda_ggx(theta, phi, ax, ay);
}

// ---------------------------------------------------------------------------------------------
// Fresnel.

// Schlick 1994 Eq. 15, with std::pow.
inline double fresnel_schlick(double f0, double cos_theta) {
  return f0 + (1.0 - f0) * std::pow(1.0 - cos_theta, 5);
}

// Unpolarised reflectance from vacuum onto a medium of complex index n = eta + i k, from the
// Fresnel amplitude coefficients (Born & Wolf, Principles of Optics, Sec. 1.5.2 and 14.2):
//   n cos(theta_t) = sqrt(n^2 - sin^2 theta)      (principal root: the refracted wave decays)
//   r_s = (cos - n cos_t) / (cos + n cos_t),  r_p = (n^2 cos - n cos_t) / (n^2 cos + n cos_t)
//   F = (|r_s|^2 + |r_p|^2) / 2.
// With k = 0 and eta < 1 the root turns imaginary past the critical angle and |r| = 1 (TIR).
inline double fresnel_complex(double eta, double k, double cos_theta) {
  using C = std::complex<double>;
  C n(eta, k);
  C n2 = n * n;
  double sin2 = (1.0 - cos_theta) * (1.0 + cos_theta);
  C n_cos_t = std::sqrt(n2 - C(sin2, 0.0));
  C rs = (cos_theta - n_cos_t) / (cos_theta + n_cos_t);
  C rp = (n2 * cos_theta - n_cos_t) / (n2 * cos_theta + n_cos_t);
  return 0.5 * (std::norm(rs) + std::norm(rp));
}

// Dielectric from index 1 onto index ior, in the angle form of the Fresnel equations
// (Hecht, Optics, Eq. 4.42-4.43): r_s = -sin(ti - tt) / sin(ti + tt),
// r_p = tan(ti - tt) / tan(ti + tt), with Snell sin(tt) = sin(ti) / ior. The form is 0/0 at
// normal incidence, where F = ((ior - 1) / (ior + 1))^2.
inline double fresnel_dielectric_angles(double ior, double cos_theta) {
  // wo.h of a retro-reflection (wi = wo) can round to 1 + ulp: acos would give NaN.
  double ti = std::acos(std::min(cos_theta, 1.0));
  double sin_t = std::sin(ti) / ior;
  if (sin_t >= 1.0) return 1.0;
  if (ti == 0.0) return std::pow((ior - 1.0) / (ior + 1.0), 2);
  double tt = std::asin(sin_t);
  double rs = std::sin(ti - tt) / std::sin(ti + tt);
  double rp = std::tan(ti - tt) / std::tan(ti + tt);
  return 0.5 * (rs * rs + rp * rp);
}

inline Vec3 fresnel(const Material &m, double cos_theta) {
  switch (m.fresnel) {
    case kFresnelConductor:
      return {fresnel_complex(m.a.x, m.b.x, cos_theta), fresnel_complex(m.a.y, m.b.y, cos_theta),
              fresnel_complex(m.a.z, m.b.z, cos_theta)};
    case kFresnelDielectric: {
      double f = fresnel_dielectric_angles(m.a.x, cos_theta);
      return {f, f, f};
    }
    default:
      return {fresnel_schlick(m.a.x, cos_theta), fresnel_schlick(m.a.y, cos_theta),
              fresnel_schlick(m.a.z, cos_theta)};
  }
}

// ---------------------------------------------------------------------------------------------
// The smooth BRDF (Walter et al. 2007 Eq. 20, Heitz 2014 Eq. 99):
//   f(wi, wo) = F(wo.h) G2 D(h) / (4 cos_i cos_o),  G2 = 1 / (1 + Lambda(wo) + Lambda(wi)),
// returned as f cos_i (the BRDF probe of DESIGN.md). Zero below either horizon.
inline Vec3 brdf_cos(const Material &m, Vec3 wi, Vec3 wo) {
  if (wi.z <= 0.0 || wo.z <= 0.0) return {0.0, 0.0, 0.0};
  Vec3 h = normalized(add(wi, wo));
  double d = D(m.ndf, h, m.alpha_x, m.alpha_y);
  double g2 = 1.0 / (1.0 + lambda(m.ndf, wo, m.alpha_x, m.alpha_y) +
                     lambda(m.ndf, wi, m.alpha_x, m.alpha_y));
  double cos_i = std::cos(theta_of(wi)), cos_o = std::cos(theta_of(wo));
  double f = g2 * d / (4.0 * cos_i * cos_o);
  return scale(fresnel(m, dot(wo, h)), f * cos_i);
}

// ---------------------------------------------------------------------------------------------
// Quadrature.

struct Rule {
  std::vector<double> x, w;
};

// n-point Gauss-Legendre on [a, b]: Newton iteration on P_n from the Tricomi initial guess
// (Abramowitz & Stegun 25.4.29); weights 2 / ((1 - x^2) P_n'(x)^2).
inline Rule gauss_legendre(int n, double a, double b) {
  Rule r;
  r.x.resize(n);
  r.w.resize(n);
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p1 = 1.0, p0 = 0.0;
      for (int j = 1; j <= n; ++j) {
        double p2 = p0;
        p0 = p1;
        p1 = ((2.0 * j - 1.0) * z * p0 - (j - 1.0) * p2) / j;
      }
      dp = n * (z * p1 - p0) / (z * z - 1.0);
      double dz = p1 / dp;
      z -= dz;
      if (std::fabs(dz) < 1e-16) break;
    }
    double w = 2.0 / ((1.0 - z * z) * dp * dp);
    double half = 0.5 * (b - a), mid = 0.5 * (a + b);
    r.x[i] = mid - half * z;
    r.x[n - 1 - i] = mid + half * z;
    r.w[i] = r.w[n - 1 - i] = half * w;
  }
  return r;
}

// n equally spaced nodes over a full period [a, a + 2 pi): spectrally accurate for smooth
// periodic integrands.
inline Rule periodic_trapezoid(int n, double a) {
  Rule r;
  for (int i = 0; i < n; ++i) {
    r.x.push_back(a + 2.0 * kPi * (i + 0.5) / n);
    r.w.push_back(2.0 * kPi / n);
  }
  return r;
}

// Azimuth phi and the parameter psi of the elliptical map tan(phi) = (ay / ax) tan(psi), so
// (cos phi, sin phi) = (ax cos psi, ay sin psi) / N with N = sqrt(ax^2 cos^2 psi + ay^2 sin^2 psi).
// Then lobe_scale(phi) = N and dphi/dpsi = ax ay / N^2: the lobe mass per unit psi is constant,
// so a strongly anisotropic lobe (ax / ay = 25) needs no more azimuthal nodes than a round one.
// psi_of_phi is the continuous inverse (psi and phi always lie in the same quadrant).
inline double psi_of_phi(double phi, double ax, double ay) {
  double psi = std::atan2(ax * std::sin(phi), ay * std::cos(phi));
  return phi + std::remainder(psi - phi, 2.0 * kPi);
}

// Integral of g(h) dω_h over the part of the upper hemisphere with psi (see psi_of_phi) in the
// support of psi_rule and 0 <= theta <= theta_max(phi) <= pi/2, for integrands shaped like a
// microfacet lobe of roughness (ax, ay) around the normal.
//
// Polar substitution tan(theta) = N(psi) tan(u): a lobe of width ~alpha becomes O(1) wide in u
// whatever the roughness, so Gauss-Legendre in u resolves alpha = 1e-3 as well as alpha = 1.
// dθ/du = N / (cos^2 u + N^2 sin^2 u), finite on [0, pi/2]. With ax = ay = 1 this is the plain
// (theta, phi) product rule, suitable for integrands that are not concentrated at the normal.
template <class ThetaMax, class Integrand>
double integrate_hemisphere(const Rule &psi_rule, int n_u, double ax, double ay, ThetaMax theta_max,
                            Integrand g) {
  const Rule unit = gauss_legendre(n_u, 0.0, 1.0);
  double total = 0.0;
  for (size_t ip = 0; ip < psi_rule.x.size(); ++ip) {
    double psi = psi_rule.x[ip];
    double ex = ax * std::cos(psi), ey = ay * std::sin(psi);
    double s = std::hypot(ex, ey);
    double cp = ex / s, sp = ey / s;
    double dphi_dpsi = ax * ay / (s * s);
    double tmax = theta_max(std::atan2(sp, cp));
    double u_max = tmax >= kPi / 2 ? kPi / 2 : std::atan(std::tan(tmax) / s);
    double inner = 0.0;
    for (size_t iu = 0; iu < unit.x.size(); ++iu) {
      double u = u_max * unit.x[iu];
      double cu = std::cos(u), su = std::sin(u);
      double theta = std::atan2(s * su, cu);
      double dtheta_du = s / (cu * cu + s * s * su * su);
      double st = std::sin(theta);
      Vec3 h = {st * cp, st * sp, std::cos(theta)};
      inner += unit.w[iu] * g(h) * st * dtheta_du;
    }
    total += psi_rule.w[ip] * dphi_dpsi * u_max * inner;
  }
  return total;
}

// Adaptive Gauss-Legendre on [a, b]: a panel is accepted when its 10- and 20-point values agree
// to tol (the 20-point value is then far more accurate than that for analytic integrands),
// otherwise it is bisected with tol split between the halves. Starts from `panels` equal panels
// so that a narrow feature cannot slip between the nodes of a single coarse panel.
inline const Rule &unit_gauss(int n) {
  static const Rule g10 = gauss_legendre(10, 0.0, 1.0);
  static const Rule g20 = gauss_legendre(20, 0.0, 1.0);
  return n == 10 ? g10 : g20;
}

template <class F>
double integrate_panel(F &f, double a, double b, double tol, int depth) {
  const Rule &g10 = unit_gauss(10), &g20 = unit_gauss(20);
  double coarse = 0.0, fine = 0.0, magnitude = 0.0;
  for (size_t i = 0; i < g10.x.size(); ++i) coarse += g10.w[i] * f(a + (b - a) * g10.x[i]);
  for (size_t i = 0; i < g20.x.size(); ++i) {
    double v = f(a + (b - a) * g20.x[i]);
    fine += g20.w[i] * v;
    magnitude += g20.w[i] * std::fabs(v);
  }
  coarse *= b - a;
  fine *= b - a;
  magnitude *= b - a;
  // Below ~1e-13 of the panel's magnitude the difference is rounding noise, not truncation.
  double diff = std::fabs(fine - coarse);
  if (diff <= tol || diff <= 1e-13 * magnitude || depth >= 20) return fine;
  double mid = 0.5 * (a + b);
  return integrate_panel(f, a, mid, 0.5 * tol, depth + 1) +
         integrate_panel(f, mid, b, 0.5 * tol, depth + 1);
}

template <class F>
double integrate_adaptive(F f, double a, double b, double tol, int panels) {
  double total = 0.0;
  for (int i = 0; i < panels; ++i) {
    double lo = a + (b - a) * i / panels, hi = a + (b - a) * (i + 1) / panels;
    total += integrate_panel(f, lo, hi, tol / panels, 0);
  }
  return total;
}

// integrate_hemisphere over the full circle of azimuths with adaptive rules in both psi and u,
// for domains theta <= theta_max(phi) whose boundary varies quickly with phi (grazing views).
// tol is the target absolute error; the inner integrals get a much smaller share.
template <class ThetaMax, class Integrand>
double integrate_hemisphere_adaptive(double ax, double ay, ThetaMax theta_max, Integrand g,
                                     double tol) {
  auto over_u = [&](double psi) {
    double ex = ax * std::cos(psi), ey = ay * std::sin(psi);
    double s = std::hypot(ex, ey);
    double cp = ex / s, sp = ey / s;
    double tmax = theta_max(std::atan2(sp, cp));
    double u_max = tmax >= kPi / 2 ? kPi / 2 : std::atan(std::tan(tmax) / s);
    auto f = [&](double u) {
      double cu = std::cos(u), su = std::sin(u);
      double theta = std::atan2(s * su, cu);
      double st = std::sin(theta);
      Vec3 h = {st * cp, st * sp, std::cos(theta)};
      return g(h) * st * s / (cu * cu + s * s * su * su);
    };
    return ax * ay / (s * s) * integrate_adaptive(f, 0.0, u_max, 1e-3 * tol, 2);
  };
  return integrate_adaptive(over_u, 0.0, 2.0 * kPi, tol, 8);
}

// ---------------------------------------------------------------------------------------------
// Deterministic random numbers (splitmix64; same sequence on every platform and library).

class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Upper-hemisphere direction with cos(theta) uniform in [cos_min, cos_max].
  Vec3 direction(double cos_min, double cos_max) {
    double c = uniform(cos_min, cos_max);
    return from_cos(c, uniform(0.0, 2.0 * kPi));
  }
  // Direction uniform on the whole sphere.
  Vec3 sphere() { return from_cos(uniform(-1.0, 1.0), uniform(0.0, 2.0 * kPi)); }

 private:
  uint64_t state_;
};

// |a - b| / |b|, with 0 for a == b == 0.
inline double rel_err(double a, double b) {
  if (a == b) return 0.0;
  return std::fabs(a - b) / std::fabs(b);
}

}  // namespace glint_test::ref

#endif  // GLINT_TESTS_KERNELS_REFERENCE_H
