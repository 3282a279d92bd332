/* Entry of the Kemppinen glint model for BRDF probes, directional and point
 * lights (models/kemppinen/kemppinen_eval.h). Each work-item evaluates
 * GLINT_LANES (16) queries as the lanes of OpenCL vectors, as the smooth model
 * does (kernels/simd_io.h says why); the cell loops have uniform trip counts
 * and per-query conditions are selects. Polygon lights run in the second pass
 * (models/kemppinen/kemppinen_area.cl). */
/* Square roots by AVX-512's estimate + one Newton step where the device has it, as the smooth
 * model's entry does (kernels/compat.h glint_sqrt_nn / glint_rsqrt_nn): the smooth BRDF part,
 * the lights and the point pass's map T, footprint and level set-up
 * (models/kemppinen/kemppinen_ndf.h kemppinen_root) queue ~30 divisions and square roots per
 * 16-query block on the divider otherwise. The polygon and sampling entries keep libm's. */
#define GLINT_FAST_ROOTS 1
/* Uniform light set-up in scalars, the same bits (kernels/punctual_lights.h). */
#define GLINT_SCALAR_LIGHTS 1
/* a * b + c fused where the compiler finds it, as the smooth entry does (kernels/compat.h). */
#define GLINT_CONTRACT_FMA 1
#include "kernels/kernel_args.h"
#include "kernels/simd_io.h"
#include "kernels/work_item.h"
#include "models/kemppinen/kemppinen_eval.h"

#if GLINT_LANES != 16
#error "models/kemppinen/kemppinen.cl loads blocks of 16 queries (kemppinen_model.cpp)"
#endif

/* The block's uv (2 floats per query) and footprints (4 per query), one
 * vector per component: contiguous vector loads and shuffles, as
 * kernels/simd_io.h does for xyz triples (the per-lane gathers they replace
 * were 5-9% of the kernel). In the last, partial block the lanes past n
 * repeat query n - 1 (finite work, never stored). */
GLINT_FN void kemppinen_block_load_uv(__global const float *uv, __global const float *footprint,
                                      uint base, uint n, GLINT_PRIVATE real *u,
                                      GLINT_PRIVATE real *v, GLINT_PRIVATE real *foot) {
  float16 a0, a1, f0, f1, f2, f3;
  if (base + 16u <= n) {
    a0 = vload16(0, uv + 2 * (size_t)base);
    a1 = vload16(1, uv + 2 * (size_t)base);
    const __global float *f = footprint + 4 * (size_t)base;
    f0 = vload16(0, f);
    f1 = vload16(1, f);
    f2 = vload16(2, f);
    f3 = vload16(3, f);
  } else {
    float t[96];
    for (uint j = 0; j < 16u; ++j) {
      size_t i = (size_t)min(base + j, n - 1u);
      t[2 * j] = uv[2 * i];
      t[2 * j + 1] = uv[2 * i + 1];
      for (uint k = 0; k < 4u; ++k) t[32 + 4 * j + k] = footprint[4 * i + k];
    }
    a0 = vload16(0, t);
    a1 = vload16(1, t);
    f0 = vload16(2, t);
    f1 = vload16(3, t);
    f2 = vload16(4, t);
    f3 = vload16(5, t);
  }
  *u = GLINT_FLOATS_TO_REAL((float16)(a0.even, a1.even));
  *v = GLINT_FLOATS_TO_REAL((float16)(a0.odd, a1.odd));
  foot[0] = GLINT_FLOATS_TO_REAL((float16)(f0.s048c, f1.s048c, f2.s048c, f3.s048c));
  foot[1] = GLINT_FLOATS_TO_REAL((float16)(f0.s159d, f1.s159d, f2.s159d, f3.s159d));
  foot[2] = GLINT_FLOATS_TO_REAL((float16)(f0.s26ae, f1.s26ae, f2.s26ae, f3.s26ae));
  foot[3] = GLINT_FLOATS_TO_REAL((float16)(f0.s37bf, f1.s37bf, f2.s37bf, f3.s37bf));
}

__kernel void glint_kemppinen(GLINT_KERNEL_ARGS) {
  uint base = glint_work_item() * GLINT_LANES;
  /* Padding work-items; uniform for all lanes of a work-item, not divergent. */
  if (base >= n) return;
  EvalSpec spec = kernel_spec();
  KernelInputs in = GLINT_KERNEL_INPUTS();

  QueryInputs q = block_load_queries(spec, in, base);
  real u, v, foot[4];
  kemppinen_block_load_uv(uv, footprint, base, n, &u, &v, foot);
  real3 L = kemppinen_shade(spec, in, q, u, v, foot);
  /* Only when an earlier pass wrote `out`; this pass runs first. */
  if (accumulate) L = r3_add(block_load3(out, base, n), L);
  block_store3(out, base, n, L);
}
