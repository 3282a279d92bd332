// The scheduler fails fast when full and runs every accepted job.
#include "server/scheduler.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>

namespace glint {
namespace {

TEST(Scheduler, RefusesBeyondMaxPendingAndRecovers) {
  std::promise<void> release;
  std::shared_future<void> gate = release.get_future().share();
  std::atomic<int> ran{0};
  {
    Scheduler scheduler(1, 2);
    std::promise<void> started;
    ASSERT_TRUE(scheduler.TrySubmit([&](int) {
      started.set_value();
      gate.wait();
      ++ran;
    }));
    started.get_future().wait();                             // job 1 is running
    ASSERT_TRUE(scheduler.TrySubmit([&](int) { ++ran; }));   // queued: 2 pending
    EXPECT_FALSE(scheduler.TrySubmit([&](int) { ++ran; }));  // full
    EXPECT_EQ(scheduler.pending(), 2u);
    release.set_value();
    // Destruction drains the queue.
  }
  EXPECT_EQ(ran.load(), 2);
}

TEST(Scheduler, EachWorkerHasItsOwnLane) {
  std::atomic<int> workers_seen{0};
  std::promise<void> both;
  std::atomic<int> arrived{0};
  std::shared_future<void> gate = both.get_future().share();
  {
    Scheduler scheduler(2, 8);
    for (int j = 0; j < 2; ++j) {
      ASSERT_TRUE(scheduler.TrySubmit([&](int worker) {
        workers_seen |= 1 << worker;
        if (++arrived == 2) both.set_value();
        gate.wait();  // both jobs run at once, so they must be on different workers
      }));
    }
  }
  EXPECT_EQ(workers_seen.load(), 3);
}

}  // namespace
}  // namespace glint
