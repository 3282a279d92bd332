// The work-group size of a kernel launch on whatever device glintd runs on. DeviceEngineOptions::
// local_size (128) is what PoCL's CPU device was measured with; a GPU or another device may
// accept less: CL_DEVICE_MAX_WORK_GROUP_SIZE and CL_DEVICE_MAX_WORK_ITEM_SIZES[0] bound every
// kernel, CL_KERNEL_WORK_GROUP_SIZE each kernel after its build (registers, private memory), and
// a launch above any of them fails (CL_INVALID_WORK_GROUP_SIZE, or CL_OUT_OF_RESOURCES). The
// engine launches every kernel with the largest size not above its configured one that those
// limits allow (LocalSizeFor), padding the global size to a multiple of it (GridFor), and shrinks
// it further where an enqueue still fails (EnqueueShrinkingGroups).
//
// Results do not depend on the size: every work-item evaluates its own queries from its global
// index alone (kernels/work_item.h); no kernel uses local memory, barriers or local / group ids
// (grep kernels/ models/ for __local, barrier, get_local_id, get_group_id: none), and padding
// work-items past the batch return at their bounds check.
#pragma once

#include <CL/cl.h>

#include <algorithm>
#include <cstddef>

#include "server/launch_grid.h"

namespace glint {

// Limits on a kernel's work-group size; 0 = none known.
struct WorkGroupLimits {
  size_t kernel = 0;  // CL_KERNEL_WORK_GROUP_SIZE of the built kernel on the device
  size_t device = 0;  // min(CL_DEVICE_MAX_WORK_GROUP_SIZE, CL_DEVICE_MAX_WORK_ITEM_SIZES[0])
  size_t cap = 0;     // DeviceEngineOptions::max_local_size (tests impose a small device's limit)
};

// The work-group size of a pass: `configured` work-items (DeviceEngineOptions::local_size)
// divided by the pass's blocks per work-item (BINOMIAL's lights pass keeps the queries per group,
// server/model.h lights_blocks_fp32; 1 for every other pass), at least 1, then lowered to the
// smallest limit. The division comes first: a limit of 16 with 128 / 4 = 32 gives 16, not 4.
inline size_t LocalSizeFor(size_t configured, size_t blocks, const WorkGroupLimits &limits) {
  size_t local = std::max<size_t>(1, configured / std::max<size_t>(1, blocks));
  for (size_t limit : {limits.kernel, limits.device, limits.cap})
    if (limit > 0) local = std::min(local, limit);
  return local;
}

// Whether an enqueue that failed with `err` may succeed with smaller work-groups: the device's
// own verdict on the size (CL_INVALID_WORK_GROUP_SIZE, CL_INVALID_WORK_ITEM_SIZE) or on the
// resources a group of that size needs (CL_OUT_OF_RESOURCES: some drivers report registers or
// private memory only there, not in CL_KERNEL_WORK_GROUP_SIZE).
inline bool SmallerGroupsMayHelp(cl_int err) {
  return err == CL_INVALID_WORK_GROUP_SIZE || err == CL_INVALID_WORK_ITEM_SIZE ||
         err == CL_OUT_OF_RESOURCES;
}

// Enqueues `work_items` work-items (enqueue(const LaunchGrid &) -> cl_int) in groups of *local,
// halving *local after each failure SmallerGroupsMayHelp names, down to 1. Returns the last
// enqueue's error; *local is the size it used (the size to keep for the kernel on success). A
// failed enqueue runs nothing, so a retry cannot change the output.
template <class Enqueue>
cl_int EnqueueShrinkingGroups(size_t work_items, size_t *local, Enqueue &&enqueue) {
  for (;;) {
    const cl_int err = enqueue(GridFor(work_items, *local));
    if (err == CL_SUCCESS || *local <= 1 || !SmallerGroupsMayHelp(err)) return err;
    *local /= 2;
  }
}

}  // namespace glint
