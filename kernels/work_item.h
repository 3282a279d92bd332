/* The linear index of this work-item in a launch of one or two dimensions.
 *
 * The device engine launches a batch as a 2D grid (server/launch_grid.h): rows of at most 65534
 * work-items (the largest multiple of the local size below 65535: 65408 at the default 128), as many rows as the batch needs. Why:
 * PoCL 3.1 compiles a kernel's work-group function separately for grids whose widest dimension
 * is below 65535 work-items ("smallgrid", pocl_cache.c pocl_cache_kernel_cachedir_path,
 * pocl_llvm_wg.cc; grid_width_specialization_limit = USHRT_MAX in devices/common.c) and for
 * larger ones, so a 1D launch of a large batch compiled the kernel a second time (25-30% of a
 * variant's compile) after a warm-up with one query. With no dimension reaching the limit every
 * launch uses the one work-group function the warm-up compiled.
 *
 * Row-major: work-item (x, y) is index y * width + x, so a batch's work-items cover indices
 * 0 .. rows x width - 1 in order and each query keeps the work-item (and the lanes) it had in a
 * 1D launch: results do not depend on the grid shape. Indices past the batch are padding; every
 * entry bounds-checks the index against the query count. A 1D launch (y = 0) gives
 * get_global_id(0), as before. */
#ifndef GLINT_WORK_ITEM_H
#define GLINT_WORK_ITEM_H

#ifdef __OPENCL_VERSION__
inline uint glint_work_item(void) {
  return (uint)(get_global_id(1) * get_global_size(0) + get_global_id(0));
}
#endif

#endif
