/* Entry of the binomial glint model (models/binomial/binomial_eval.h) for
 * requests with polygon lights by an area method other than LTC (REFERENCE,
 * MONTE_CARLO, LECOCQ, AUTO), whose integrators branch per query: one query
 * per work-item (GLINT_LANES == 1). Everything else runs 16 queries per
 * work-item in binomial_lanes.cl. Light kinds the request lacks are compiled
 * out (GLINT_HAS_DIRECTIONAL, GLINT_HAS_POINT). */
#include "kernels/kernel_args.h"
#include "kernels/work_item.h"
#include "models/binomial/binomial_eval.h"

__kernel void glint_binomial(GLINT_KERNEL_ARGS) {
  uint i = glint_work_item();
  if (i >= n) return;
  kernel_store(out, i, binomial_query(kernel_spec(), GLINT_KERNEL_INPUTS(), i), accumulate);
}
