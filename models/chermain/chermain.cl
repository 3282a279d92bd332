/* Entry of the Chermain et al. 2020 glint model (models/chermain/chermain_eval.h).
 * One query per work-item (GLINT_LANES == 1): the footprint's cell loops
 * branch per query. Light kinds the request lacks are compiled out
 * (GLINT_HAS_DIRECTIONAL, GLINT_HAS_POINT). */
#include "kernels/kernel_args.h"
#include "kernels/work_item.h"
#include "models/chermain/chermain_eval.h"

__kernel void glint_chermain(GLINT_KERNEL_ARGS) {
  uint i = glint_work_item();
  if (i >= n) return;
  kernel_store(out, i, chermain_query(kernel_spec(), GLINT_KERNEL_INPUTS(), i), accumulate);
}
