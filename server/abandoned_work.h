// Queries glintd did not compute because nobody waited for them any more: the client cancelled
// the call, its deadline passed, or shutdown cancelled work in flight after --shutdown-grace.
// Counted where the work stops (the slice loop's stop check, server/sliced_eval.h, and a queued
// job dropped before it started, server/dead_call.cpp), so the count is the work saved, not the
// work done: a 600-query request cancelled after 40 queries adds 560.
//
// Exported as glint_abandoned_queries_total{reason="cancelled|deadline|shutdown"} (server/
// metrics.h) and in glintd's last line on exit. Operators read it as "how much work clients
// gave up on" (a deadline count that grows with load says the deadlines are too tight for the
// queue); tests read it to see that abandoned work stopped short of its full size without
// timing anything (tests/service/robustness_test.cpp).
#pragma once

#include <atomic>
#include <cstdint>

#include "server/status.h"

namespace glint {

struct AbandonedCounts {
  uint64_t cancelled = 0;  // the client cancelled the call (or went away)
  // The call's deadline passed, as the server saw it. A client whose own deadline expires
  // first sends a cancellation, which reaches the server before (or at) the server's deadline
  // for the call: work stopped by it counts as cancelled.
  uint64_t deadline = 0;
  uint64_t shutdown = 0;  // cancelled by the server after --shutdown-grace
};

class AbandonedWork {
 public:
  // `queries` not computed because work stopped with `stop` (a stop check's status). Any other
  // status (a refusal, a device failure) is not abandoned work and is not counted.
  void Count(const Status &stop, uint64_t queries) {
    if (std::atomic<uint64_t> *counter = CounterFor(stop.code()))
      counter->fetch_add(queries, std::memory_order_relaxed);
  }

  AbandonedCounts counts() const {
    return {cancelled_.load(std::memory_order_relaxed), deadline_.load(std::memory_order_relaxed),
            shutdown_.load(std::memory_order_relaxed)};
  }

 private:
  std::atomic<uint64_t> *CounterFor(Status::Code code) {
    switch (code) {
      case Status::Code::kCancelled:
        return &cancelled_;
      case Status::Code::kDeadlineExceeded:
        return &deadline_;
      case Status::Code::kUnavailable:  // StopReason's status once shutdown cancels work
        return &shutdown_;
      default:
        return nullptr;
    }
  }

  std::atomic<uint64_t> cancelled_{0}, deadline_{0}, shutdown_{0};
};

}  // namespace glint
