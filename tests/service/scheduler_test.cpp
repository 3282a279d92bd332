// The scheduler fails fast when full and runs every accepted job.
#include "server/scheduler.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

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

// glintd holds its workers during the kernel warm-up (server/main.cpp): jobs queue, count against
// --max-pending and start only on Release. Not a timing check: a held job must not run however
// long we wait, and must run once released.
TEST(Scheduler, HeldJobsQueueAndStartOnlyWhenReleased) {
  std::atomic<int> ran{0};
  std::promise<void> both_ran;
  {
    Scheduler scheduler(2, 2);
    scheduler.Hold();
    auto job = [&](int) -> Scheduler::Respond {
      if (++ran == 2) both_ran.set_value();
      return nullptr;
    };
    ASSERT_TRUE(scheduler.TrySubmit(job));
    ASSERT_TRUE(scheduler.TrySubmit(job));
    EXPECT_FALSE(scheduler.TrySubmit(job));  // held jobs hold their slots
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_EQ(ran.load(), 0);
    EXPECT_EQ(scheduler.pending(), 2u);
    scheduler.Release();
    both_ran.get_future().wait();
    EXPECT_EQ(ran.load(), 2);
  }
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

namespace glint {
namespace {

struct TestMember : Scheduler::BatchMember {
  TestMember(std::string k, uint32_t q, int i) {
    key = std::move(k);
    queries = q;
    id = i;
  }
  int id = 0;
};

// Dynamic batching: with the worker busy, queued members of one key are gathered oldest first
// up to max_queries; other keys and plain jobs keep their own runs; a member gathered alone
// runs its own job; every member holds its own pending slot.
TEST(SchedulerBatching, GathersQueuedMembersOfOneKeyUpToMaxQueries) {
  std::promise<void> release;
  std::shared_future<void> gate = release.get_future().share();
  std::mutex mutex;
  std::vector<std::string> runs;  // "batch:1,2,4" or "solo:3"
  {
    Scheduler scheduler(1, 64);
    scheduler.EnableBatching({std::chrono::microseconds(0), 100},
                             [&](int, const Scheduler::Members &members) {
                               std::string run = "batch:";
                               for (const auto &m : members)
                                 run += std::to_string(static_cast<TestMember &>(*m).id) + ",";
                               std::lock_guard<std::mutex> lock(mutex);
                               runs.push_back(run);
                               return std::vector<Scheduler::Respond>(members.size());
                             });
    std::promise<void> started;
    ASSERT_TRUE(scheduler.TrySubmit([&](int) -> Scheduler::Respond {
      started.set_value();
      gate.wait();
      return nullptr;
    }));
    started.get_future().wait();
    auto submit = [&](const char *key, uint32_t queries, int id) {
      return scheduler.TrySubmit(
          [&, id](int) -> Scheduler::Respond {
            std::lock_guard<std::mutex> lock(mutex);
            runs.push_back("solo:" + std::to_string(id));
            return nullptr;
          },
          key ? std::make_shared<TestMember>(key, queries, id) : nullptr);
    };
    ASSERT_TRUE(submit("A", 30, 1));
    ASSERT_TRUE(submit("A", 30, 2));
    ASSERT_TRUE(submit("B", 10, 3));
    ASSERT_TRUE(submit("A", 30, 4));
    ASSERT_TRUE(submit("A", 30, 5));  // 30 x 4 > 100: the next batch
    ASSERT_TRUE(submit(nullptr, 0, 6));
    ASSERT_TRUE(submit("A", 50, 7));
    EXPECT_EQ(scheduler.pending(), 8u) << "the running job and 7 queued, batched or not";
    release.set_value();
  }
  const std::vector<std::string> expected = {"batch:1,2,4,", "solo:3", "batch:5,7,", "solo:6"};
  EXPECT_EQ(runs, expected);
}

// With a delay, an idle worker that took a member waits for more of its key (and dispatches as
// soon as the batch is full); without one, a member that arrives after the worker took the
// first runs on its own.
TEST(SchedulerBatching, WaitsUpToTheDelayForMoreMembersOnlyWhenAsked) {
  for (int delay_ms : {0, 5000}) {
    std::mutex mutex;
    std::vector<size_t> sizes;
    std::atomic<int> solo{0};
    {
      Scheduler scheduler(1, 8);
      scheduler.EnableBatching({std::chrono::milliseconds(delay_ms), 60},
                               [&](int, const Scheduler::Members &m) {
                                 std::lock_guard<std::mutex> lock(mutex);
                                 sizes.push_back(m.size());
                                 return std::vector<Scheduler::Respond>(m.size());
                               });
      auto job = [&](int) -> Scheduler::Respond {
        ++solo;
        return nullptr;
      };
      ASSERT_TRUE(scheduler.TrySubmit(job, std::make_shared<TestMember>("A", 30, 1)));
      // Long enough for the idle worker to have taken the first (a loaded machine only makes
      // the delay case gather sooner; the no-delay case needs the worker to have run it).
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      ASSERT_TRUE(scheduler.TrySubmit(job, std::make_shared<TestMember>("A", 30, 2)));
    }
    if (delay_ms == 0) {
      EXPECT_EQ(solo.load(), 2);
      EXPECT_TRUE(sizes.empty());
    } else {
      EXPECT_EQ(solo.load(), 0);
      EXPECT_EQ(sizes, std::vector<size_t>{2});
    }
  }
}

// Dead calls (issue 12): a queued job whose Dead check reports its call dead gives up its slot
// when the queue is full (TrySubmit, HasRoom) and when a worker takes a job; its job never runs
// and its answer runs exactly once. A live queued job keeps its slot and runs.
TEST(Scheduler, DeadQueuedJobsGiveUpTheirSlotsAndNeverRun) {
  std::promise<void> release;
  std::shared_future<void> gate = release.get_future().share();
  std::atomic<int> ran{0}, answered_dead{0};
  std::atomic<bool> dead[3] = {false, false, false};
  {
    Scheduler scheduler(1, 4);
    std::promise<void> started;
    ASSERT_TRUE(scheduler.TrySubmit([&](int) -> Scheduler::Respond {
      started.set_value();
      gate.wait();
      return nullptr;
    }));
    started.get_future().wait();  // the worker is busy; the queue holds 3
    auto job = [&](int) -> Scheduler::Respond {
      ++ran;
      return nullptr;
    };
    auto check = [&](int i) -> Scheduler::Dead {
      return [&, i]() -> Scheduler::Respond {
        if (!dead[i]) return nullptr;
        return [&] { ++answered_dead; };
      };
    };
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(scheduler.TrySubmit(job, nullptr, check(i)));
    EXPECT_FALSE(scheduler.HasRoom());
    EXPECT_FALSE(scheduler.TrySubmit(job, nullptr, check(0))) << "all alive: full";
    dead[0] = dead[2] = true;
    EXPECT_TRUE(scheduler.HasRoom());
    EXPECT_EQ(answered_dead.load(), 2);
    EXPECT_EQ(scheduler.pending(), 2u) << "the running job and the live queued one";
    EXPECT_TRUE(scheduler.TrySubmit(job, nullptr, check(0)));  // dies while queued, too
    EXPECT_EQ(answered_dead.load(), 2) << "not full: nothing dropped on submission";
    release.set_value();  // the worker drops it when it takes the next job
  }
  EXPECT_EQ(ran.load(), 1) << "only the live queued job ran";
  EXPECT_EQ(answered_dead.load(), 3);
}

}  // namespace
}  // namespace glint
