// The LTC table lookup (kernels/area/ltc_lookup.h) in the device's lane path against the host's
// scalar path, bit for bit: the lanes compute each lane's cell, weights and bilinear blend with
// the scalar path's operations, then move the 8-float entries into one vector per component with
// shuffles (area_ltc_transpose8; 16 lanes: two transposes and a concatenation). The transpose is
// data movement only, so without fused multiply-adds (the kernel below compiles with
// FP_CONTRACT off, as the binomial lane kernels do) every component of every lane must equal the
// host's float lookup for the same (alpha, cos theta_o) exactly; a lane or component swapped by a
// wrong shuffle mask gives another cell's value and fails. The independent reference is the
// host's plain loop over the four corner entries (no lanes, no shuffles).
//
// The same for area_ltc_lookup_uniform_alpha (one alpha per block, given as a scalar: the alpha
// cell and weight computed once) against the host lookup at that alpha in every lane.
//
// Inputs: every lane of a block in a different cell (random alpha and cos theta_o over the grid,
// plus the clamps: alpha < 0, > 1, cos theta_o < 0, > 1, the last cell's edge), both tables
// (GGX, Beckmann), 8 and 16 lanes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "data/ltc/ltc_table.h"
#include "server/cl_handle.h"
#include "server/cl_runtime.h"
#include "server/kernel_source.h"

// Last: compat.h defines the macro GLINT_R(x), which must not meet any header parsed after it.
namespace ltc_lookup_host {
#define GLINT_USE_DOUBLE 0
#include "kernels/area/ltc_lookup.h"
}  // namespace ltc_lookup_host

namespace glint {
namespace {

// `uniform` 1: area_ltc_lookup_uniform_alpha with the block's first alpha for every lane (the
// smooth model's LTC pass: one material per request), else area_ltc_lookup with each lane's.
const char *kKernel = R"(
__kernel void lookup(__global const float *table, __global const float *alpha,
                     __global const float *cos_o, __global float *out, int uniform) {
  size_t i = get_global_id(0);
#if GLINT_LANES == 16
  real a = vload16(i, alpha), c = vload16(i, cos_o);
#else
  real a = vload8(i, alpha), c = vload8(i, cos_o);
#endif
  real e[GLINT_LTC_ENTRY];
  if (uniform)
    area_ltc_lookup_uniform_alpha(table, alpha[i * GLINT_LANES], c, e);
  else
    area_ltc_lookup(table, a, c, e);
  /* out[(i * 8 + k) * lanes + lane]: component k of every lane of block i. */
  for (int k = 0; k < GLINT_LTC_ENTRY; ++k) {
#if GLINT_LANES == 16
    vstore16(e[k], i * GLINT_LTC_ENTRY + k, out);
#else
    vstore8(e[k], i * GLINT_LTC_ENTRY + k, out);
#endif
  }
}
)";

void CheckLookup(int lanes, ltc_table::Ndf ndf, int uniform) {
  const char *cache = std::getenv("GLINT_CACHE_DIR");
  std::unique_ptr<ClRuntime> rt;
  ASSERT_TRUE(ClRuntime::Create("", cache ? cache : "", &rt).ok());
  cl_program program = nullptr;
  const Status built =
      rt->GetProgram(ExpandKernelSource("kernels/area/ltc_lookup.h") + kKernel,
                     "-DGLINT_LANES=" + std::to_string(lanes) +
                         " -DGLINT_USE_DOUBLE=0 -DGLINT_HAS_FRAME=0 -cl-single-precision-constant",
                     &program);
  ASSERT_TRUE(built.ok()) << built.message();

  std::vector<float> alpha, cos_o;
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 4096; ++i) {
    alpha.push_back(u(rng));
    cos_o.push_back(u(rng));
  }
  // The clamps and the grid's last cell (x or y = 63 uses cell 62 with weight 1).
  for (float a : {-0.5f, 0.0f, 1e-4f, 1.0f, 1.5f})
    for (float c : {-0.2f, 0.0f, 1e-3f, 0.5f, 1.0f, 1.2f}) {
      alpha.push_back(a);
      cos_o.push_back(c);
    }
  while (alpha.size() % size_t(lanes)) {
    alpha.push_back(u(rng));
    cos_o.push_back(u(rng));
  }
  const size_t n = alpha.size();
  const float *table = ltc_table::table(ndf);
  const size_t table_bytes =
      sizeof(float) * ltc_table::kSize * ltc_table::kSize * ltc_table::kEntryFloats;

