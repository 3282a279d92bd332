// kemppinen_log2_pos (models/kemppinen/kemppinen_ndf.h) as the point pass's device entry compiles
// it (GLINT_FAST_ROOTS, fused multiply-adds, 16 lanes, fp32): there the series' argument
// t = (m - 1) / (m + 1) is (m - 1) times glint_recip_nn(m + 1) instead of a division. Checked
// against long double log2 (an independent reference) with the bound derived from the method:
//  - the host form's bound (FastLog2.WithinItsBoundOfLongDouble, kemppinen_test.cpp): the atanh
//    series' truncation and the fp32 roundings, 2.5 u + 1e-9 (u = 2^-24), plus half an ulp of
//    the result;
//  - t's extra relative error: glint_recip_nn's 3 u + 2^-28 (kernels/compat.h; m + 1 in
//    [1.7, 2.5] is inside its domain) and the product's rounding u, where the division had u:
//    3 u + 2^-28 more; it reaches the result through t p(t^2), whose relative sensitivity to t
//    is t (p + 2 t^2 p') <= 0.52 for |t| <= 0.1716 (m in [sqrt(1/2), sqrt 2)): <= 1.6 u.
// Total 4.1 u + 1e-9 + half an ulp. On a device where the fast path is not compiled it is the
// division (the host form), the bound then holds a fortiori and the test says it skipped.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
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

const char *kKernel = R"(
__kernel void log2_active(__global int *active) { active[0] = GLINT_FAST_ROOTS_ACTIVE; }
__kernel void log2_fast(__global const float *x, __global float *y) {
  size_t i = get_global_id(0);
  vstore16(kemppinen_log2_pos(vload16(i, x)), i, y);
}
)";

TEST(FastLog2Device, WithinItsBoundOfLongDouble) {
  std::unique_ptr<ClRuntime> rt;
  cl_program program = nullptr;
  ASSERT_TRUE(
      test::BuildFastRootsLaneProgram("models/kemppinen/kemppinen_ndf.h", kKernel, &rt, &program));

  // The inputs of the host test: log-uniform over [1e-30, 1e30] (the footprint's range), the
  // binade edges at 1 and sqrt 2 (where m and the exponent switch) with their neighbours, and a
  // dense grid over [0.5, 3].
  std::vector<float> x;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> lx(std::log(1e-30), std::log(1e30));
  for (int i = 0; i < 200000; ++i) x.push_back(float(std::exp(lx(rng))));
  for (int e = -99; e <= 99; ++e)
    for (double base : {1.0, std::sqrt(2.0)}) {
      const float v = float(std::ldexp(base, e));
      x.push_back(v);
      x.push_back(std::nextafter(v, 0.0f));
      x.push_back(std::nextafter(v, 1e38f));
    }
  for (int i = 0; i <= 100000; ++i) x.push_back(float(0.5 + 2.5 * i / 100000.0));
  while (x.size() % 16) x.push_back(1.0f);

  cl_int err = CL_SUCCESS;
  ClQueue queue(clCreateCommandQueue(rt->context(), rt->device(), 0, &err));
  ASSERT_EQ(err, CL_SUCCESS);
  std::vector<float> y;
  ASSERT_TRUE(test::RunFloatLaneKernel(*rt, program, queue.get(), "log2_fast", 16, x, {&y}));

  const double u = 0x1p-24;
  double worst = 0, worst_ulps = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const long double ref = std::log2((long double)x[i]);
    const double e = std::fabs(double((long double)y[i] - ref));
    const double half_ulp = 0.5 * std::fabs(double(std::nextafter(y[i], 1e38f) - y[i]));
    ASSERT_LE(e, 4.1 * u + 1e-9 + half_ulp) << "log2(" << x[i] << ") = " << y[i];
    worst = std::max(worst, e);
    worst_ulps = std::max(worst_ulps, e / (2 * half_ulp));
  }
  int active = -1;
  ASSERT_TRUE(test::ReadDeviceIntFlag(*rt, program, queue.get(), "log2_active", &active));
  std::printf("device %s: fast log2 over %zu inputs, max abs error %.3g (%.2f ulp)\n",
              rt->info().name.c_str(), x.size(), worst, worst_ulps);
  if (active != 1)
    GTEST_SKIP() << "the device compiled the division (no AVX-512 or not 16 lanes): the "
                    "reciprocal path was not tested";
}

}  // namespace
}  // namespace glint
