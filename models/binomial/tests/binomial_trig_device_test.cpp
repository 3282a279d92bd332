// The arcsine count's fp32 sine and arcsine (models/binomial/binomial_trig.h:
// binomial_sin_quadrant, binomial_asin_sqrt) on the device, built as the binomial lane kernels
// build them (16 lanes, no GLINT_FAST_ROOTS, FP_CONTRACT off), on every fp32 input of their ranges,
// and as the one-query kernel binomial.cl builds them (GLINT_LANES=1: the same IEEE operations,
// each piece behind a scalar branch instead of a lane-mask test):
//  - neither ever falls from one fp32 input to the next. The count must never fall as p grows
//    (models/binomial/binomial_count.h, binomial_arcsine_theta), which needs both. Session 17
//    found a polynomial sine that fell by an ulp at 287 inputs (models/binomial/README.md "Quad
//    throughput (session 17)"); session 18 checked PoCL's `sin` and `asin(sqrt(p))` here, which
//    session 19 replaced by these;
//  - the device gives the host's bits (BinomialTrig in binomial_test.cpp checks the host on every
//    input, and the accuracy against long double) on a sample of 2^20 inputs each, subnormal
//    ones included.
#include <gtest/gtest.h>

#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#include "server/cl_handle.h"
#include "server/cl_runtime.h"
#include "server/kernel_source.h"
#include "tests/support/device_lane_kernel.h"

namespace host32 {
#include "models/binomial/binomial_trig.h"
}  // namespace host32

namespace glint {
namespace {

// the clamp's upper end in binomial_arcsine_theta, 0.5f * GLINT_PI in fp32: 1.57079637 (0x3fc90fdb)
constexpr uint32_t kLastBits = 0x3fc90fdbu;
constexpr uint32_t kOneBits = 0x3f800000u;
constexpr uint32_t kChunk = 4096;

const char *kKernel = R"(
/* each lane checks the 4096 consecutive fp32 inputs from its start's bits (and the one before),
 * up to `last` */
__kernel void sin_falls(__global const float *start, __global float *falls) {
  size_t i = get_global_id(0);
  uint16 b = as_uint16(vload16(i, start));
  float16 prev = binomial_sin_quadrant(as_float16(b - select((uint16)0, (uint16)1, b > (uint16)0)));
  int16 nf = (int16)0;
  for (uint j = 0; j < 4096u; ++j) {
    float16 s = binomial_sin_quadrant(as_float16(min(b + (uint16)j, (uint16)0x3fc90fdbu)));
    nf -= !(s >= prev); /* a NaN counts as a fall */
    prev = s;
  }
  vstore16(convert_float16(nf), i, falls);
}
__kernel void asin_sqrt_falls(__global const float *start, __global float *falls) {
  size_t i = get_global_id(0);
  uint16 b = as_uint16(vload16(i, start));
  float16 prev = binomial_asin_sqrt(as_float16(b - select((uint16)0, (uint16)1, b > (uint16)0)));
  int16 nf = (int16)0;
  for (uint j = 0; j < 4096u; ++j) {
    float16 s = binomial_asin_sqrt(as_float16(min(b + (uint16)j, (uint16)0x3f800000u)));
    nf -= !(s >= prev);
    prev = s;
  }
  vstore16(convert_float16(nf), i, falls);
}
__kernel void values(__global const float *x, __global float *sine, __global float *theta) {
  size_t i = get_global_id(0);
  float16 v = vload16(i, x);
  vstore16(binomial_sin_quadrant(v), i, sine);
  vstore16(binomial_asin_sqrt(fmin(v, 1.0f)), i, theta);
}
)";

// The same checks at one lane (binomial.cl's GLINT_LANES=1 build): one work-item per start.
const char *kKernel1 = R"(
__kernel void sin_falls(__global const float *start, __global float *falls) {
  size_t i = get_global_id(0);
  uint b = as_uint(start[i]);
  float prev = binomial_sin_quadrant(as_float(b - (b > 0u ? 1u : 0u)));
  int nf = 0;
  for (uint j = 0; j < 4096u; ++j) {
    float s = binomial_sin_quadrant(as_float(min(b + j, 0x3fc90fdbu)));
    nf += !(s >= prev); /* a scalar comparison is 0 or 1; a NaN counts as a fall */
    prev = s;
  }
  falls[i] = (float)nf;
}
__kernel void asin_sqrt_falls(__global const float *start, __global float *falls) {
  size_t i = get_global_id(0);
  uint b = as_uint(start[i]);
  float prev = binomial_asin_sqrt(as_float(b - (b > 0u ? 1u : 0u)));
  int nf = 0;
  for (uint j = 0; j < 4096u; ++j) {
    float s = binomial_asin_sqrt(as_float(min(b + j, 0x3f800000u)));
    nf += !(s >= prev);
    prev = s;
  }
  falls[i] = (float)nf;
}
__kernel void values(__global const float *x, __global float *sine, __global float *theta) {
  size_t i = get_global_id(0);
  sine[i] = binomial_sin_quadrant(x[i]);
  theta[i] = binomial_asin_sqrt(fmin(x[i], 1.0f));
}
)";

