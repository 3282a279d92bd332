/* Entry of the binomial glint model (models/binomial/binomial_eval.h) for
 * directional, point and polygon lights by LTC: each work-item evaluates
 * GLINT_LANES (16, binomial_model.cpp) queries as the lanes of OpenCL vectors,
 * the footprint grids, the LTC clips and the count draws per lane with selects (binomial_count.h
 * says what diverges). Polygon lights by the other area methods run one query
 * per work-item (binomial.cl). Light kinds the request lacks are compiled out
 * (GLINT_HAS_DIRECTIONAL, GLINT_HAS_POINT).
 * Why 16 lanes and not 8 (until session 15): one zmm instruction does the work of two ymm ones,
 * and the kernel's dependent chains (cell-key hashes, the LTC clip, the draw) are shared by
 * twice as many queries; the longer exact searches of a 16-lane work-item (it pays its longest
 * lane) cost less than that at every N_P measured (models/binomial/README.md "Quad throughput
 * (session 15)"). The result per query is the same bit for bit: every lane runs the scalar
 * arithmetic whatever the width. */
#include "kernels/kernel_args.h"
#include "kernels/simd_io.h"
#include "kernels/work_item.h"
#include "models/binomial/binomial_eval.h"

/* Component k of the `stride` floats per query of array a, for the queries [base, base +
 * GLINT_LANES), in lanes; lanes past n repeat query n - 1 (as block_load3). */
GLINT_FN real binomial_lanes_load(const __global float *a, uint stride, uint k, uint base, uint n) {
  float t[GLINT_LANES];
  for (uint j = 0; j < GLINT_LANES; ++j) t[j] = a[stride * (size_t)min(base + j, n - 1) + k];
  return GLINT_FLOATS_TO_REAL(GLINT_VLOADN(0, t));
}

__kernel void glint_binomial_lanes(GLINT_KERNEL_ARGS) {
  uint base = glint_work_item() * GLINT_LANES;
  /* Padding work-items; uniform for all lanes of a work-item, not divergent. */
  if (base >= n) return;
  EvalSpec spec = kernel_spec();
  KernelInputs in = GLINT_KERNEL_INPUTS();
  real fp[4]; /* du/dx, dv/dx, du/dy, dv/dy */
  real u, v;
#if GLINT_LANES == 8
  if (base + GLINT_LANES <= n) {
    /* A full block: the same floats by vector loads and shuffles instead of 48 scalar loads
     * (block_load3 does the same for the 3-vectors). */
    const __global float *f = footprint + 4 * (size_t)base;
    float8 f0 = vload8(0, f), f1 = vload8(1, f), f2 = vload8(2, f), f3 = vload8(3, f);
    fp[0] = GLINT_FLOATS_TO_REAL((float8)(f0.s04, f1.s04, f2.s04, f3.s04));
    fp[1] = GLINT_FLOATS_TO_REAL((float8)(f0.s15, f1.s15, f2.s15, f3.s15));
    fp[2] = GLINT_FLOATS_TO_REAL((float8)(f0.s26, f1.s26, f2.s26, f3.s26));
    fp[3] = GLINT_FLOATS_TO_REAL((float8)(f0.s37, f1.s37, f2.s37, f3.s37));
    const __global float *t = uv + 2 * (size_t)base;
    float8 t0 = vload8(0, t), t1 = vload8(1, t);
    u = GLINT_FLOATS_TO_REAL((float8)(t0.even, t1.even));
    v = GLINT_FLOATS_TO_REAL((float8)(t0.odd, t1.odd));
  } else
#elif GLINT_LANES == 16
  if (base + GLINT_LANES <= n) {
    /* The same for 16 lanes: 4 + 2 vload16 and shuffles instead of 96 scalar loads. */
    const __global float *f = footprint + 4 * (size_t)base;
    float16 f0 = vload16(0, f), f1 = vload16(1, f), f2 = vload16(2, f), f3 = vload16(3, f);
    fp[0] = GLINT_FLOATS_TO_REAL((float16)(f0.s048c, f1.s048c, f2.s048c, f3.s048c));
    fp[1] = GLINT_FLOATS_TO_REAL((float16)(f0.s159d, f1.s159d, f2.s159d, f3.s159d));
    fp[2] = GLINT_FLOATS_TO_REAL((float16)(f0.s26ae, f1.s26ae, f2.s26ae, f3.s26ae));
    fp[3] = GLINT_FLOATS_TO_REAL((float16)(f0.s37bf, f1.s37bf, f2.s37bf, f3.s37bf));
    const __global float *t = uv + 2 * (size_t)base;
    float16 t0 = vload16(0, t), t1 = vload16(1, t);
    u = GLINT_FLOATS_TO_REAL((float16)(t0.even, t1.even));
    v = GLINT_FLOATS_TO_REAL((float16)(t0.odd, t1.odd));
  } else
#endif
  {
    for (uint k = 0; k < 4; ++k) fp[k] = binomial_lanes_load(footprint, 4, k, base, n);
    u = binomial_lanes_load(uv, 2, 0, base, n);
    v = binomial_lanes_load(uv, 2, 1, base, n);
  }
  real3 L = binomial_shade(spec, in, block_load_queries(spec, in, base), u, v, fp, 0u);
  /* Only when an earlier pass wrote `out`; the binomial model has one pass per request. */
  if (accumulate) L = r3_add(block_load3(out, base, n), L);
  block_store3(out, base, n, L);
}
