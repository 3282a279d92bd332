// kernels/fresnel.h (fp64 build) against closed forms at normal and grazing incidence, against
// Fresnel amplitude coefficients evaluated with std::complex, and against the angle form of the
// Fresnel equations. fp32 agreement is checked in precision_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "kernel_api.h"
#include "reference.h"

namespace glint_test {
namespace {

struct Conductor {
  const char *name;
  double eta;
  double k;
};

// Metals at roughly R, G, B (from the usual measured tables, e.g. Palik via pbrt's spectra; only
// plausibility matters here), plus edge cases: weak absorption and a very small eta.
constexpr Conductor kConductors[] = {
    {"gold R", 0.143, 3.983},      {"gold G", 0.374, 2.385},      {"gold B", 1.442, 1.603},
    {"silver G", 0.117, 3.122},    {"copper R", 0.200, 3.912},    {"copper B", 1.102, 2.142},
    {"aluminium R", 1.657, 9.224}, {"aluminium B", 0.521, 4.837}, {"weakly absorbing", 1.5, 0.01},
    {"tiny eta", 0.02, 8.0},       {"glassy metal", 2.4, 0.3}};

constexpr double kSchlickF0[] = {0.0, 0.02, 0.04, 0.5, 0.95, 1.0};
constexpr double kIors[] = {1.0, 1.33, 1.5, 2.4, 1.0 / 1.33, 1.0 / 1.5};

// cos(theta) from grazing to normal, denser near both ends where the curves bend.
std::vector<double> cos_samples() {
  std::vector<double> c = {0.0, 1e-9, 1e-6, 1e-4, 1e-3, 1.0 - 1e-6, 1.0};
  constexpr int kSteps = 400;
  for (int i = 1; i < kSteps; ++i) c.push_back(std::pow(static_cast<double>(i) / kSteps, 1.5));
  std::sort(c.begin(), c.end());
  return c;
}

TEST(KernelFresnel, SchlickEndpointsAndClosedForm) {
  constexpr double kRelTol = 1e-14;
  for (double f0 : kSchlickF0) {
    // At normal incidence 1 - cos = 0 exactly, so F must be f0 to the bit.
    EXPECT_EQ(f64::fresnel_schlick(f0, 1.0), f0);
    // At grazing incidence f0 + (1 - f0) may round by an ulp.
    EXPECT_DOUBLE_EQ(f64::fresnel_schlick(f0, 0.0), 1.0) << "f0 " << f0;
    double previous = 1.0;
    for (double c : cos_samples()) {
      double f = f64::fresnel_schlick(f0, c);
      EXPECT_NEAR(f, ref::fresnel_schlick(f0, c), kRelTol * ref::fresnel_schlick(f0, c))
          << "f0 " << f0 << " cos " << c;
      // Reflectance falls monotonically from grazing to normal incidence.
      EXPECT_LE(f, previous * (1 + kRelTol)) << "f0 " << f0 << " cos " << c;
      previous = f;
    }
  }
}

// Born & Wolf normal-incidence reflectance R = ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2).
TEST(KernelFresnel, ConductorNormalAndGrazingIncidence) {
  constexpr double kRelTol = 1e-13;
  for (const Conductor &m : kConductors) {
    double expected =
        ((m.eta - 1) * (m.eta - 1) + m.k * m.k) / ((m.eta + 1) * (m.eta + 1) + m.k * m.k);
    EXPECT_NEAR(f64::fresnel_conductor(m.eta, m.k, 1.0), expected, kRelTol * expected) << m.name;
    // Every interface reflects everything at grazing incidence (r_s = r_p = 1 at cos = 0), and
    // F approaches 1 linearly in cos: 1 - F = O(cos) with an O(1) constant for these metals.
    EXPECT_NEAR(f64::fresnel_conductor(m.eta, m.k, 0.0), 1.0, 1e-15) << m.name;
    EXPECT_NEAR(f64::fresnel_conductor(m.eta, m.k, 1e-6), 1.0, 1e-4) << m.name;
  }
}

TEST(KernelFresnel, ConductorMatchesComplexAmplitudes) {
  constexpr double kRelTol = 1e-9;
  double worst = 0.0;
  for (const Conductor &m : kConductors) {
    for (double c : cos_samples()) {
      double expected = ref::fresnel_complex(m.eta, m.k, c);
      double got = f64::fresnel_conductor(m.eta, m.k, c);
      worst = std::max(worst, ref::rel_err(got, expected));
      EXPECT_NEAR(got, expected, kRelTol * expected) << m.name << " cos " << c;
      EXPECT_GE(got, 0.0);
      EXPECT_LE(got, 1.0);
    }
  }
  std::printf("[ info ] conductor vs complex amplitudes: max relative error = %.2e\n", worst);
}

// A "conductor" without absorption is a dielectric: same reflectance from both kernel functions,
// the complex reference and the angle form of the Fresnel equations, TIR included for eta < 1.
TEST(KernelFresnel, ConductorWithoutAbsorptionIsDielectric) {
  constexpr double kSameFormulaTol = 1e-12;
  constexpr double kRefTol = 1e-9;
  for (double ior : kIors) {
    if (ior == 1.0) continue;  // matched index: 0/0 at exactly grazing incidence in both forms
    for (double c : cos_samples()) {
      double conductor = f64::fresnel_conductor(ior, 0.0, c);
      double dielectric = f64::fresnel_dielectric(ior, c);
      double expected = ref::fresnel_dielectric_angles(ior, c);
      // Absolute near Brewster's angle, where r_p vanishes and the relative error of the small
      // p term is meaningless; F itself stays >= ~((n-1)/(n+1))^2 / 2.
      EXPECT_NEAR(conductor, dielectric, kSameFormulaTol) << "ior " << ior << " cos " << c;
      EXPECT_NEAR(dielectric, expected, kRefTol * expected) << "ior " << ior << " cos " << c;
      EXPECT_NEAR(dielectric, ref::fresnel_complex(ior, 0.0, c), kRefTol * expected)
          << "ior " << ior << " cos " << c;
    }
  }
}

TEST(KernelFresnel, DielectricNormalIncidenceAndGrazing) {
  for (double ior : kIors) {
    double expected = std::pow((ior - 1) / (ior + 1), 2);
    EXPECT_NEAR(f64::fresnel_dielectric(ior, 1.0), expected, 1e-15) << "ior " << ior;
    EXPECT_NEAR(f64::fresnel_dielectric(ior, 0.0), 1.0, 1e-15) << "ior " << ior;
  }
  // Glass: 4 % at normal incidence, the textbook number.
  EXPECT_NEAR(f64::fresnel_dielectric(1.5, 1.0), 0.04, 1e-15);
}

// From the dense side (ior < 1), everything beyond the critical angle sin(theta_c) = ior is
// reflected, and F rises continuously to 1 as the critical angle is approached from inside.
TEST(KernelFresnel, DielectricTotalInternalReflection) {
  for (double ior : {1.0 / 1.33, 1.0 / 1.5, 1.0 / 2.4}) {
    double cos_critical = std::sqrt(1.0 - ior * ior);
    for (double c : cos_samples()) {
      if (c >= cos_critical * (1 - 1e-12)) continue;
      EXPECT_EQ(f64::fresnel_dielectric(ior, c), 1.0) << "ior " << ior << " cos " << c;
    }
    double inside = f64::fresnel_dielectric(ior, cos_critical + 1e-10);
    EXPECT_LT(inside, 1.0) << "ior " << ior;
    EXPECT_GT(inside, 0.999) << "ior " << ior;
    EXPECT_LT(f64::fresnel_dielectric(ior, cos_critical + 0.05), 0.9) << "ior " << ior;
  }
}

// Issue 8: ior^2 underflows (fp32 below ior ~1e-19), and the former (1 - c^2) / ior^2 was 0/0 =
// NaN at normal incidence. The exact value: ((1 - ior) / (1 + ior))^2 at normal incidence, which
// tends to 1 as ior -> 0, and total internal reflection (F = 1) wherever sin(theta) > ior; both
// precisions must give it, from ior 1e-38 up. Large ior: the closed form at normal incidence and
// the angle form elsewhere. fp32 tolerance: a few roundings of an O(1) result, 1e-6.
TEST(KernelFresnel, DielectricExtremeIorInBothPrecisions) {
  for (double ior : {1e-38, 1e-30, 1e-20, 1e-10, 1e-4}) {
    for (double c : {1.0, 1.0 - 1e-6, 0.5, 1e-4, 0.0}) {
      const double sin_t = std::sqrt(1 - c * c);
      const double expected = sin_t > ior ? 1.0 : std::pow((1 - ior) / (1 + ior), 2);
      const double f32v = f32::fresnel_dielectric(ior, c), f64v = f64::fresnel_dielectric(ior, c);
      EXPECT_NEAR(f64v, expected, 1e-15) << "ior " << ior << " cos " << c;
      EXPECT_NEAR(f32v, expected, 1e-6) << "ior " << ior << " cos " << c;
    }
  }
  for (double ior : {1e3, 1e5, 9.99e5}) {
    const double normal = std::pow((ior - 1) / (ior + 1), 2);
    EXPECT_NEAR(f64::fresnel_dielectric(ior, 1.0), normal, 1e-15) << "ior " << ior;
    EXPECT_NEAR(f32::fresnel_dielectric(ior, 1.0), normal, 1e-6) << "ior " << ior;
    for (double c : {0.5, 1e-4}) {
      const double expected = ref::fresnel_dielectric_angles(ior, c);
      // 1e-9: the angle form's own rounding (as kRefTol above; at cos 1e-4 and ior 1e6 it is
      // ~1e-12 from the sines of ti +- tt with tt ~ 1e-6).
      EXPECT_NEAR(f64::fresnel_dielectric(ior, c), expected, 1e-9) << "ior " << ior;
      EXPECT_NEAR(f32::fresnel_dielectric(ior, c), expected, 1e-6) << "ior " << ior;
    }
  }
}

// fresnel_eval dispatches on the kind and evaluates per channel; the dielectric uses a.x only.
TEST(KernelFresnel, EvalDispatchesPerChannel) {
  constexpr double kRelTol = 1e-9;
  const Material schlick = {kNdfGgx, 0.3, 0.3, kFresnelSchlick, {0.04, 0.5, 0.95}, {0, 0, 0}};
  const Material gold = {
      kNdfGgx, 0.3, 0.3, kFresnelConductor, {0.143, 0.374, 1.442}, {3.983, 2.385, 1.603}};
  const Material glass = {kNdfGgx, 0.3, 0.3, kFresnelDielectric, {1.5, 7.0, 9.0}, {0, 0, 0}};
  for (const Material &m : {schlick, gold, glass}) {
    for (double c : {0.0, 0.1, 0.5, 0.9, 1.0}) {
      Vec3 got = f64::fresnel_eval(m, c), expected = ref::fresnel(m, c);
      EXPECT_NEAR(got.x, expected.x, kRelTol * expected.x) << m << " cos " << c;
      EXPECT_NEAR(got.y, expected.y, kRelTol * expected.y) << m << " cos " << c;
      EXPECT_NEAR(got.z, expected.z, kRelTol * expected.z) << m << " cos " << c;
    }
  }
}

// F_conductor computes a = Re sqrt((eta + i k)^2 - sin^2) through w = sqrt((a2b2 + |t0|) / 2)
// and multiplies both Fresnel fractions by w (one division per channel, fresnel.h). Two regimes
// of that form: w ~ 1e-10 (eta^2 - k^2 ~ sin^2 and eta k tiny), where the terms of degree 2 in w
// reach the fp32 subnormals unless rescaled (at grazing cosines F then lost 3e-6 to 6e-5, found
// by emulating the unscaled form in numpy float32), and w = 0 (k = 0 exactly at the critical
// angle, t0 rounding to 0), where both fractions are 0/0 unless w is replaced. Against the
// complex-amplitude reference on the same (float) inputs: F is well conditioned in these inputs
// (the reference's own 1 - cos^2 rounds like the kernel's), so fp32 gets a few eps
// (4 eps_32 = 4.8e-7), fp64 1e-12.
TEST(KernelFresnel, ConductorTinyAbsorptionTinyEtaAndCriticalAngle) {
  constexpr double kTol32 = 4.8e-7, kTol64 = 1e-12;
  struct Case {
    double eta, k, c;
  };
  // (eta^4 must stay above the fp32 subnormals for the tiny-eta cases, or t0^2 and with it
  // a2b2 flush to 0: 0/0 at c = 1 in any form of the formula; validation asks eta >= 1e-6.)
  for (const Case &m : {Case{1e-10, 0.0, 1.0}, Case{3e-11, 1e-11, 1.0}, Case{1.0, 5e-21, 1e-14},
                        Case{1.0, 1e-21, 1e-15}, Case{1.0, 2e-20, 3e-15}}) {
    const double e = ref::round_to_float(m.eta), kk = ref::round_to_float(m.k),
                 cc = ref::round_to_float(m.c);
    const double expected = ref::fresnel_complex(e, kk, cc);
    EXPECT_NEAR(f32::fresnel_conductor(e, kk, cc), expected, kTol32 * expected)
        << "eta " << e << " k " << kk << " c " << cc;
    EXPECT_NEAR(f64::fresnel_conductor(e, kk, cc), expected, kTol64 * expected)
        << "eta " << e << " k " << kk << " c " << cc;
  }
  // k = 0, eta = 0.5: the critical angle is at sin^2 = 0.25. Find float cosines next to
  // sqrt(0.75) for which 1 - c^2 rounds to exactly 0.25 in fp32 (t0 = 0, w = 0): total internal
  // reflection begins there, F = 1 (r_s = r_p = 1 with a real cos_t = 0).
  int at_critical = 0;
  float below = std::sqrt(0.75f), above = below;
  for (int step = 0; step < 64; ++step) {
    for (float c : {below, above}) {
      if (0.5f * 0.5f - (1.0f - c * c) != 0.0f) continue;
      EXPECT_EQ(f32::fresnel_conductor(0.5, 0.0, c), 1.0) << "cos " << c;
      ++at_critical;
    }
    below = std::nextafter(below, 0.0f);
    above = std::nextafter(above, 2.0f);
  }
  EXPECT_GT(at_critical, 0) << "no float cosine puts t0 at exactly 0: the w = 0 case is untested";
}

}  // namespace
}  // namespace glint_test
