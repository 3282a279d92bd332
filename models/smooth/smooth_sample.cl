/* The smooth model's sample pass (models/smooth/smooth_sample.h): one sample
 * per work-item, sample k of query i at work-item i K + k. */
#include "kernels/work_item.h"
#include "models/smooth/smooth_sample.h"

__kernel void glint_smooth_sample(GLINT_SAMPLE_KERNEL_ARGS) {
  uint s = glint_work_item();
  if (s >= n * samples_per_query) return;
  sample_store(out, s,
               smooth_sample(kernel_spec(), GLINT_KERNEL_INPUTS(), s / samples_per_query,
                             s % samples_per_query));
}
