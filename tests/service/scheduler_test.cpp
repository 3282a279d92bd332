// The scheduler fails fast when full and runs every accepted job.
#include "server/scheduler.h"

#include <gtest/gtest.h>

#include <atomic>
#include <functional>
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
    ASSERT_TRUE(scheduler.TrySubmit([&](int) -> Scheduler::Respond {
      started.set_value();
      gate.wait();
      ++ran;
      return nullptr;
    }));
    started.get_future().wait();  // job 1 is running
    auto count = [&](int) -> Scheduler::Respond {
      ++ran;
      return nullptr;
    };
    ASSERT_TRUE(scheduler.TrySubmit(count));   // queued: 2 pending
    EXPECT_FALSE(scheduler.TrySubmit(count));  // full
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
      ASSERT_TRUE(scheduler.TrySubmit([&](int worker) -> Scheduler::Respond {
        workers_seen |= 1 << worker;
        if (++arrived == 2) both.set_value();
        gate.wait();  // both jobs run at once, so they must be on different workers
        return nullptr;
      }));
    }
  }
  EXPECT_EQ(workers_seen.load(), 3);
}

// The slot is free by the time the client is answered: a client that submits its next job from
// the answer of the last one (what a sequential client does) is never refused, even with room for
// a single job. With the answer given before the slot was freed, this failed intermittently.
TEST(Scheduler, SlotIsFreeWhenTheClientIsAnswered) {
  Scheduler scheduler(1, 1);
  constexpr int kChain = 2000;
  std::atomic<int> refused{0}, done{0};
  std::promise<void> finished;
  std::function<void()> submit = [&] {
    bool ok = scheduler.TrySubmit([&](int) -> Scheduler::Respond {
      return [&] {
        if (++done == kChain) {
          finished.set_value();
          return;
        }
        submit();  // the "client" sends its next request on receipt of the answer
      };
    });
    if (!ok) {
      ++refused;
      finished.set_value();
    }
  };
  submit();
  finished.get_future().wait();
  EXPECT_EQ(refused.load(), 0);
  EXPECT_EQ(done.load(), kChain);
}

}  // namespace
}  // namespace glint
