/* Entry of the Kemppinen glint model for polygon lights
 * (models/kemppinen/kemppinen_polygons.h), one query per work-item: polygon
 * clipping and the area methods branch per query. Adds to the first pass. */
#include "kernels/kernel_args.h"
#include "kernels/work_item.h"
#include "models/kemppinen/kemppinen_polygons.h"

__kernel void glint_kemppinen_area(GLINT_KERNEL_ARGS) {
  uint i = glint_work_item();
  if (i >= n) return;
  kernel_store(out, i, kemppinen_polygons_query(kernel_spec(), GLINT_KERNEL_INPUTS(), i),
               accumulate);
}
