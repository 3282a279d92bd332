/* Entry of the smooth model for BRDF probes, directional and point lights
 * (models/smooth/smooth_eval.h). Each work-item evaluates GLINT_BLOCKS blocks
 * (2 for fp32 probes, else 1) of GLINT_LANES (16) queries as the lanes of
 * OpenCL vectors (kernels/simd_io.h says why); the
 * ceil(n / (GLINT_BLOCKS GLINT_LANES)) work-items, padded, run as a 2D grid
 * (kernels/work_item.h). Inputs stay float in buffers; `real` is the
 * arithmetic. */
/* Square roots by AVX-512's estimate + one Newton step where the device has it
 * (kernels/compat.h glint_sqrt_nn): this kernel is bound by its divider. */
#define GLINT_FAST_ROOTS 1
/* and a * b + c fused where the compiler finds it (kernels/compat.h). */
#define GLINT_CONTRACT_FMA 1
/* Uniform light set-up (a directional light's normalisation; without a frame a point light's
 * direction and I / d^2) once per block in scalars, the same IEEE operations, so the same bits
 * (kernels/punctual_lights.h): 16-lane vdivps/vsqrtps of broadcast values otherwise. */
#define GLINT_SCALAR_LIGHTS 1
#include "kernels/kernel_args.h"
#include "kernels/simd_io.h"
#include "kernels/work_item.h"
#include "models/smooth/smooth_eval.h"

/* Blocks of GLINT_LANES queries per work-item (server/model.h ModelPass::probe_blocks_fp32): 2
 * for fp32 probes, 1 otherwise. */
#ifndef GLINT_BLOCKS
#define GLINT_BLOCKS 1
#endif
/* The launch gives each work-item GLINT_BLOCKS blocks: an entry that evaluated fewer would leave
 * queries unwritten, so any other count is a build error, not a silent gap. */
#if GLINT_BLOCKS != 1 && !(GLINT_BLOCKS == 2 && GLINT_PROBE)
#error "glint_smooth evaluates 2 blocks per work-item for probes only (GLINT_BLOCKS)"
#endif

__kernel void glint_smooth(GLINT_KERNEL_ARGS) {
#if GLINT_PROBE
  uint base = glint_work_item() * (GLINT_BLOCKS * GLINT_LANES);
  /* Padding work-items; uniform for all lanes of a work-item, not divergent. */
  if (base >= n) return;
  EvalSpec spec = kernel_spec();
  KernelInputs in = GLINT_KERNEL_INPUTS();
  /* Probes take the material by value (kernels/kernel_args.h `material_values`): PoCL then
   * computes what depends on it alone once per work-group instead of once per block. The same
   * floats and operations as from the buffer, so the same bits. */
  SmoothMaterial m = smooth_material_from_values(material_values, spec.ndf, spec.fresnel);
  QueryInputs q = block_load_queries(spec, in, base);
#if GLINT_BLOCKS == 2
  /* The second block: independent of the first, so the core overlaps the two blocks' long
   * dependency chains (the Fresnel's dependent roots and division). Past the end of the batch
   * its loads repeat query n - 1 (block_load3) and its store is skipped. Each query's
   * operations are the ones of a one-block work-item: the same bits. */
  uint base1 = base + GLINT_LANES;
  QueryInputs q1 = block_load_queries(spec, in, base1);
#endif
  real3 L = smooth_shade_material(spec, in, m, q);
#if GLINT_BLOCKS == 2
  real3 L1 = smooth_shade_material(spec, in, m, q1);
#endif
  /* Only when an earlier pass wrote `out`; the smooth model runs this pass first. */
  if (accumulate) L = r3_add(block_load3(out, base, n), L);
  block_store3(out, base, n, L);
#if GLINT_BLOCKS == 2
  if (base1 < n) {
    if (accumulate) L1 = r3_add(block_load3(out, base1, n), L1);
    block_store3(out, base1, n, L1);
  }
#endif
#else
  /* Directional and point lights: one block per work-item, the material from the buffer
   * (by value not measured here; other models' ratios are relative to this kernel). */
  uint base = glint_work_item() * GLINT_LANES;
  /* Padding work-items; uniform for all lanes of a work-item, not divergent. */
  if (base >= n) return;
  EvalSpec spec = kernel_spec();
  KernelInputs in = GLINT_KERNEL_INPUTS();

  QueryInputs q = block_load_queries(spec, in, base);
  real3 L = smooth_shade(spec, in, q);
  /* Only when an earlier pass wrote `out`; the smooth model runs this pass first. */
  if (accumulate) L = r3_add(block_load3(out, base, n), L);
  block_store3(out, base, n, L);
#endif
}