  cl_int err = CL_SUCCESS;
  ClBuffer t_buf(clCreateBuffer(rt->context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, table_bytes,
                                const_cast<float *>(table), &err));
  ASSERT_EQ(err, CL_SUCCESS);
  ClBuffer a_buf(clCreateBuffer(rt->context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                                n * sizeof(float), alpha.data(), &err));
  ASSERT_EQ(err, CL_SUCCESS);
  ClBuffer c_buf(clCreateBuffer(rt->context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                                n * sizeof(float), cos_o.data(), &err));
  ASSERT_EQ(err, CL_SUCCESS);
  const size_t out_bytes = n * GLINT_LTC_ENTRY * sizeof(float);
  ClBuffer o_buf(clCreateBuffer(rt->context(), CL_MEM_WRITE_ONLY, out_bytes, nullptr, &err));
  ASSERT_EQ(err, CL_SUCCESS);
  ClKernel kernel(clCreateKernel(program, "lookup", &err));
  ASSERT_EQ(err, CL_SUCCESS);
  cl_mem args[4] = {t_buf.get(), a_buf.get(), c_buf.get(), o_buf.get()};
  for (cl_uint a = 0; a < 4; ++a)
    ASSERT_EQ(clSetKernelArg(kernel.get(), a, sizeof(cl_mem), &args[a]), CL_SUCCESS);
  ASSERT_EQ(clSetKernelArg(kernel.get(), 4, sizeof(int), &uniform), CL_SUCCESS);
  ClQueue queue(clCreateCommandQueue(rt->context(), rt->device(), 0, &err));
  ASSERT_EQ(err, CL_SUCCESS);
  const size_t global = n / size_t(lanes);
  ASSERT_EQ(clEnqueueNDRangeKernel(queue.get(), kernel.get(), 1, nullptr, &global, nullptr, 0,
                                   nullptr, nullptr),
            CL_SUCCESS);
  std::vector<float> out(n * GLINT_LTC_ENTRY);
  ASSERT_EQ(clEnqueueReadBuffer(queue.get(), o_buf.get(), CL_TRUE, 0, out_bytes, out.data(), 0,
                                nullptr, nullptr),
            CL_SUCCESS);

  int mismatches = 0;
  for (size_t i = 0; i < n; ++i) {
    float e[GLINT_LTC_ENTRY];
    const size_t block = i / size_t(lanes), lane = i % size_t(lanes);
    const float a = uniform ? alpha[block * size_t(lanes)] : alpha[i];
    ltc_lookup_host::area_ltc_lookup(table, a, cos_o[i], e);
    for (int k = 0; k < GLINT_LTC_ENTRY; ++k) {
      const float d = out[(block * GLINT_LTC_ENTRY + size_t(k)) * size_t(lanes) + lane];
      if (std::memcmp(&d, &e[k], sizeof d) != 0 && ++mismatches <= 10)
        ADD_FAILURE() << lanes << " lanes, uniform " << uniform << ", query " << i << " (alpha "
                      << a << ", cos " << cos_o[i] << "), component " << k << ": device " << d
                      << ", host " << e[k];
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(LtcLookupDevice, SixteenLanesGiveTheHostBits) {
  for (int uniform : {0, 1}) {
    CheckLookup(16, ltc_table::Ndf::kGgx, uniform);
    CheckLookup(16, ltc_table::Ndf::kBeckmann, uniform);
  }
}

TEST(LtcLookupDevice, EightLanesGiveTheHostBits) {
  for (int uniform : {0, 1}) {
    CheckLookup(8, ltc_table::Ndf::kGgx, uniform);
    CheckLookup(8, ltc_table::Ndf::kBeckmann, uniform);
  }
}

}  // namespace
}  // namespace glint
