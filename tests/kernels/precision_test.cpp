// The same kernel headers compiled with real = float and real = double: agreement away from the
// extremes, and at the extremes (DESIGN.md "Stability at the extremes") finite, non-negative
// outputs in both precisions that also match the independent reference wherever the value is
// well conditioned.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "kernel_api.h"
#include "reference.h"

namespace glint_test {
namespace {

using ref::kPi;

// All material parameters float-representable, so both builds see the same material.
std::vector<Material> materials(int ndf, Alphas a) {
  double ax = ref::round_to_float(a.x), ay = ref::round_to_float(a.y);
  auto f = [](double x, double y, double z) { return ref::round_to_float(Vec3{x, y, z}); };
  return {
      {ndf, ax, ay, kFresnelSchlick, f(0.04, 0.5, 0.95), f(0, 0, 0)},
      {ndf, ax, ay, kFresnelConductor, f(0.143, 0.374, 1.442), f(3.983, 2.385, 1.603)},
      {ndf, ax, ay, kFresnelDielectric, f(1.5, 1.5, 1.5), f(0, 0, 0)},
      {ndf, ax, ay, kFresnelDielectric, f(1 / 1.5, 1 / 1.5, 1 / 1.5), f(0, 0, 0)},
  };
}

// ---------------------------------------------------------------------------------------------
// 8. fp32 against fp64 on identical (float-representable) inputs, cos > 0.05 and alpha >= 0.01.
//
// The fp32 error is set by conditioning, not by the formulas: rounding the half vector by ~6e-8
// moves the Beckmann exponent t^2 by ~t^2 * 4e-7, which exp(-t^2) turns into a relative error of
// the same size, so the Beckmann tail (t^2 up to the cut-off at 80) gets a looser bound than the
// lobe core. Measured maxima: 1.3e-6 for GGX with Schlick, 6e-6 over the core with every
// Fresnel kind, 3e-5 in the Beckmann tail (see the printout).
constexpr double kCoreRelTol = 1e-5;  // GGX everywhere, Beckmann with t^2 < 20
constexpr double kTailRelTol = 1e-4;  // Beckmann 20 <= t^2 <= 80
constexpr double kCosMin = 0.05;

// From the dense side (ior < 1), F has infinite slope at the critical angle: with
// cos_t^2 = 1 - (1 - cos^2) / ior^2, the fp32 rounding of cos_t^2 gives |dF/F| <~ 3.5e-7 / cos_t^2
// (measured over 2e6 angles). Away from that the Fresnel terms are as accurate as the rest.
constexpr double kCriticalSlope = 1e-6;
constexpr double kCriticalSkip = 1e-4;  // |cos_t^2| below this: too close to call

// Extra relative tolerance for the Fresnel term at cos(theta) = c, or < 0 to skip the sample.
double critical_angle_tol(const Material &m, double c) {
  if (m.fresnel != kFresnelDielectric || m.a.x >= 1.0) return 0.0;
  double cos_t2 = 1.0 - (1.0 - c * c) / (m.a.x * m.a.x);
  if (std::fabs(cos_t2) < kCriticalSkip) return -1.0;
  return cos_t2 > 0.0 ? kCriticalSlope / cos_t2 : 0.0;  // TIR: exactly 1 in both
}

TEST(KernelPrecision, Fp32MatchesFp64AwayFromExtremes) {
  constexpr Alphas kAlphas[] = {{0.01, 0.01}, {0.05, 0.05}, {0.2, 0.2},  {0.5, 0.5},
                                {1.0, 1.0},   {0.1, 0.6},   {0.02, 0.3}, {0.6, 0.1}};
  constexpr int kPairs = 3000;
  ref::Rng rng(17);
  double worst_core = 0.0, worst_tail = 0.0;
  long compared = 0;
  for (int ndf : kNdfs) {
    for (const Alphas a0 : kAlphas) {
      const Alphas a = {ref::round_to_float(a0.x), ref::round_to_float(a0.y)};
      const std::vector<Material> mats = materials(ndf, a);
      for (int i = 0; i < kPairs; ++i) {
        // Half random pairs, half mirrored about a normal inside the lobe (see smooth_brdf_test).
        Vec3 wo = rng.direction(kCosMin, 1.0), wi;
        if (i % 2 == 0) {
          wi = rng.direction(kCosMin, 1.0);
        } else {
          double phi = rng.uniform(0.0, 2 * kPi);
          Vec3 h = ref::from_angles(std::atan(3.0 * rng.uniform() * ref::lobe_scale(phi, a.x, a.y)),
                                    phi);
          wi = ref::add(ref::scale(h, 2.0 * ref::dot(wo, h)), ref::scale(wo, -1.0));
          if (wi.z < kCosMin) continue;
        }
        wo = ref::round_to_float(wo);
        wi = ref::round_to_float(wi);
        Vec3 h = ref::normalized(ref::add(wi, wo));
        double t2 = ref::beckmann_exponent(ref::theta_of(h), ref::phi_of(h), a.x, a.y);
        bool tail = ndf == kNdfBeckmann && t2 >= 20.0;
        // Within rounding of the cut-off one build may flush D to 0 and the other not.
        bool at_cutoff = ndf == kNdfBeckmann && std::fabs(t2 - 80.0) < 0.1;
        if (ndf == kNdfBeckmann && t2 > 80.0 && !at_cutoff) continue;  // both exactly 0
        for (const Material &m : mats) {
          double extra = critical_angle_tol(m, ref::dot(wo, h));
          if (extra < 0.0) continue;
          double tol = (tail ? kTailRelTol : kCoreRelTol) + extra;
          Vec3 v32 = f32::reflect_cos(m, wi, wo), v64 = f64::reflect_cos(m, wi, wo);
          for (auto [p, q] :
               {std::pair{v32.x, v64.x}, std::pair{v32.y, v64.y}, std::pair{v32.z, v64.z}}) {
            if (at_cutoff && (p == 0.0 || q == 0.0)) continue;
            double err = ref::rel_err(p, q);
            double &worst = tail ? worst_tail : worst_core;
            if (extra == 0.0) worst = std::max(worst, err);
            ++compared;
            EXPECT_LT(err, tol) << m << " wi " << wi << " wo " << wo << " fp32 " << p << " fp64 "
                                << q << " t^2 " << t2;
          }
        }
        // The pieces, so that a failure above can be pinned on one of them.
        EXPECT_LT(ref::rel_err(f32::visibility(ndf, wo, wi, a.x, a.y),
                               f64::visibility(ndf, wo, wi, a.x, a.y)),
                  kCoreRelTol)
            << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y << ") wi " << wi << " wo " << wo;
        // wz Lambda enters G2 only through z + wz Lambda, so compare it on that scale.
        double zl32 = f32::z_lambda(ndf, wo, a.x, a.y), zl64 = f64::z_lambda(ndf, wo, a.x, a.y);
        EXPECT_LT(std::fabs(zl32 - zl64) / (wo.z + zl64), kCoreRelTol)
            << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y << ") wo " << wo;
      }
    }
  }
  std::printf(
      "[ info ] fp32 vs fp64: max relative difference %.2e (core), %.2e (Beckmann tail)"
      " over %ld values\n",
      worst_core, worst_tail, compared);
}

TEST(KernelPrecision, Fp32FresnelMatchesFp64) {
  constexpr double kRelTol = 2e-6;
  double worst = 0.0;
  for (int step = 0; step <= 1000; ++step) {
    double c = ref::round_to_float(step / 1000.0);
    for (double f0 : {0.02, 0.04, 0.5, 0.95}) {
      double v32 = f32::fresnel_schlick(f0, c),
             v64 = f64::fresnel_schlick(ref::round_to_float(f0), c);
      worst = std::max(worst, ref::rel_err(v32, v64));
      EXPECT_LT(ref::rel_err(v32, v64), kRelTol) << "schlick f0 " << f0 << " cos " << c;
    }
    for (auto [eta, k] : {std::pair{0.143, 3.983}, std::pair{1.442, 1.603}, std::pair{1.657, 9.224},
                          std::pair{0.02, 8.0}, std::pair{2.4, 0.3}}) {
      double e = ref::round_to_float(eta), kk = ref::round_to_float(k);
      double v32 = f32::fresnel_conductor(e, kk, c), v64 = f64::fresnel_conductor(e, kk, c);
      worst = std::max(worst, ref::rel_err(v32, v64));
      EXPECT_LT(ref::rel_err(v32, v64), kRelTol)
          << "conductor " << eta << " + i " << k << " cos " << c;
    }
    for (double ior : {1.33, 1.5, 2.4, 1 / 1.5, 1 / 2.4}) {
      const Material glass = {
          kNdfGgx,  0.1, 0.1, kFresnelDielectric, ref::round_to_float(Vec3{ior, ior, ior}),
          {0, 0, 0}};
      double extra = critical_angle_tol(glass, c);
      if (extra < 0.0) continue;
      double v32 = f32::fresnel_dielectric(glass.a.x, c),
             v64 = f64::fresnel_dielectric(glass.a.x, c);
      EXPECT_LT(ref::rel_err(v32, v64), kRelTol + extra) << "dielectric " << ior << " cos " << c;
      if (extra == 0.0) worst = std::max(worst, ref::rel_err(v32, v64));
    }
  }
  std::printf("[ info ] fp32 vs fp64 Fresnel: max relative difference %.2e\n", worst);
}

// ---------------------------------------------------------------------------------------------
// 9. Extremes: roughness 1e-4 .. 1 (also mixed), cos theta down to 1e-7 (and beyond, to the
// smallest normal float), the mirror and the retro-reflection configuration at grazing angles,
// and directions at or below the horizon. Outputs must be finite and >= 0 in both precisions;
// below the horizon exactly 0.
constexpr Alphas kExtremeAlphas[] = {{1e-4, 1e-4}, {1e-3, 1e-3}, {1e-2, 1e-2}, {0.3, 0.3},
                                     {1.0, 1.0},   {1e-4, 1.0},  {1.0, 1e-4}};
constexpr double kExtremeCos[] = {1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 0.5, 1.0};
constexpr double kExtremeAzimuths[] = {0.0, kPi / 4, kPi / 2, kPi, 3.0};

bool finite_non_negative(Vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && v.x >= 0.0 &&
         v.y >= 0.0 && v.z >= 0.0;
}

// Every combination of the listed cosines and azimuths for wo, and for wi: the same set, plus the
// mirror direction of wo and wo itself (retro-reflection).
std::vector<std::pair<Vec3, Vec3>> extreme_pairs(const std::vector<double> &cosines) {
  std::vector<Vec3> dirs;
  for (double c : cosines) {
    for (double phi : kExtremeAzimuths) dirs.push_back(ref::round_to_float(ref::from_cos(c, phi)));
  }
  std::vector<std::pair<Vec3, Vec3>> pairs;
  for (Vec3 wo : dirs) {
    for (Vec3 wi : dirs) pairs.emplace_back(wi, wo);
    pairs.emplace_back(Vec3{-wo.x, -wo.y, wo.z}, wo);  // mirror: h = n exactly
    pairs.emplace_back(wo, wo);                        // retro-reflection: h = wo
  }
  return pairs;
}

// Beyond "finite and non-negative": at the extremes the values themselves are compared with the
// independent reference (reference.h: trigonometric NDF and Smith forms, complex-amplitude
// Fresnel, in double) wherever the value is well conditioned. Relative tolerance, for a build of
// unit roundoff eps:
//   64 eps kappa + [dielectric from the dense side] 16 eps / cos_t^2,
//   kappa = 1 + (4 / alpha_min) g / |wi + wo|,  g = 1 (GGX), max(1, sqrt(t^2)) (Beckmann).
// h = normalize(wi + wo) carries a direction error of ~2 eps / |wi + wo| (the sum cancels when wi
// and wo are grazing at opposite azimuths), which D turns into a relative error of its
// log-slope, <= 2 / alpha for GGX and 2 sqrt(t^2) / alpha for Beckmann (t^2 its exponent; the
// exponential's condition); G2 and Fresnel are O(1)-conditioned (the kernels' z Lambda forms
// avoid Lambda's 1 / cos growth), 64 covers the roundings. Near the dielectric's critical
// angle F has slope ~1 / cos_t^2 (see critical_angle_tol, there in fp32 terms: 1e-6 ~ 16 eps).
// Plus the reference's own error, 64 eps_64 (kappa + 1 / cos_i + 1 / cos_o) (its angles lose
// eps_64 / cos relative in the cosines). Compared only where that tolerance is below 1e-2 ("well
// conditioned": at least two digits guaranteed), and in fp32 only for cosines >= 1e-7 (DESIGN.md's
// range; below it, products of two cosines leave fp32's normal range). Beyond the Beckmann cut-off
// (t^2 > 80) the kernels return exactly 0 by design; asserted.
constexpr double kEps64 = 0x1.0p-53, kEps32 = 0x1.0p-24;  // unit roundoffs

struct ExtremeStats {
  long compared = 0, skipped = 0;
  double worst = 0;  // largest error / tolerance
};

template <class ReflectCos>
ExtremeStats check_extremes(const char *precision, ReflectCos reflect_cos,
                            const std::vector<double> &cosines, double eps) {
  const auto pairs = extreme_pairs(cosines);
  const bool fp32 = eps > 1e-10;
  ExtremeStats st;
  for (int ndf : kNdfs) {
    for (const Alphas a : kExtremeAlphas) {
      for (const Material &m : materials(ndf, a)) {
        for (const auto &[wi, wo] : pairs) {
          Vec3 v = reflect_cos(m, wi, wo);
          EXPECT_TRUE(finite_non_negative(v))
              << precision << " " << m << " wi " << wi << " wo " << wo << " -> " << v;
          // The value against the independent reference, where well conditioned.
          const Vec3 sum = ref::add(wi, wo);
          const Vec3 h = ref::normalized(sum);
          const double t2 = ref::beckmann_exponent(ref::theta_of(h), ref::phi_of(h), a.x, a.y);
          if (ndf == kNdfBeckmann && t2 > 80.0 * (1 + 1e-3)) {
            EXPECT_TRUE(v.x == 0.0 && v.y == 0.0 && v.z == 0.0)
                << precision << " beyond the Beckmann cut-off: " << m << " wi " << wi << " wo "
                << wo << " -> " << v;
            continue;
          }
          const double g = ndf == kNdfBeckmann ? std::max(1.0, std::sqrt(t2)) : 1.0;
          const double kappa = 1 + 4 / std::min(a.x, a.y) * g / ref::norm(sum);
          const double cos_oh = ref::dot(wo, h);
          double crit = 0.0;
          if (m.fresnel == kFresnelDielectric && m.a.x < 1.0) {
            const double cos_t2 = 1.0 - (1.0 - cos_oh * cos_oh) / (m.a.x * m.a.x);
            crit = cos_t2 > 0.0 ? 16 * eps / cos_t2 : 0.0;
          }
          // The reference's own error: the same kappa in double, and its trigonometric form
          // (cos(theta) from theta = atan2(...)) has an absolute error ~eps_64 in each cosine,
          // i.e. relative eps_64 / cos at grazing angles.
          const double tol = 64 * eps * kappa + crit + 64 * kEps64 * (kappa + 1 / wi.z + 1 / wo.z);
          const bool in_range = !fp32 || (wi.z >= 1e-7 && wo.z >= 1e-7);
          const bool near_cutoff = ndf == kNdfBeckmann && std::fabs(t2 - 80.0) < 0.1;
          if (!(tol < 1e-2) || !in_range || near_cutoff) {
            ++st.skipped;
            continue;
          }
          // Float-rounded unit vectors are off unit length by ~eps_32, which the kernels (z as
          // given) and the reference (angles) read differently; fp64 therefore compares at the
          // exactly normalised (double) directions. fp32's own inputs are floats.
          const Vec3 ni = fp32 ? wi : ref::normalized(wi), no = fp32 ? wo : ref::normalized(wo);
          const Vec3 got = fp32 ? v : reflect_cos(m, ni, no);
          const Vec3 want = ref::brdf_cos(m, ni, no);
          for (auto [p, q] :
               {std::pair{got.x, want.x}, std::pair{got.y, want.y}, std::pair{got.z, want.z}}) {
            const double err = ref::rel_err(p, q);
            st.worst = std::max(st.worst, err / tol);
            ++st.compared;
            EXPECT_LT(err, tol) << precision << " " << m << " wi " << wi << " wo " << wo
                                << " kernel " << p << " reference " << q << " kappa " << kappa;
          }
        }
      }
    }
  }
  std::printf(
      "[ info ] %s extremes: %ld values against the reference (worst %.3f of the "
      "tolerance), %ld pairs not well conditioned\n",
      precision, st.compared, st.worst, st.skipped);
  return st;
}

TEST(KernelExtremes, FiniteNonNegativeAndAccurateFp64) {
  check_extremes("fp64", f64::reflect_cos, {std::begin(kExtremeCos), std::end(kExtremeCos)},
                 kEps64);
}

TEST(KernelExtremes, FiniteNonNegativeAndAccurateFp32) {
  check_extremes("fp32", f32::reflect_cos, {std::begin(kExtremeCos), std::end(kExtremeCos)},
                 kEps32);
}

// Beyond the 1e-7 of the design notes, down to float subnormals (a client may send any unit
// vector; validation only demands unit length). Before smith_visibility_cos_i, fp32 returned inf
// here once both cosines were below ~1e-35 at alpha 1e-4 (V overflowed before the cos_i factor).
TEST(KernelExtremes, FiniteNonNegativeAndAccurateAtTinyCosines) {
  const std::vector<double> tiny = {1e-12, 1e-20, 1e-30, 1e-36, 1.2e-38, 1e-40, 1.4e-45, 1.0};
  check_extremes("fp64", f64::reflect_cos, tiny, kEps64);
  check_extremes("fp32", f32::reflect_cos, tiny, kEps32);
}

// The pieces at the extremes too: D, z Lambda and V are finite and >= 0, and fp32 matches fp64 on
// identical (float) inputs within 64 eps_32 times their condition: D relative to its value with
// condition 1 for GGX (a power of a sum of positive terms) and 1 + t^2 for Beckmann (exp(-t^2)),
// skipped within 0.1% of the cut-off t^2 = 80 where one build may flush to 0; z Lambda on the
// scale z + z Lambda on which it enters G2 (the kernels' forms are built to be accurate there),
// condition 1; V = G2 / (4 cos_i cos_o) relative, condition 1.
TEST(KernelExtremes, PiecesFiniteNonNegativeAndAgreeBetweenPrecisions) {
  const auto pairs = extreme_pairs({std::begin(kExtremeCos), std::end(kExtremeCos)});
  double worst[3] = {0, 0, 0};
  for (int ndf : kNdfs) {
    for (const Alphas a0 : kExtremeAlphas) {
      const Alphas a = {ref::round_to_float(a0.x), ref::round_to_float(a0.y)};
      for (const auto &[wi, wo] : pairs) {
        Vec3 h = ref::round_to_float(ref::normalized(ref::add(wi, wo)));
        const double d32 = f32::ndf_D(ndf, h, a.x, a.y), d64 = f64::ndf_D(ndf, h, a.x, a.y);
        const double zl32 = f32::z_lambda(ndf, wo, a.x, a.y),
                     zl64 = f64::z_lambda(ndf, wo, a.x, a.y);
        const double v32 = f32::visibility(ndf, wo, wi, a.x, a.y),
                     v64 = f64::visibility(ndf, wo, wi, a.x, a.y);
        for (auto [name, v] :
             {std::pair{"D32", d32}, std::pair{"D64", d64}, std::pair{"zL32", zl32},
              std::pair{"zL64", zl64}, std::pair{"V32", v32}, std::pair{"V64", v64}}) {
          EXPECT_TRUE(std::isfinite(v) && v >= 0.0)
              << name << " " << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y << ") wi " << wi
              << " wo " << wo << " -> " << v;
        }
        const double t2 = ref::beckmann_exponent(ref::theta_of(h), ref::phi_of(h), a.x, a.y);
        const double err[3] = {ref::rel_err(d32, d64), std::fabs(zl32 - zl64) / (wo.z + zl64),
                               ref::rel_err(v32, v64)};
        const double kappa[3] = {ndf == kNdfBeckmann ? 1 + t2 : 1.0, 1.0, 1.0};
        for (int k = 0; k < 3; ++k) {
          if (k == 0 && ndf == kNdfBeckmann && t2 > 80.0 * (1 - 1e-3)) continue;
          worst[k] = std::max(worst[k], err[k] / kappa[k] / kEps32);
          EXPECT_LT(err[k], 64 * kEps32 * kappa[k]) << (k == 0   ? "D"
                                                        : k == 1 ? "z Lambda"
                                                                 : "V")
                                                    << " " << ndf_name(ndf) << " alpha (" << a.x
                                                    << ", " << a.y << ") wi " << wi << " wo " << wo;
        }
      }
    }
  }
  std::printf(
      "[ info ] pieces fp32 vs fp64 at the extremes, worst error / (eps_32 condition): "
      "D %.1f, z Lambda %.1f, V %.1f\n",
      worst[0], worst[1], worst[2]);
}

// At the exact mirror configuration (h = n, computed exactly in both precisions) the peak value
// must also agree between the builds, even at alpha = 1e-4 and grazing angles where it is huge.
TEST(KernelExtremes, MirrorPeakAgreesBetweenPrecisions) {
  constexpr double kRelTol = 1e-5;
  for (int ndf : kNdfs) {
    for (const Alphas a : kExtremeAlphas) {
      for (const Material &m : materials(ndf, a)) {
        for (double c : kExtremeCos) {
          for (double phi : kExtremeAzimuths) {
            Vec3 wo = ref::round_to_float(ref::from_cos(c, phi));
            Vec3 wi = {-wo.x, -wo.y, wo.z};
            Vec3 v32 = f32::reflect_cos(m, wi, wo), v64 = f64::reflect_cos(m, wi, wo);
            EXPECT_LT(ref::rel_err(v32.x, v64.x), kRelTol)
                << m << " wo " << wo << " fp32 " << v32.x << " fp64 " << v64.x;
            EXPECT_GT(v64.x, 0.0) << m << " wo " << wo;
          }
        }
      }
    }
  }
}

// Below or on the horizon: exactly 0, in both precisions.
TEST(KernelExtremes, ExactlyZeroAtOrBelowTheHorizon) {
  const std::vector<Vec3> below = {{1.0, 0.0, 0.0},
                                   {0.0, 1.0, -0.0},
                                   {0.6, 0.0, -0.8},
                                   {0.0, 0.0, -1.0},
                                   ref::round_to_float(ref::from_cos(-1e-7, 1.0)),
                                   ref::round_to_float(ref::from_cos(-0.3, 2.0))};
  const std::vector<Vec3> above = {{0.0, 0.0, 1.0},
                                   ref::round_to_float(ref::from_cos(1e-7, 0.5)),
                                   ref::round_to_float(ref::from_cos(0.5, 4.0))};
  for (int ndf : kNdfs) {
    for (const Alphas a : kExtremeAlphas) {
      for (const Material &m : materials(ndf, a)) {
        auto expect_zero = [&](Vec3 wi, Vec3 wo) {
          for (Vec3 v : {f32::reflect_cos(m, wi, wo), f64::reflect_cos(m, wi, wo)}) {
            EXPECT_TRUE(v.x == 0.0 && v.y == 0.0 && v.z == 0.0)
                << m << " wi " << wi << " wo " << wo << " -> " << v;
          }
        };
        for (Vec3 b : below) {
          for (Vec3 u : above) {
            expect_zero(b, u);
            expect_zero(u, b);
          }
          for (Vec3 b2 : below) expect_zero(b, b2);
        }
      }
    }
  }
}

}  // namespace
}  // namespace glint_test
