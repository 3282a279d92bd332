// The AUTO training set's truth (tools/area_auto Truth: tests/support/plane_adaptive.h with the
// kernels' BRDF) and LECOCQ at grazing views, against an independent reference: Monte Carlo in
// double over the light's solid angle with a BRDF written here from the papers (not the kernels'
// functions), two sampling strategies combined by the balance heuristic (Veach 1997 Sec. 9.2):
// the lobe (h ~ D(h) h.z, wi = reflect(wo, h)) and the light (uniform over its area). Two
// training outliers of session 11's refit, by their configurations:
//  - Beckmann MakeConfigs(1, 1000, 8, BECKMANN)[634] view 7 (alpha 0.013, wo.z 1e-4): REFERENCE
//    8 / 16 nodes gave 1.8 / 4.1 from a unit-radiance light, above the albedo bound, and the
//    truth gave 1.9e-25. The truth was wrong (its adaptive quadrature missed the lobe's sliver
//    where the light's edge cuts it, the mirror direction lying just outside the light); the true
//    value is 0.607. REFERENCE is under-resolved there (0.11, 0.32, 0.57 at 32, 128, 1024 nodes),
//    an error the AUTO table measures, not a defect of its Jacobian.
//  - GGX MakeConfigs(1, 1000, 8, GGX)[676] view 7 (alpha 0.72, wo.z 1e-4, a small light 20-30
//    deg up): LECOCQ gave 0.995 (~albedo) for a truth of 0.0028: its moments put the mean half
//    vector on the horizon and W ~ 1 / h.z exploded (kernels/area/area_lecocq.h lecocq_weight).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "kernels/layout.h"
#include "tools/area_auto/area_auto_data.h"
#include "tools/area_auto/area_auto_fit.h"

