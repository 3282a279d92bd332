/* Entry of the smooth model for polygon lights (models/smooth/smooth_polygons.h),
 * one query per work-item (GLINT_LANES == 1). Runs after glint_smooth when the
 * request also has probes or other lights, and then adds to its output. */
#include "kernels/kernel_args.h"
#include "kernels/work_item.h"
#include "models/smooth/smooth_polygons.h"

__kernel void glint_smooth_area(GLINT_KERNEL_ARGS) {
  uint i = glint_work_item();
  if (i >= n) return;
  kernel_store(out, i, smooth_polygons_query(kernel_spec(), GLINT_KERNEL_INPUTS(), i), accumulate);
}
