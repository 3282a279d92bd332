// kernels/ndf.h ggx_D_visibility_cos_i (GGX D(h) times the height-correlated Smith V times cos_i,
// in one division: the product smooth_reflect_cos evaluates per query) against an independent
// long-double evaluation of the textbook factors: D in Heitz 2014's slope form (Eq. 85), Lambda
// from Eq. 86 and G2 = 1 / (1 + Lambda_o + Lambda_i) (Eq. 99), V cos_i = G2 / (4 cos_o).
// Swept over alpha 1e-4..1 (isotropic and anisotropic both ways) and cosines 1..1e-7 (the
// documented range's grazing end), in fp64 and fp32, pointwise to a rounding-error bound.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "kernel_api.h"
#include "reference.h"

namespace glint_test {
namespace {

using LD = long double;

// Heitz 2014 Eq. 86: Lambda(w) = (-1 + sqrt(1 + 1 / a^2)) / 2 with 1 / a = alpha_o tan theta,
// alpha_o^2 tan^2 theta = (ax^2 wx^2 + ay^2 wy^2) / wz^2 (Eq. 80 in components).
LD LambdaGgx(Vec3 w, LD ax, LD ay) {
  const LD wx = w.x, wy = w.y, wz = w.z;
  const LD inv_a2 = (ax * ax * wx * wx + ay * ay * wy * wy) / (wz * wz);
  return (-1 + std::sqrt(1 + inv_a2)) / 2;
}

// D(h) V cos_i in long double. D from the slopes (x~, y~) = (-hx / hz, -hy / hz) (Heitz 2014
// Eq. 85): D = 1 / (pi ax ay hz^4 (1 + x~^2 / ax^2 + y~^2 / ay^2)^2); homogeneous of degree -4 in
// h like the kernel's form, so both agree on the same (not exactly unit) double h. Lambda's
// -1 + sqrt(1 + x) cancels for small x, but only in Lambda's low bits: 1 + Lambda_o + Lambda_i
// keeps its long-double accuracy.
LD Reference(Vec3 h, Vec3 wo, Vec3 wi, LD ax, LD ay) {
  const LD hz = h.z, sx = -LD(h.x) / hz, sy = -LD(h.y) / hz;
  const LD e = 1 + sx * sx / (ax * ax) + sy * sy / (ay * ay);
  const LD D = 1 / (std::numbers::pi_v<LD> * ax * ay * hz * hz * hz * hz * e * e);
  const LD g2 = 1 / (1 + LambdaGgx(wo, ax, ay) + LambdaGgx(wi, ax, ay));  // Eq. 99
  const LD v = g2 / (4 * LD(wo.z) * LD(wi.z));
  return D * v * LD(wi.z);
}

// The rounding-error bound of the kernel's evaluation, to first order in the unit roundoff u
// (2^-53 fp64, 2^-24 fp32; every operation within u relative, sqrt halves its argument's error).
// sx = hx (1 / ax): 2u, sx^2: 5u, q = sx^2 + sy^2 + hz^2 (positive terms): 7u. xo = ax wo.x: u,
// xo^2: 3u, xo^2 + yo^2: 4u, + zo^2: 5u, r_o = sqrt: 3.5u; r_o zi and zo r_i: 4.5u, their sum
// 5.5u. denom = 2 pi ax ay q q (r_o zi + zo r_i): pi's representation u, five rounded products
// 5u, q twice 14u, the sum 5.5u: 25.5u. zi / denom: 26.5u. The reference's own error (~30 long
// double roundings, 2^-64 each) is below 0.02u of fp64. Hence 27u. The inputs are
// float-representable (both builds see the same values); the reference takes the same vectors.
constexpr double kUlps = 27.0;

struct Alpha {
  double x, y;
};
constexpr Alpha kAlphas[] = {{1e-4, 1e-4}, {1e-3, 1e-3}, {0.01, 0.01}, {0.2, 0.2}, {1.0, 1.0},
                             {1e-4, 1.0},  {1.0, 1e-4},  {0.05, 0.3},  {0.3, 0.05}};
// cos theta from the normal to 1e-7 above the horizon (reference.h from_cos: exact cosines).
constexpr double kCos[] = {1.0, 0.999, 0.7, 0.3, 0.05, 1e-3, 1e-5, 1e-7};
// wo's azimuth, and wi's relative to it: the same side (h near wo), opposite (h near the
// normal for equal cosines), and in between, off the alpha axes.
constexpr double kPhiO[] = {0.0, 0.4, 1.9};
constexpr double kDeltaPhi[] = {0.0, 1.1, std::numbers::pi, 4.0};

template <class F>
void Sweep(F &&check) {
  for (const Alpha a : kAlphas)
    for (double co : kCos)
      for (double ci : kCos)
        for (double po : kPhiO)
          for (double dp : kDeltaPhi) {
            const Vec3 wo = ref::round_to_float(ref::from_cos(co, po));
            const Vec3 wi = ref::round_to_float(ref::from_cos(ci, po + dp));
            const Vec3 h = ref::round_to_float(ref::normalized(ref::add(wo, wi)));
            check(a, wo, wi, h);
          }
}

void ExpectWithinUlps(double got, LD want, double u, const char *what, Alpha a, Vec3 wo, Vec3 wi,
                      Vec3 h) {
  ASSERT_GT(want, 0) << "the sweep stays above the horizon";
  const double rel = double(std::fabs(LD(got) - want) / want);
  EXPECT_LE(rel, kUlps * u) << what << " alpha (" << a.x << ", " << a.y << ") wo " << wo << " wi "
                            << wi << " h " << h << ": got " << got << ", reference " << double(want)
                            << ", " << rel / u << " u";
}

// A value the reference must give exactly: alpha 1, wo = wi = h = n: D = 1 / pi, Lambda = 0,
// G2 = 1, V cos_i = 1 / 4, so 1 / (4 pi). Guards the reference itself against a slip.
TEST(KernelGgxDvCosI, ReferenceGivesTheClosedFormAtNormalIncidence) {
  const Vec3 n = {0, 0, 1};
  EXPECT_NEAR(double(Reference(n, n, n, 1, 1)), 1 / (4 * std::numbers::pi), 1e-18);
  EXPECT_NEAR(f64::ggx_dv_cos_i(n, n, n, 1, 1), 1 / (4 * std::numbers::pi), 1e-16);
}

TEST(KernelGgxDvCosI, Fp64MatchesLongDoubleWithinRoundingBound) {
  Sweep([](Alpha a, Vec3 wo, Vec3 wi, Vec3 h) {
    ExpectWithinUlps(f64::ggx_dv_cos_i(h, wo, wi, a.x, a.y), Reference(h, wo, wi, a.x, a.y),
                     0x1p-53, "fp64", a, wo, wi, h);
  });
}

// The same bound in fp32 (u = 2^-24): the comment in ndf.h keeps every intermediate inside
// fp32's normal range over this sweep, so no underflow adds to it. The alphas are rounded to
// float as the wrapper rounds them, so the reference sees the kernel's inputs.
TEST(KernelGgxDvCosI, Fp32MatchesLongDoubleWithinRoundingBound) {
  Sweep([](Alpha a, Vec3 wo, Vec3 wi, Vec3 h) {
    const Alpha af = {ref::round_to_float(a.x), ref::round_to_float(a.y)};
    ExpectWithinUlps(f32::ggx_dv_cos_i(h, wo, wi, af.x, af.y), Reference(h, wo, wi, af.x, af.y),
                     0x1p-24, "fp32", af, wo, wi, h);
  });
}

}  // namespace
}  // namespace glint_test
