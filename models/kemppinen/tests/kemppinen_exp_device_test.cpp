// kemppinen_exp_neg (models/kemppinen/kemppinen_exp.h) as the point pass's device entry compiles
// it (GLINT_FAST_ROOTS, fused multiply-adds, 16 lanes, fp32): the claim is the SAME BITS as the
// device library's exp(-x) on its domain x in [-86, 86] (it is PoCL's SLEEF xexpf written out with
// a one-step 2^q), checked bit for bit on the device over the domain; and, as an independent
// reference for both, within SLEEF's documented 1 ulp of long double exp. On a device where the
// fast path is not compiled it is the library exp itself (the test then says so and skips).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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
__kernel void exp_active(__global int *active) { active[0] = GLINT_KEMPPINEN_FAST_EXP; }
__kernel void exp_both(__global const float *x, __global float *fast, __global float *lib) {
  size_t i = get_global_id(0);
  real v = vload16(i, x);
  vstore16(kemppinen_exp_neg(v), i, fast);
  vstore16(exp(-v), i, lib);
}
)";

TEST(KemppinenExpDevice, SameBitsAsTheLibraryExpOnItsDomain) {
  std::unique_ptr<ClRuntime> rt;
  cl_program program = nullptr;
  ASSERT_TRUE(
      test::BuildFastRootsLaneProgram("models/kemppinen/kemppinen_exp.h", kKernel, &rt, &program));

  // The domain's ends and 0, a uniform grid of 2^20 + 1 points over [-86, 86], and 2^18 random
  // floats of every binade in (0, 86] with both signs (small arguments, where q = 0 and s is
  // the argument itself), plus the points where rint(x / ln 2) changes (q's steps: u near
  // 2^+-1/2).
  std::vector<float> x = {0.0f, -0.0f, 86.0f, -86.0f, 80.0f, 18.0f, -2.0f};
  for (int i = 0; i <= (1 << 20); ++i) x.push_back(float(-86.0 + 172.0 * i / (1 << 20)));
  std::mt19937 rng(16);
  std::uniform_real_distribution<float> mantissa(1.0f, 2.0f);
  for (int e = -126; e <= 6; ++e)
    for (int k = 0; k < 2000; ++k) {
      float v = std::ldexp(mantissa(rng), e);
      if (v <= 86.0f) x.push_back((k & 1) ? -v : v);
    }
  for (int q = -124; q <= 124; ++q) {
    const float edge = float((q + 0.5) * 0.69314718055994530942);
    float v = std::nextafter(std::nextafter(edge, -1e9f), -1e9f);
    for (int n = 0; n < 5; ++n, v = std::nextafter(v, 1e9f))
      if (std::fabs(v) <= 86.0f) x.push_back(v);
  }
  while (x.size() % 16) x.push_back(1.0f);

  cl_int err = CL_SUCCESS;
  ClQueue queue(clCreateCommandQueue(rt->context(), rt->device(), 0, &err));
  ASSERT_EQ(err, CL_SUCCESS);
  std::vector<float> fast, lib;
  ASSERT_TRUE(
      test::RunFloatLaneKernel(*rt, program, queue.get(), "exp_both", 16, x, {&fast, &lib}));

  size_t differ = 0;
  double worst_ulp = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    if (std::memcmp(&fast[i], &lib[i], sizeof(float)) != 0 && ++differ <= 10)
      ADD_FAILURE() << "exp(-" << x[i] << "): " << fast[i] << " vs the library's " << lib[i];
    // SLEEF's xexpf is documented within 1.0 ulp; the results here are normal floats.
    const long double ref = std::exp(-(long double)x[i]);
    const long double ulp =
        std::nextafter(float(ref), float(INFINITY)) - std::nextafter(float(ref), 0.0f);
    const double e = double(std::fabs((long double)fast[i] - ref) / (ulp / 2));
    worst_ulp = std::max(worst_ulp, e);
    EXPECT_LE(e, 1.0) << "exp(-" << x[i] << ") = " << fast[i];
  }
  EXPECT_EQ(differ, 0u) << "of " << x.size() << " arguments";

  int active = -1;
  ASSERT_TRUE(test::ReadDeviceIntFlag(*rt, program, queue.get(), "exp_active", &active));
  std::printf(
      "device %s: %zu arguments in [-86, 86], %zu differ from the library exp, worst %.3g "
      "ulp from long double\n",
      rt->info().name.c_str(), x.size(), differ, worst_ulp);
  if (active != 1)
    GTEST_SKIP() << "the device compiled the library exp (no AVX-512 or not 16 lanes): the "
                    "written-out path was not tested";
}

}  // namespace
}  // namespace glint
