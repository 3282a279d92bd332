// server/abandoned_work.h: only the statuses a stop check returns when nobody waits any more
// (CANCELLED, DEADLINE_EXCEEDED, UNAVAILABLE after --shutdown-grace) count as abandoned work; a
// refusal does not. The shared-memory path relies on this: its overlapped value check stops the
// slices with INVALID_ARGUMENT, and the generic on_stop then counts nothing for it
// (server/shm_io.cpp).
#include "server/abandoned_work.h"

#include <gtest/gtest.h>

namespace glint {
namespace {

TEST(AbandonedWork, CountsStopsNobodyWaitsForAndNothingElse) {
  AbandonedWork w;
  w.Count(Status::Cancelled("the client cancelled the call"), 3);
  w.Count(Status::DeadlineExceeded("the call's deadline passed"), 5);
  w.Count(Status::Unavailable("shutting down"), 7);
  w.Count(Status::InvalidArgument("refused by the value check"), 1000);
  w.Count(Status::Ok(), 2000);
  const AbandonedCounts c = w.counts();
  EXPECT_EQ(c.cancelled, 3u);
  EXPECT_EQ(c.deadline, 5u);
  EXPECT_EQ(c.shutdown, 7u);
}

}  // namespace
}  // namespace glint
