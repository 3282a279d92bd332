/* Entry of the NORMAL_MAP model for polygon lights (models/normal_map/normal_map_polygons.h),
 * one query per work-item. Adds to the first pass when that ran. */
#include "kernels/kernel_args.h"
#include "kernels/work_item.h"
#include "models/normal_map/normal_map_polygons.h"

__kernel void glint_normal_map_area(GLINT_KERNEL_ARGS) {
  uint i = glint_work_item();
  if (i >= n) return;
  kernel_store(out, i, normal_map_polygons_query(kernel_spec(), GLINT_KERNEL_INPUTS(), i),
               accumulate);
}
