/* Entry of the NORMAL_MAP model (Yan et al. 2014; models/normal_map/normal_map_eval.h).
 * One query per work-item (GLINT_LANES == 1): the quadtree traversal branches per
 * query. The map's table (Model::request_table) arrives as model_table. */
#include "kernels/kernel_args.h"
#include "kernels/work_item.h"
#include "models/normal_map/normal_map_eval.h"

__kernel void glint_normal_map(GLINT_KERNEL_ARGS) {
  uint i = glint_work_item();
  if (i >= n) return;
  kernel_store(out, i, normal_map_query(kernel_spec(), GLINT_KERNEL_INPUTS(), i), accumulate);
}
