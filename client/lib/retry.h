// Client-side retries of transient failures: UNAVAILABLE (no connection, server restarting)
// and RESOURCE_EXHAUSTED (glintd's queue is full: --max-pending). Evaluation is a pure
// function of the request (the determinism contract), so repeating a call is always safe.
//
// Backoff as gRPC's retry design (gRFC A6) specifies it: before retry n (n = 1, 2, ...) wait
// uniform(0, min(max_backoff, initial_backoff x multiplier^(n-1))), "full jitter", so that
// clients refused together do not come back together. Attempts are bounded, and a retry whose
// wait would end past the call's deadline is not made: the last status is returned instead.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <functional>
#include <thread>

namespace glint::client {

struct RetryPolicy {
  int max_attempts = 5;  // including the first; 1 = never retry
  std::chrono::milliseconds initial_backoff{100};
  double multiplier = 2.0;
  std::chrono::milliseconds max_backoff{2000};
};

// UNAVAILABLE or RESOURCE_EXHAUSTED.
bool IsRetryable(grpc::StatusCode code);

// The upper end of the jittered wait before retry n >= 1.
std::chrono::milliseconds BackoffCeiling(const RetryPolicy &policy, int retry);

using Clock = std::chrono::steady_clock;

// Runs `attempt` until it returns a status that is OK or not retryable, `max_attempts` were
// made, or the next wait would end past `deadline` (Clock::time_point::max() = none). `sleep`
// waits (tests pass a recorder); `attempts`, if given, receives the number of attempts made.
grpc::Status CallWithRetries(
    const RetryPolicy &policy, Clock::time_point deadline,
    const std::function<grpc::Status()> &attempt, int *attempts = nullptr,
    const std::function<void(Clock::duration)> &sleep = [](Clock::duration d) {
      std::this_thread::sleep_for(d);
    });

}  // namespace glint::client
