#include "client/lib/retry.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <thread>

namespace glint::client {

bool IsRetryable(grpc::StatusCode code) {
  return code == grpc::StatusCode::UNAVAILABLE || code == grpc::StatusCode::RESOURCE_EXHAUSTED;
}

std::chrono::milliseconds BackoffCeiling(const RetryPolicy &policy, int retry) {
  const double ceiling = static_cast<double>(policy.initial_backoff.count()) *
                         std::pow(policy.multiplier, std::max(0, retry - 1));
  return std::chrono::milliseconds(
      static_cast<int64_t>(std::min(ceiling, static_cast<double>(policy.max_backoff.count()))));
}

grpc::Status CallWithRetries(const RetryPolicy &policy, Clock::time_point deadline,
                             const std::function<grpc::Status()> &attempt, int *attempts,
                             const std::function<void(Clock::duration)> &sleep) {
  // One generator per thread, seeded from the OS: jitter must differ between clients.
  thread_local std::mt19937_64 rng{std::random_device{}()};
  int made = 0;
  grpc::Status status;
  for (;;) {
    status = attempt();
    ++made;
    if (status.ok() || !IsRetryable(status.error_code()) || made >= policy.max_attempts) break;
    const auto ceiling = std::chrono::duration_cast<Clock::duration>(BackoffCeiling(policy, made));
    std::uniform_int_distribution<Clock::rep> jitter(0, ceiling.count());
    const Clock::duration wait(jitter(rng));
    if (deadline != Clock::time_point::max() && Clock::now() + wait >= deadline) break;
    sleep(wait);
  }
  if (attempts) *attempts = made;
  return status;
}

}  // namespace glint::client
