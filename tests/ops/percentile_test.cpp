// Nearest-rank percentiles (client/lib/percentile.h) against values worked out by hand.
#include "client/lib/percentile.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace glint::client {
namespace {

// The textbook nearest-rank example (n = 5): rank = ceil(p/100 * 5).
//   p5 -> ceil(0.25) = 1 -> 15;  p30 -> ceil(1.5) = 2 -> 20;  p40 -> ceil(2) = 2 -> 20;
//   p50 -> ceil(2.5) = 3 -> 35;  p100 -> 5 -> 50.
TEST(Percentile, NearestRankTextbookExample) {
  const std::vector<double> x = {35, 20, 50, 15, 40};  // unsorted on purpose
  EXPECT_EQ(NearestRankPercentile(x, 5), 15);
  EXPECT_EQ(NearestRankPercentile(x, 30), 20);
  EXPECT_EQ(NearestRankPercentile(x, 40), 20);
  EXPECT_EQ(NearestRankPercentile(x, 50), 35);
  EXPECT_EQ(NearestRankPercentile(x, 100), 50);
}

// Latencies 1..10 ms shuffled, n = 10: p50 -> rank 5 -> 5; p90 -> rank 9 -> 9;
// p99 -> ceil(9.9) = 10 -> 10; p91 -> ceil(9.1) = 10 -> 10; p10 -> rank 1 -> 1.
TEST(Percentile, TenLatenciesByHand) {
  const std::vector<double> x = {7, 3, 10, 1, 9, 2, 8, 5, 4, 6};
  const std::vector<double> p = NearestRankPercentiles(x, {10, 50, 90, 91, 99});
  EXPECT_EQ(p, (std::vector<double>{1, 5, 9, 10, 10}));
}

// n = 200: p99 has rank exactly 198 (not 199: 99 x 200 / 100 is an exact integer).
TEST(Percentile, ExactRankIsNotRoundedUp) {
  std::vector<double> x;
  for (int i = 200; i >= 1; --i) x.push_back(i);
  EXPECT_EQ(NearestRankPercentile(x, 99), 198);
  EXPECT_EQ(NearestRankPercentile(x, 50), 100);
  EXPECT_EQ(NearestRankPercentile(x, 90), 180);
}

TEST(Percentile, EmptyIsNaNAndBadPercentileThrows) {
  EXPECT_TRUE(std::isnan(NearestRankPercentile({}, 50)));
  EXPECT_THROW(NearestRankPercentile({1.0}, 0), std::invalid_argument);
  EXPECT_THROW(NearestRankPercentile({1.0}, 100.5), std::invalid_argument);
  EXPECT_THROW(NearestRankPercentile({1.0}, std::nan("")), std::invalid_argument);
  EXPECT_EQ(NearestRankPercentile({4.0}, 0.001), 4.0);
}

}  // namespace
}  // namespace glint::client