float FloatOfBits(uint32_t b) {
  float f;
  std::memcpy(&f, &b, sizeof f);
  return f;
}

TEST(BinomialTrigDevice, NeverFallsOnAnyFp32InputAndGivesTheHostsBits) {
  std::unique_ptr<ClRuntime> rt;
  cl_program program = nullptr, program1 = nullptr;
  // as binomial_lanes.cl is built (server/eval_plan.cpp's options; no fast roots, no contraction)
  ASSERT_TRUE(
      test::BuildLaneProgram("", "models/binomial/binomial_trig.h", kKernel, &rt, &program));
  // and as binomial.cl's one-query entry: the same options at one lane (FP_CONTRACT is off there
  // whatever the frame, kernels/compat.h)
  const Status built1 = rt->GetProgram(
      ExpandKernelSource("models/binomial/binomial_trig.h") + kKernel1,
      "-DGLINT_LANES=1 -DGLINT_USE_DOUBLE=0 -DGLINT_HAS_FRAME=0 -cl-single-precision-constant",
      &program1);
  ASSERT_TRUE(built1.ok()) << built1.message();
  cl_int err = CL_SUCCESS;
  ClQueue queue(clCreateCommandQueue(rt->context(), rt->device(), 0, &err));
  ASSERT_EQ(err, CL_SUCCESS);

  // the host's bits: uniform bits up to pi/2 (half of them below 2^-30, subnormals included) and
  // uniform values, the sine of each and the arcsine of min(x, 1)
  std::vector<float> x;
  std::mt19937 rng(19);
  std::uniform_int_distribution<uint32_t> bits(0, kLastBits);
  std::uniform_real_distribution<float> lin(0.0f, FloatOfBits(kLastBits));
  for (int i = 0; i < (1 << 19); ++i) {
    x.push_back(FloatOfBits(bits(rng)));
    x.push_back(lin(rng));
  }
  for (float e : {0.0f, 0.25f, 0.75f, 1.0f, FloatOfBits(kLastBits)})
    for (int d = -8; d <= 8; ++d) {
      uint32_t b;
      std::memcpy(&b, &e, sizeof b);
      if (b + d <= kLastBits) x.push_back(FloatOfBits(b + d));
    }
  while (x.size() % 16) x.push_back(0.5f);

  for (const size_t lanes : {size_t{16}, size_t{1}}) {
    SCOPED_TRACE(lanes);
    cl_program prog = lanes == 16 ? program : program1;
    // Every fp32 input from +0 to `last_bits` (kernel `name`: each work-item's lane checks 4096
    // from its start) and the falls the kernel counted in all of them.
    auto falls_up_to = [&](const char *name, uint32_t last_bits, double *n_falls) {
      std::vector<float> starts;
      for (uint64_t b = 0; b <= last_bits; b += kChunk) starts.push_back(FloatOfBits(uint32_t(b)));
      while (starts.size() % lanes) starts.push_back(starts.back());
      std::vector<float> falls;
      ::testing::AssertionResult ran =
          test::RunFloatLaneKernel(*rt, prog, queue.get(), name, lanes, starts, {&falls});
      *n_falls = 0;
      for (float f : falls) *n_falls += f;
      return ran;
    };
    double n_falls = 0;
    ASSERT_TRUE(falls_up_to("sin_falls", kLastBits, &n_falls));
    std::printf("%zu lane(s), %.0f fp32 x in [0, pi/2]: binomial_sin_quadrant falls at %.0f\n",
                lanes, double(kLastBits) + 1, n_falls);
    EXPECT_EQ(n_falls, 0);
    double n_theta_falls = 0;
    ASSERT_TRUE(falls_up_to("asin_sqrt_falls", kOneBits, &n_theta_falls));
    std::printf("%zu lane(s), %.0f fp32 p in [0, 1]: binomial_asin_sqrt falls at %.0f\n", lanes,
                double(kOneBits) + 1, n_theta_falls);
    EXPECT_EQ(n_theta_falls, 0);

    std::vector<float> sine, theta;
    ASSERT_TRUE(
        test::RunFloatLaneKernel(*rt, prog, queue.get(), "values", lanes, x, {&sine, &theta}));
    long differ = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      const float hs = host32::binomial_sin_quadrant(x[i]);
      const float ht = host32::binomial_asin_sqrt(std::fmin(x[i], 1.0f));
      if ((std::memcmp(&hs, &sine[i], 4) != 0 || std::memcmp(&ht, &theta[i], 4) != 0) &&
          ++differ <= 5)
        ADD_FAILURE() << "x = " << x[i] << ": sine " << sine[i] << " on the device, " << hs
                      << " on the host; asin(sqrt) " << theta[i] << ", " << ht;
    }
    std::printf("%zu lane(s), %zu inputs: the device's bits differ from the host's in %ld\n", lanes,
                x.size(), differ);
    EXPECT_EQ(differ, 0);
  }
}

}  // namespace
}  // namespace glint
