// MakeLoadQueries: the load tool's queries are valid for glintd (unit directions above the
// horizon), checked by recomputing each length.
#include <gtest/gtest.h>

#include <cmath>

#include "client/lib/load_runner.h"

namespace {

TEST(LoadQueries, UnitDirectionsInTheUpperHemisphere) {
  const glint::v1::QueryBatch q = glint::client::MakeLoadQueries(1000, true);
  ASSERT_EQ(q.count(), 1000u);
  ASSERT_EQ(q.wo_size(), 3000);
  ASSERT_EQ(q.wi_size(), 3000);
  for (int i = 0; i < 3000; i += 3) {
    for (const auto *a : {&q.wo(), &q.wi()}) {
      const double x = a->Get(i), y = a->Get(i + 1), z = a->Get(i + 2);
      // glintd's unit tolerance is |length - 1| <= 1e-3; float rounding gives ~1e-7.
      EXPECT_NEAR(std::sqrt(x * x + y * y + z * z), 1.0, 1e-6);
      EXPECT_GE(z, 0.1 - 1e-6);
    }
  }
}

}  // namespace