namespace glint::area_auto {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct D3 {
  double x, y, z;
};
D3 operator+(D3 a, D3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
D3 operator-(D3 a, D3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
D3 operator*(D3 a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
double Dot(D3 a, D3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
D3 Cross(D3 a, D3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
D3 Unit(D3 a) {
  return a * (1 / std::sqrt(Dot(a, a)));
}

// The smooth BRDF of DESIGN.md with F = 1 (Schlick f0 = 1), isotropic, written from the papers:
// f = D G2 / (4 cos_i cos_o), height-correlated G2 = 1 / (1 + Lambda_i + Lambda_o) (Heitz 2014
// Eq. 99). Beckmann (Walter et al. 2007 Eq. 25, 27): D = exp(-tan^2 / a^2) / (pi a^2 cos^4),
// Lambda = (erf(m) - 1) / 2 + exp(-m^2) / (2 m sqrt(pi)), m = cot / a. GGX (Eq. 33, 34 via
// Heitz 2014 Eq. 72): D = a^2 / (pi cos^4 (a^2 + tan^2)^2), Lambda = (-1 + sqrt(1 + 1 / m^2)) / 2.
struct Brdf {
  int ndf;
  double a;
  double Lambda(D3 w) const {
    const double s = std::sqrt(std::max(0.0, 1 - w.z * w.z));
    if (s == 0) return 0;
    const double m = w.z / (a * s);
    if (ndf == GLINT_NDF_BECKMANN)
      return 0.5 * (std::erf(m) - 1) + std::exp(-m * m) / (2 * m * std::sqrt(kPi));
    return 0.5 * (-1 + std::sqrt(1 + 1 / (m * m)));
  }
  double D(D3 h) const {
    if (h.z <= 0) return 0;
    const double c2 = h.z * h.z, t2 = (1 - c2) / c2;
    if (ndf == GLINT_NDF_BECKMANN) return std::exp(-t2 / (a * a)) / (kPi * a * a * c2 * c2);
    const double q = a * a + t2;
    return a * a / (kPi * c2 * c2 * q * q);
  }
  // f(wi, wo) cos_i.
  double FCos(D3 wi, D3 wo) const {
    if (wi.z <= 0 || wo.z <= 0) return 0;
    const D3 h = Unit(wi + wo);
    return D(h) / (1 + Lambda(wi) + Lambda(wo)) / (4 * wo.z);
  }
  // Sampling h with density D(h) h.z (Walter et al. 2007 Eq. 28-30, 35-36): tan^2 theta_h.
  double Tan2(double u) const {
    return ndf == GLINT_NDF_BECKMANN ? -a * a * std::log1p(-u) : a * a * u / (1 - u);
  }
};

// A convex polygon light seen from the origin (one-sided, emitting towards the origin).
struct Light {
  std::vector<D3> v;
  D3 n;                     // unit normal of the plane, pointing away from the origin
  double d;                 // distance of the plane
  double winding = 1;       // +1: counter-clockwise about n
  std::vector<double> cum;  // cumulative fan-triangle areas
  explicit Light(const std::vector<D3> &p) : v(p) {
    D3 s = {0, 0, 0};  // sum v_i x v_i+1 = 2 area x the normal about which v turns anticlockwise
    for (size_t i = 0; i < v.size(); ++i) s = s + Cross(v[i], v[(i + 1) % v.size()]);
    n = Unit(s);
    d = Dot(n, v[0]);
    if (d < 0) {
      n = n * -1;
      d = -d;
      winding = -1;
    }
    double a = 0;
    for (size_t i = 1; i + 1 < v.size(); ++i) {
      a += 0.5 *
           std::sqrt(Dot(Cross(v[i] - v[0], v[i + 1] - v[0]), Cross(v[i] - v[0], v[i + 1] - v[0])));
      cum.push_back(a);
    }
  }
  double Area() const { return cum.back(); }
  // The point where the ray along unit w meets the light, if it does.
  bool Hit(D3 w, D3 *p) const {
    const double dn = Dot(w, n);
    if (!(dn > 0)) return false;  // parallel, or the plane is behind the origin along w
    *p = w * (d / dn);
    for (size_t i = 0; i < v.size(); ++i) {
      const D3 a = v[i], b = v[(i + 1) % v.size()];
      if (winding * Dot(Cross(b - a, *p - a), n) < 0) return false;
    }
    return true;
  }
  // Solid-angle density of uniform area sampling at the point p (unit direction w).
  double Pdf(D3 p, D3 w) const { return Dot(p, p) / (Area() * Dot(w, n)); }
  D3 Sample(double u0, double u1, double u2) const {
    const double t = u0 * Area();
    size_t k = 0;
    while (k + 1 < cum.size() && cum[k] < t) ++k;
    if (u1 + u2 > 1) {
      u1 = 1 - u1;
      u2 = 1 - u2;
    }
    return v[0] + (v[k + 1] - v[0]) * u1 + (v[k + 2] - v[0]) * u2;
  }
};

struct Estimate {
  double mean, se;
};

// int_light f cos_i dwi (unit radiance) by the balance heuristic of one lobe sample and one light
// sample per iteration; `n` iterations, seeded counter-free generator, explicit transforms.
Estimate MisReference(const Brdf &f, D3 wo, const Light &light, long n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto u = [&] { return double(rng() >> 11) * (1.0 / 9007199254740992.0); };
  auto pdf_lobe = [&](D3 wi) {
    const D3 h = Unit(wi + wo);
    const double oh = Dot(wo, h);
    return oh > 0 ? f.D(h) * h.z / (4 * oh) : 0.0;
  };
  double sum = 0, sum2 = 0;
  for (long k = 0; k < n; ++k) {
    double x = 0;
    {  // lobe sample
      const double t2 = f.Tan2(u()), ph = 2 * kPi * u();
      const double cz = 1 / std::sqrt(1 + t2), sz = std::sqrt(t2) * cz;
      const D3 h = {sz * std::cos(ph), sz * std::sin(ph), cz};
      const double oh = Dot(wo, h);
      D3 p;
      if (oh > 0) {
        const D3 wi = h * (2 * oh) - wo;
        if (wi.z > 0 && light.Hit(wi, &p)) {
          const double pb = pdf_lobe(wi), pl = light.Pdf(p, wi);
          x += f.FCos(wi, wo) / (pb + pl);
        }
      }
    }
    {  // light sample
      const double u0 = u(), u1 = u(), u2 = u();
      const D3 p = light.Sample(u0, u1, u2);
      const D3 wi = Unit(p);
      if (wi.z > 0) {
        const double pb = pdf_lobe(wi), pl = light.Pdf(p, wi);
        x += f.FCos(wi, wo) / (pb + pl);
      }
    }
    sum += x;
    sum2 += x * x;
  }
  const double mean = sum / double(n);
  return {mean, std::sqrt(std::max(0.0, sum2 / double(n) - mean * mean) / double(n))};
}

struct Query {
  Config config;  // with the one view
  Brdf brdf;
  D3 wo;
  Light light;
};
Query TrainingQuery(int ndf, int index, int view) {
  Config c = MakeConfigs(kTrainSeed, index + 1, 8, ndf)[size_t(index)];
  c.wo = {c.wo[size_t(view)]};
  // As the request carries them: floats.
  std::vector<D3> p;
  for (const V3 &v : c.polygon)
    p.push_back({double(float(v[0])), double(float(v[1])), double(float(v[2]))});
  const V3 &w = c.wo[0];
  return {c,
          Brdf{ndf, double(float(c.alpha))},
          {double(float(w[0])), double(float(w[1])), double(float(w[2]))},
          Light(p)};
}

TEST(AreaTruth, BeckmannGrazingSliverAtTheLightsEdgeConfig634View7) {
  const Query q = TrainingQuery(GLINT_NDF_BECKMANN, 634, 7);
  const Estimate ref = MisReference(q.brdf, q.wo, q.light, 4000000, 634);
  const double truth = Truth(q.config)[0];
  std::printf("Beckmann [634] view 7: MC %.6f +- %.6f, truth %.6f\n", ref.mean, ref.se, truth);
  ASSERT_GT(ref.mean, 20 * ref.se) << "the reference resolves the light";
  // The truth's stated accuracy (rel. tol. 1e-5) plus 4 standard errors of the reference.
  EXPECT_NEAR(truth, ref.mean, 4 * ref.se + 1e-5 * ref.mean);
}

// LECOCQ (host path, fp32 as the device) against the reference, in tools/lecocq/README.md's
// measure |x - ref| / max(ref, 0.01): at most 0.605, the worst it states for alpha 0.4-1 at
// grazing views (README "Near-horizon views", session 10), plus 4 standard errors of the
// reference in that measure. Before the fix: 0.995 for 0.0029, i.e. 99 in this measure (350 in
// AUTO's, floor 1e-3).
TEST(AreaTruth, LecocqGgxGrazingSmallLightConfig676View7) {
  const Query q = TrainingQuery(GLINT_NDF_GGX, 676, 7);
  const Estimate ref = MisReference(q.brdf, q.wo, q.light, 4000000, 676);
  const double truth = Truth(q.config)[0];
  ASSERT_GT(ref.mean, 20 * ref.se) << "the reference resolves the light";
  EXPECT_NEAR(truth, ref.mean, 4 * ref.se + 1e-5 * ref.mean);
  const double floor = std::max(ref.mean, 0.01), allowance = 4 * ref.se / floor;
  for (auto method : {glint::v1::LECOCQ, glint::v1::LECOCQ_PEARSON}) {
    const double x = HostRed(MakeRequest(q.config, method, 0, 1))[0];
    std::printf("GGX [676] view 7: MC %.6g +- %.2g, truth %.6g, %s %.6g\n", ref.mean, ref.se, truth,
                glint::v1::AreaMethod_Name(method).c_str(), x);
    EXPECT_LE(std::fabs(x - ref.mean) / floor, 0.605 + allowance)
        << glint::v1::AreaMethod_Name(method);
  }
}

}  // namespace
}  // namespace glint::area_auto
