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

}  // namespace
}  // namespace glint
