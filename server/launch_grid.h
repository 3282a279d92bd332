// The NDRange of a kernel launch: a 2D grid whose dimensions both stay below PoCL 3.1's
// small-grid limit, so every launch of a kernel runs the work-group function its first (one-
// query) launch compiled. kernels/work_item.h says why (PoCL compiles a second work-group
// function for grids with a dimension of 65535 work-items or more) and how a kernel turns the
// 2D id back into its linear index.
#pragma once

#include <cstddef>

namespace glint {

// PoCL 3.1 specialises a work-group function for grids whose widest dimension is below this
// (devices/common.c: grid_width_specialization_limit = USHRT_MAX; pocl_cache.c compares with <).
inline constexpr size_t kPoclSmallGridLimit = 65535;

struct LaunchGrid {
  size_t global[2] = {0, 1};
  size_t local[2] = {1, 1};
};

// `work_items` work-items (> 0) in work-groups of `local` (1 .. kPoclSmallGridLimit - 1): one row
// of ceil(work_items / local) groups while that stays below the limit, else rows of the widest
// multiple of `local` below it, as many as the work-items need (the last row padded). Rows stay
// below the limit up to (65534 / local * local) x 65534 work-items, about 4.3e9 for local 128;
// beyond that (no batch the service accepts) the launch is still correct, it only compiles PoCL's
// large-grid function once.
inline LaunchGrid GridFor(size_t work_items, size_t local) {
  LaunchGrid g;
  g.local[0] = local;
  const size_t groups = (work_items + local - 1) / local;
  const size_t max_width = (kPoclSmallGridLimit - 1) / local * local;
  if (groups * local <= max_width) {
    g.global[0] = groups * local;
  } else {
    g.global[0] = max_width;
    g.global[1] = (work_items + max_width - 1) / max_width;
  }
  return g;
}

}  // namespace glint
