/* The smooth model's sample pass (models/smooth/smooth_sample.h): one sample
 * per work-item, sample k of query i at work-item i K + k. */
#include "models/smooth/smooth_sample.h"

__kernel void glint_smooth_sample(GLINT_SAMPLE_KERNEL_ARGS) {
  uint s = (uint)get_global_id(0);
  if (s >= n * samples_per_query) return;
  sample_store(out, s,
               smooth_sample(kernel_spec(), GLINT_KERNEL_INPUTS(), s / samples_per_query,
                             s % samples_per_query));
}
