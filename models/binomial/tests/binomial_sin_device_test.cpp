// The device's fp32 `sin` on the arcsine count's range (binomial_arcsine_theta, models/binomial/
// binomial_count.h: n sin^2(phi), phi clamped to [0, pi/2]), checked on the device for every fp32
// phi in [0, pi/2] (1.07e9 inputs, a few seconds), as the 16-lane lane kernels call it:
//  - it never falls from one fp32 input to the next. The count must never fall as p grows, and
//    the arcsine count is non-decreasing in p only if its sine is; session 17 found a polynomial
//    sine that fell by an ulp at 287 inputs (models/binomial/README.md "Quad throughput (session
//    17)"), and whether the device's own `sin` is monotone there had not been checked;
//  - against long double sin on a sample, within the 4 ulp that OpenCL 1.2 requires of `sin`;
//  - theta = asin(sqrt(p)), the angle the sine is taken of, never falls either, for every fp32 p
//    in [0, 1] (review, session 18: the argument needs both).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#include "server/cl_handle.h"
#include "server/cl_runtime.h"
#include "tests/support/device_lane_kernel.h"

namespace glint {
namespace {

// the clamp's upper end, 0.5f * GLINT_PI in fp32: 1.57079637 (bits 0x3fc90fdb)
constexpr uint32_t kLastBits = 0x3fc90fdbu;
constexpr uint32_t kChunk = 4096;

const char *kKernel = R"(
/* each lane checks the 4096 consecutive fp32 inputs from its start's bits (and the one before) */
__kernel void sin_falls(__global const float *start, __global float *falls) {
  size_t i = get_global_id(0);
  uint16 b = as_uint16(vload16(i, start));
  float16 prev = sin(as_float16(b - select((uint16)0, (uint16)1, b > (uint16)0)));
  int16 nf = (int16)0;
  for (uint j = 0; j < 4096u; ++j) {
    float16 s = sin(as_float16(min(b + (uint16)j, (uint16)0x3fc90fdbu)));
    nf -= !(s >= prev); /* a NaN counts as a fall */
    prev = s;
  }
  vstore16(convert_float16(nf), i, falls);
}
/* the same for theta = asin(sqrt(p)) over p in [0, 1] (binomial_prob_theta) */
__kernel void asin_sqrt_falls(__global const float *start, __global float *falls) {
  size_t i = get_global_id(0);
  uint16 b = as_uint16(vload16(i, start));
  float16 prev = asin(sqrt(as_float16(b - select((uint16)0, (uint16)1, b > (uint16)0))));
  int16 nf = (int16)0;
  for (uint j = 0; j < 4096u; ++j) {
    float16 s = asin(sqrt(as_float16(min(b + (uint16)j, (uint16)0x3f800000u))));
    nf -= !(s >= prev);
    prev = s;
  }
  vstore16(convert_float16(nf), i, falls);
}
__kernel void sin_values(__global const float *x, __global float *y) {
  size_t i = get_global_id(0);
  vstore16(sin(vload16(i, x)), i, y);
}
)";

TEST(BinomialSinDevice, NonDecreasingOnEveryFp32InZeroToHalfPi) {
  std::unique_ptr<ClRuntime> rt;
  cl_program program = nullptr;
  ASSERT_TRUE(
      test::BuildFastRootsLaneProgram("models/binomial/binomial_count.h", kKernel, &rt, &program));
  cl_int err = CL_SUCCESS;
  ClQueue queue(clCreateCommandQueue(rt->context(), rt->device(), 0, &err));
  ASSERT_EQ(err, CL_SUCCESS);

  // Every fp32 input from +0 to `last_bits` (kernel `name`: each lane checks 4096 from its start)
  // and the falls the kernel counted in all of them.
  auto falls_up_to = [&](const char *name, uint32_t last_bits, double *n_falls) {
    std::vector<float> starts;
    for (uint64_t b = 0; b <= last_bits; b += kChunk) {
      float f;
      const uint32_t bits = uint32_t(b);
      std::memcpy(&f, &bits, sizeof f);
      starts.push_back(f);
    }
    while (starts.size() % 16) starts.push_back(starts.back());
    std::vector<float> falls;
    ::testing::AssertionResult ran =
        test::RunFloatLaneKernel(*rt, program, queue.get(), name, 16, starts, {&falls});
    *n_falls = 0;
    for (float f : falls) *n_falls += f;
    return ran;
  };
  double n_falls = 0;
  ASSERT_TRUE(falls_up_to("sin_falls", kLastBits, &n_falls));
  std::printf("%.0f fp32 inputs in [0, pi/2]: sin falls at %.0f\n", double(kLastBits) + 1, n_falls);
  EXPECT_EQ(n_falls, 0);

  // theta = asin(sqrt(p)), the arcsine count's angle (binomial_prob_theta, and asin(sqrt(p2))
  // above the upper switch): the count is non-decreasing in p only if theta is, whatever the
  // lane kernels' square root (GLINT_FAST_ROOTS) is. Every fp32 p in [0, 1].
  constexpr uint32_t kOneBits = 0x3f800000u;
  double n_theta_falls = 0;
  ASSERT_TRUE(falls_up_to("asin_sqrt_falls", kOneBits, &n_theta_falls));
  std::printf("%.0f fp32 p in [0, 1]: asin(sqrt(p)) falls at %.0f\n", double(kOneBits) + 1,
              n_theta_falls);
  EXPECT_EQ(n_theta_falls, 0);

  // accuracy on a sample: uniform in [0, pi/2] and log-uniform towards 0
  std::vector<float> x;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> lin(0.0, 1.5707963);
  std::uniform_real_distribution<double> lg(std::log(1e-30), std::log(1.57));
  for (int i = 0; i < 200000; ++i) {
    x.push_back(float(lin(rng)));
    x.push_back(float(std::exp(lg(rng))));
  }
  x.push_back(0.0f);
  while (x.size() % 16) x.push_back(1.5707964f);
  std::vector<float> y;
  ASSERT_TRUE(test::RunFloatLaneKernel(*rt, program, queue.get(), "sin_values", 16, x, {&y}));
  double worst_ulps = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const long double ref = std::sin((long double)x[i]);
    if (ref == 0) {
      ASSERT_EQ(y[i], 0.0f);
      continue;
    }
    const double ulp = std::fabs(double(std::nextafter(float(ref), 2.0f) - float(ref)));
    const double e = std::fabs(double((long double)y[i] - ref));
    ASSERT_LE(e, 4 * ulp) << "sin(" << x[i] << ") = " << y[i];
    worst_ulps = std::max(worst_ulps, e / ulp);
  }
  std::printf("sample of %zu: worst %.2f ulp\n", x.size(), worst_ulps);
}

}  // namespace
}  // namespace glint
