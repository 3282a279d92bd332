// FormatRate (client/lib/rate_format.h), the rate glint eval and glint render print: three
// significant digits with an SI prefix, checked against strings worked out by hand.
#include "client/lib/rate_format.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using glint::client::FormatRate;

// The old "%.0f queries/s" printed these as "0": one query in 3 s (a cold kernel compile).
TEST(RateFormat, SlowBatchesKeepTheirDigits) {
  EXPECT_EQ(FormatRate(1, 3), "0.333");
  EXPECT_EQ(FormatRate(3, 2.1), "1.43");
  EXPECT_EQ(FormatRate(1, 2000), "0.0005");
}

TEST(RateFormat, LargeRatesGetAPrefix) {
  EXPECT_EQ(FormatRate(12.5, 1), "12.5");
  EXPECT_EQ(FormatRate(4560, 1), "4.56 k");
  EXPECT_EQ(FormatRate(1048576, 0.3033), "3.46 M");  // 3457224 / s
  EXPECT_EQ(FormatRate(1.2e9, 1), "1.2 G");
  // Rounding to three digits carries into the next prefix, never "1e+03".
  EXPECT_EQ(FormatRate(999.7, 1), "1 k");
  EXPECT_EQ(FormatRate(999.4, 1), "999");
}

TEST(RateFormat, NothingTimedIsADash) {
  EXPECT_EQ(FormatRate(0, 1), "0");
  EXPECT_EQ(FormatRate(10, 0), "-");
  EXPECT_EQ(FormatRate(10, -1), "-");
  EXPECT_EQ(FormatRate(10, NAN), "-");
  EXPECT_EQ(FormatRate(10, INFINITY), "-");
}

}  // namespace
