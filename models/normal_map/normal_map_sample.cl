/* The NORMAL_MAP model's sample pass (models/normal_map/normal_map_sample.h): one sample per
 * work-item, sample k of query i at work-item i K + k. The map's table (Model::request_table)
 * arrives as model_table. */
#include "kernels/work_item.h"
#include "models/normal_map/normal_map_sample.h"

__kernel void glint_normal_map_sample(GLINT_SAMPLE_KERNEL_ARGS) {
  uint s = glint_work_item();
  if (s >= n * samples_per_query) return;
  sample_store(out, s,
               normal_map_sample(kernel_spec(), GLINT_KERNEL_INPUTS(), s / samples_per_query,
                                 s % samples_per_query));
}
