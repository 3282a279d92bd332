// GridFor (server/launch_grid.h) against the properties every launch relies on, checked by
// enumeration: the local size divides the row width, no dimension reaches PoCL's small-grid limit
// (else PoCL compiles a second work-group function), the grid covers every work-item, and the
// padding is less than one row (one group when the grid is a single row). kernels/work_item.h
// turns (x, y) back into y * width + x, so covering [0, n) with row-major indices is what
// makes the result the same as a 1D launch.
#include "server/launch_grid.h"

#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

#include "server/work_group_size.h"

namespace glint {
namespace {

TEST(LaunchGrid, RowsDividedByTheLocalSizeBelowPoclsLimitCoveringEveryWorkItem) {
  const size_t locals[] = {1, 2, 64, 96, 128, 1000, 32767, 65534};
  for (size_t local : locals) {
    const size_t max_width = (kPoclSmallGridLimit - 1) / local * local;
    const std::vector<size_t> counts = {1,
                                        local,
                                        local + 1,
                                        max_width - 1,
                                        max_width,
                                        max_width + 1,
                                        2 * max_width,
                                        2 * max_width + 1,
                                        1000 * max_width + 17,
                                        size_t(1) << 20};
    for (size_t n : counts) {
      SCOPED_TRACE(testing::Message() << "local " << local << ", work-items " << n);
      const LaunchGrid g = GridFor(n, local);
      EXPECT_EQ(g.local[0], local);
      EXPECT_EQ(g.local[1], 1u);
      EXPECT_EQ(g.global[0] % local, 0u);
      EXPECT_LT(g.global[0], kPoclSmallGridLimit);
      EXPECT_LT(g.global[1], kPoclSmallGridLimit);
      EXPECT_GE(g.global[1], 1u);
      const size_t covered = g.global[0] * g.global[1];
      EXPECT_GE(covered, n);
      if (g.global[1] == 1)
        EXPECT_LT(covered - n, local);  // one row: padded to whole groups only
      else
        EXPECT_LT(covered - n, g.global[0]);  // several rows: the last row padded
    }
  }
}

// LocalSizeFor (server/work_group_size.h): the configured size divided by the blocks per
// work-item first, then lowered to the smallest limit (0 = none), never below 1.
TEST(LocalSizeFor, LargestSizeNotAboveTheConfiguredOneThatEveryLimitAllows) {
  const struct {
    size_t configured, blocks, kernel, device, cap, expected;
  } cases[] = {
      {128, 1, 0, 0, 0, 128},        // no limits known: the configured size (PoCL: 4096 each)
      {128, 1, 4096, 4096, 0, 128},  // PoCL's CPU device
      {128, 4, 4096, 4096, 0, 32},   // BINOMIAL's lights pass: 4 blocks per work-item
      {128, 4, 16, 4096, 0, 16},     // divided first: min(32, 16), not min(128, 16) / 4 = 4
      {128, 1, 96, 256, 0, 96},      // the kernel's own limit, not a power of two
      {128, 1, 256, 64, 0, 64},      // the device's
      {128, 1, 100, 80, 0, 80},      // the smaller of both
      {128, 1, 4096, 4096, 3, 3},    // the test cap
      {128, 1, 2, 4096, 7, 2},       // a cap above a limit changes nothing
      {128, 4, 4096, 4096, 7, 7},    // 32 capped at 7
      {128, 3, 0, 0, 0, 42},         // blocks not dividing: rounded down
      {2, 4, 0, 0, 0, 1},            // fewer work-items than blocks: at least 1
      {1, 1, 1, 1, 1, 1},           {7, 1, 5, 0, 0, 5}, {7, 2, 0, 0, 2, 2},  // 3 capped at 2
      {128, 0, 0, 0, 0, 128},  // blocks 0 = 1 (Model::Blocks never says 0; the guard is cheap)
  };
  for (const auto &c : cases) {
    SCOPED_TRACE(testing::Message()
                 << "configured " << c.configured << ", blocks " << c.blocks << ", kernel "
                 << c.kernel << ", device " << c.device << ", cap " << c.cap);
    EXPECT_EQ(LocalSizeFor(c.configured, c.blocks, {c.kernel, c.device, c.cap}), c.expected);
  }
}

// EnqueueShrinkingGroups against a fake device that refuses groups above `accepts` (with the
// given error): the sizes tried halve from the start down to the first accepted one, each grid
// padded to a multiple of its own size; errors a smaller group cannot cure are returned at once;
// at size 1 the device's last error is returned.
TEST(EnqueueShrinkingGroups, HalvesUntilTheDeviceAcceptsThenKeepsThatSize) {
  const struct {
    size_t start, accepts;
    cl_int refusal;
    cl_int result;
    size_t final_local;
    std::vector<size_t> tried;
  } cases[] = {
      {128, 128, CL_INVALID_WORK_GROUP_SIZE, CL_SUCCESS, 128, {128}},
      {128, 100, CL_INVALID_WORK_GROUP_SIZE, CL_SUCCESS, 64, {128, 64}},
      {128, 5, CL_OUT_OF_RESOURCES, CL_SUCCESS, 4, {128, 64, 32, 16, 8, 4}},
      {7, 3, CL_INVALID_WORK_ITEM_SIZE, CL_SUCCESS, 3, {7, 3}},
      {3, 1, CL_OUT_OF_RESOURCES, CL_SUCCESS, 1, {3, 1}},
      {6, 0, CL_OUT_OF_RESOURCES, CL_OUT_OF_RESOURCES, 1, {6, 3, 1}},  // not even 1
      {1, 0, CL_OUT_OF_RESOURCES, CL_OUT_OF_RESOURCES, 1, {1}},
      {128, 0, CL_INVALID_KERNEL_ARGS, CL_INVALID_KERNEL_ARGS, 128, {128}},  // not the size's
  };
  const size_t work_items = 1001;  // padded to whole groups by most sizes tried
  for (const auto &c : cases) {
    SCOPED_TRACE(testing::Message() << "start " << c.start << ", accepts " << c.accepts);
    std::vector<size_t> tried;
    size_t local = c.start;
    const cl_int err = EnqueueShrinkingGroups(work_items, &local, [&](const LaunchGrid &g) {
      tried.push_back(g.local[0]);
      EXPECT_EQ(g.global[0] % g.local[0], 0u);
      EXPECT_GE(g.global[0] * g.global[1], work_items);
      return g.local[0] <= c.accepts ? CL_SUCCESS : c.refusal;
    });
    EXPECT_EQ(err, c.result);
    EXPECT_EQ(local, c.final_local);
    EXPECT_EQ(tried, c.tried);
  }
}

}  // namespace
}  // namespace glint
