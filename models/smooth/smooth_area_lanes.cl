/* Entry of the smooth model for polygon lights by LTC, the default area
 * method (models/smooth/smooth_polygons.h, kernels/area/area_ltc.h): each
 * work-item evaluates GLINT_LANES (8) queries as the lanes of OpenCL vectors,
 * the clips branch-free with per-lane vertex counts. The other area methods
 * branch per query and run one query per work-item (smooth_area.cl). Runs
 * after glint_smooth when the request also has probes or other lights, and
 * then adds to its output. */
/* a * b + c fused where the compiler finds it (kernels/compat.h). */
#define GLINT_CONTRACT_FMA 1
#include "kernels/kernel_args.h"
#include "kernels/simd_io.h"
#include "kernels/work_item.h"
#include "models/smooth/smooth_polygons.h"

__kernel void glint_smooth_area_lanes(GLINT_KERNEL_ARGS) {
  uint base = glint_work_item() * GLINT_LANES;
  /* Padding work-items; uniform for all lanes of a work-item, not divergent. */
  if (base >= n) return;
  EvalSpec spec = kernel_spec();
  KernelInputs in = GLINT_KERNEL_INPUTS();
  real3 L = smooth_polygons_ltc(spec, in, block_load_queries(spec, in, base));
  if (accumulate) L = r3_add(block_load3(out, base, n), L);
  block_store3(out, base, n, L);
}
