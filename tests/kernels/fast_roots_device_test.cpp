// glint_sqrt_nn and glint_rsqrt_nn (kernels/compat.h) as a GLINT_FAST_ROOTS kernel compiles them:
// on a 16-lane fp32 AVX-512 device, the 14-bit reciprocal square root estimate and one Newton
// step, against long double. On another device they are PoCL's correctly rounded sqrt and
// 1 / sqrt: the bound is checked too, and the test then says it was skipped (nothing fast ran).
//
// The bound, from the method (not from a measurement): the estimate r0 = (1 + e) / sqrt(x) has
// |e| <= 2^-14 (Intel SDM, VRSQRT14PS); one Newton step r0 (3/2 - x r0^2 / 2) leaves a relative
// error (3/2) e^2 + e^3 / 2 <= 1.5 2^-28 + 2^-43. The rounding of its four operations adds at most
// 4 2^-24 for the square root (x r rounds once into the result and once through r s, weighted
// 1 and 1/2, r s and 3/2 - r s / 2 weighted 1/2 and 1, the last product 1), 3 2^-24 for the
// reciprocal; second-order terms stay below 2^-40.
// glint_recip_nn (1 / x for x in [2^-126, 2^126]): the estimate r0 = (1 + e) / x, |e| < 2^-14
// (VRCP14PS), one Newton step r0 (2 - x r0) = (1 - e^2) / x, and three roundings (x r0, 2 - x r0
// near 1, the product), each at most 2^-24 relative: e^2 + 3 2^-24, second order below 2^-36.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "server/cl_handle.h"
#include "server/cl_runtime.h"
#include "server/kernel_source.h"
#include "tests/support/device_int_flag.h"
#include "tests/support/device_lane_kernel.h"

namespace glint {
namespace {

constexpr double kNewtonBound = 1.5 * 0x1p-28 + 0x1p-43;
constexpr double kSqrtBound = kNewtonBound + 4 * 0x1p-24 + 0x1p-40;
constexpr double kRsqrtBound = kNewtonBound + 3 * 0x1p-24 + 0x1p-40;
constexpr double kRecipBound = 0x1p-28 + 3 * 0x1p-24 + 0x1p-36;

const char *kKernel = R"(
__kernel void fast_roots_active(__global int *active) { active[0] = GLINT_FAST_ROOTS_ACTIVE; }
__kernel void fast_roots(__global const float *x, __global float *s, __global float *r,
                         __global float *q) {
  size_t i = get_global_id(0);
  real v = vload16(i, x);
  vstore16(glint_sqrt_nn(v), i, s);
  vstore16(glint_rsqrt_nn(v), i, r);
  vstore16(glint_recip_nn(v), i, q);
}
)";

TEST(FastRootsDevice, WithinTheNewtonStepsBoundOfLongDouble) {
  std::unique_ptr<ClRuntime> rt;
  cl_program program = nullptr;
  ASSERT_TRUE(test::BuildFastRootsLaneProgram("kernels/compat.h", kKernel, &rt, &program));

  // Every binade of the positive floats (subnormals included) at random mantissas, the ends of
  // the range, 1 and its neighbours, and the square roots' own 0.
  std::vector<float> x = {0.0f,
                          1.0f,
                          std::nextafter(1.0f, 2.0f),
                          std::nextafter(1.0f, 0.0f),
                          std::numeric_limits<float>::denorm_min(),
                          std::numeric_limits<float>::min(),
                          std::numeric_limits<float>::max()};
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> mantissa(1.0f, 2.0f);
  for (int e = -149; e <= 127; ++e)
    for (int k = 0; k < 64; ++k) x.push_back(std::ldexp(mantissa(rng), e));
  while (x.size() % 16) x.push_back(1.0f);

  cl_int err = CL_SUCCESS;
  ClQueue queue(clCreateCommandQueue(rt->context(), rt->device(), 0, &err));
  ASSERT_EQ(err, CL_SUCCESS);
  std::vector<float> s, r, q;
  ASSERT_TRUE(
      test::RunFloatLaneKernel(*rt, program, queue.get(), "fast_roots", 16, x, {&s, &r, &q}));

  EXPECT_EQ(s[0], 0.0f) << "sqrt(0) must be exactly 0, not 0 * inf";
  double worst_s = 0, worst_r = 0, worst_q = 0;
  int exact_s = 0, checked_q = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const long double xi = x[i];
    if (xi == 0) continue;
    const long double root = std::sqrt(xi);
    const double es = double(std::fabs((long double)s[i] - root) / root);
    const double er = double(std::fabs((long double)r[i] * root - 1.0L));
    worst_s = std::max(worst_s, es);
    worst_r = std::max(worst_r, er);
    exact_s += s[i] == std::sqrt(x[i]);
    EXPECT_LE(es, kSqrtBound) << "sqrt(" << x[i] << ") = " << s[i];
    EXPECT_LE(er, kRsqrtBound) << "rsqrt(" << x[i] << ") = " << r[i];
    if (xi >= 0x1p-126L && xi <= 0x1p126L) {  // glint_recip_nn's domain: 1 / x normal
      const double eq = double(std::fabs((long double)q[i] * xi - 1.0L));
      worst_q = std::max(worst_q, eq);
      ++checked_q;
      EXPECT_LE(eq, kRecipBound) << "1 / " << x[i] << " = " << q[i];
    }
  }
  EXPECT_GT(checked_q, 252 * 64);  // every binade of the domain
  int active = -1;
  ASSERT_TRUE(test::ReadDeviceIntFlag(*rt, program, queue.get(), "fast_roots_active", &active));
  std::printf(
      "device %s: worst relative error sqrt %.3g (bound %.3g), rsqrt %.3g (bound %.3g), "
      "reciprocal %.3g (bound %.3g); %d of %zu square roots correctly rounded\n",
      rt->info().name.c_str(), worst_s, kSqrtBound, worst_r, kRsqrtBound, worst_q, kRecipBound,
      exact_s, x.size() - 1);
  if (active != 1)
    GTEST_SKIP() << "the device compiled sqrt and 1 / sqrt (no AVX-512 or not 16 lanes): "
                    "the estimate path was not tested";
}

}  // namespace
}  // namespace glint
