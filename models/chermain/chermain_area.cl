/* Entry of the Chermain glint model for polygon lights
 * (models/chermain/chermain_polygons.h), one query per work-item. Adds to the
 * first pass (models/chermain/chermain.cl). */
#include "kernels/kernel_args.h"
#include "kernels/work_item.h"
#include "models/chermain/chermain_polygons.h"

__kernel void glint_chermain_area(GLINT_KERNEL_ARGS) {
  uint i = glint_work_item();
  if (i >= n) return;
  kernel_store(out, i, chermain_polygons_query(kernel_spec(), GLINT_KERNEL_INPUTS(), i),
               accumulate);
}
