/* Entry of the Kemppinen glint model for BRDF probes, directional and point
 * lights (models/kemppinen/kemppinen_eval.h). Each work-item evaluates
 * GLINT_LANES (16) queries as the lanes of OpenCL vectors, as the smooth model
 * does (kernels/simd_io.h says why); the cell loops have uniform trip counts
 * and per-query conditions are selects. Polygon lights run in the second pass
 * (models/kemppinen/kemppinen_area.cl). */
#include "kernels/kernel_args.h"
#include "kernels/simd_io.h"
#include "models/kemppinen/kemppinen_eval.h"

/* Component k of a per-query array with `stride` floats per query, for the
 * block's lanes; lanes past n repeat query n - 1 (finite work, never stored). */
GLINT_FN real kemppinen_block_gather(__global const float *a, uint stride, uint k, uint base,
                                     uint n) {
#if GLINT_LANES > 1
  float t[GLINT_LANES];
  for (uint j = 0; j < GLINT_LANES; ++j) t[j] = a[stride * min(base + j, n - 1u) + k];
  return GLINT_FLOATS_TO_REAL(GLINT_VLOADN(0, t));
#else
  return (real)a[stride * base + k];
#endif
}

__kernel void glint_kemppinen(GLINT_KERNEL_ARGS) {
  uint base = (uint)get_global_id(0) * GLINT_LANES;
  /* Padding work-items; uniform for all lanes of a work-item, not divergent. */
  if (base >= n) return;
  EvalSpec spec = kernel_spec();
  KernelInputs in = GLINT_KERNEL_INPUTS();

  QueryInputs q = block_load_queries(spec, in, base);
  real u = kemppinen_block_gather(uv, 2u, 0u, base, n);
  real v = kemppinen_block_gather(uv, 2u, 1u, base, n);
  real foot[4];
  for (uint k = 0; k < 4u; ++k) foot[k] = kemppinen_block_gather(footprint, 4u, k, base, n);
  real3 L = kemppinen_shade(spec, in, q, u, v, foot);
  /* Only when an earlier pass wrote `out`; this pass runs first. */
  if (accumulate) L = r3_add(block_load3(out, base, n), L);
  block_store3(out, base, n, L);
}
