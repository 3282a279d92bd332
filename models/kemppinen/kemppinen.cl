/* Entry of the Kemppinen glint model (models/kemppinen/kemppinen_eval.h). One
 * query per work-item (GLINT_LANES == 1): the loops over grid cells and the
 * polygon clipping branch per query (an 8-lane version is future work). Light
 * kinds the request lacks are compiled out (GLINT_HAS_DIRECTIONAL,
 * GLINT_HAS_POINT). */
#include "kernels/kernel_args.h"
#include "models/kemppinen/kemppinen_eval.h"

__kernel void glint_kemppinen(GLINT_KERNEL_ARGS) {
  uint i = (uint)get_global_id(0);
  if (i >= n) return;
  kernel_store(out, i, kemppinen_query(kernel_spec(), GLINT_KERNEL_INPUTS(), i), accumulate);
}
