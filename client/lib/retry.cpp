#include "client/lib/retry.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <random>
#include <string>
#include <thread>

namespace glint::client {

void RetryHint::ReadFrom(const grpc::ClientContext &context) {
  pushback.reset();
  const auto &trailers = context.GetServerTrailingMetadata();
  const auto it = trailers.find(kRetryPushbackMetadata);
  if (it == trailers.end()) return;
  const std::string text(it->second.data(), it->second.size());
  char *end = nullptr;
  const long long ms = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || ms < 0) return;
  pushback = std::chrono::milliseconds(ms);
}

bool IsRetryable(grpc::StatusCode code, const RetryHint &hint) {
  return code == grpc::StatusCode::UNAVAILABLE ||
         (code == grpc::StatusCode::RESOURCE_EXHAUSTED && hint.pushback.has_value());
}

std::chrono::milliseconds BackoffCeiling(const RetryPolicy &policy, int retry) {
  const double ceiling = static_cast<double>(policy.initial_backoff.count()) *
                         std::pow(policy.multiplier, std::max(0, retry - 1));
  return std::chrono::milliseconds(
      static_cast<int64_t>(std::min(ceiling, static_cast<double>(policy.max_backoff.count()))));
}

grpc::Status CallWithRetries(const RetryPolicy &policy, Clock::time_point deadline,
                             const std::function<grpc::Status(RetryHint *)> &attempt, int *attempts,
                             const std::function<void(Clock::duration)> &sleep) {
  // One generator per thread, seeded from the OS: jitter must differ between clients.
  thread_local std::mt19937_64 rng{std::random_device{}()};
  int made = 0;
  grpc::Status status;
  for (;;) {
    RetryHint hint;
    status = attempt(&hint);
    ++made;
    if (status.ok() || !IsRetryable(status.error_code(), hint) || made >= policy.max_attempts)
      break;
    const auto ceiling = std::chrono::duration_cast<Clock::duration>(BackoffCeiling(policy, made));
    std::uniform_int_distribution<Clock::rep> jitter(0, ceiling.count());
    const Clock::duration wait = std::max<Clock::duration>(
        Clock::duration(jitter(rng)), hint.pushback.value_or(std::chrono::milliseconds(0)));
    if (deadline != Clock::time_point::max() && Clock::now() + wait >= deadline) break;
    sleep(wait);
  }
  if (attempts) *attempts = made;
  return status;
}

}  // namespace glint::client
