// Client-side retries of transient failures: UNAVAILABLE (no connection, server restarting)
// and RESOURCE_EXHAUSTED when glintd says it may succeed later (its queue is full:
// --max-pending). Evaluation is a pure function of the request (the determinism contract), so
// repeating a call is always safe; repeating one that must fail again only delays the answer.
//
// RESOURCE_EXHAUSTED also means "this request exceeds a limit" (--max-request-cost, a message
// larger than the server accepts, a normal map over the memory budget): the same request is
// refused again. glintd tells the two apart as gRFC A6's server pushback does: a refusal that
// can succeed later carries trailing metadata `glint-retry-pushback-ms` (a wait in milliseconds;
// gRPC reserves the `grpc-` names), and only such a RESOURCE_EXHAUSTED is retried, after at
// least that wait.
//
// Backoff as gRPC's retry design (gRFC A6) specifies it: before retry n (n = 1, 2, ...) wait
// uniform(0, min(max_backoff, initial_backoff x multiplier^(n-1))), "full jitter", so that
// clients refused together do not come back together. Attempts are bounded, and a retry whose
// wait would end past the call's deadline is not made: the last status is returned instead.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <functional>
#include <optional>
#include <thread>

namespace glint::client {

struct RetryPolicy {
  int max_attempts = 5;  // including the first; 1 = never retry
  std::chrono::milliseconds initial_backoff{100};
  double multiplier = 2.0;
  std::chrono::milliseconds max_backoff{2000};
};

// The trailing metadata key of glintd's pushback (server/retry_pushback.h sends it).
inline constexpr char kRetryPushbackMetadata[] = "glint-retry-pushback-ms";

// What the server said about retrying the attempt's call.
struct RetryHint {
  std::optional<std::chrono::milliseconds> pushback;

  // Reads the pushback from a finished call (absent, malformed or negative: none).
  void ReadFrom(const grpc::ClientContext &context);
};

// UNAVAILABLE, or RESOURCE_EXHAUSTED with the server's pushback.
bool IsRetryable(grpc::StatusCode code, const RetryHint &hint);

// The upper end of the jittered wait before retry n >= 1.
std::chrono::milliseconds BackoffCeiling(const RetryPolicy &policy, int retry);

using Clock = std::chrono::steady_clock;

// Runs `attempt` until it returns a status that is OK or not retryable, `max_attempts` were
// made, or the next wait would end past `deadline` (Clock::time_point::max() = none). The
// attempt records the server's pushback in its RetryHint (cleared before each attempt); the
// wait is then the larger of the jittered backoff and the pushback. `sleep` waits (tests pass a
// recorder); `attempts`, if given, receives the number of attempts made.
grpc::Status CallWithRetries(
    const RetryPolicy &policy, Clock::time_point deadline,
    const std::function<grpc::Status(RetryHint *)> &attempt, int *attempts = nullptr,
    const std::function<void(Clock::duration)> &sleep = [](Clock::duration d) {
      std::this_thread::sleep_for(d);
    });

}  // namespace glint::client
