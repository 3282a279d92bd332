// CallWithRetries (client/lib/retry.h) with a scripted attempt function and a recording sleep:
// which codes are retried (RESOURCE_EXHAUSTED only with the server's pushback), the attempt
// bound, the deadline, the pushback as a lower bound of the wait, and the jitter's distribution.
#include "client/lib/retry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <vector>

namespace glint::client {
namespace {

using std::chrono::milliseconds;

struct Script {
  // A full queue's refusal: RESOURCE_EXHAUSTED with glintd's pushback (`pushback_ms` below).
  // DO_NOT_USE is never a real status, so it can stand for this one in a script.
  static constexpr grpc::StatusCode kBusy = grpc::StatusCode::DO_NOT_USE;

  explicit Script(std::vector<grpc::StatusCode> c, int64_t pushback = 0)
      : codes(std::move(c)), pushback_ms(pushback) {}
  std::vector<grpc::StatusCode> codes;  // returned in order; the last one repeats
  int64_t pushback_ms;
  size_t calls = 0;
  std::vector<Clock::duration> sleeps;

  grpc::Status Next(RetryHint *hint) {
    grpc::StatusCode c = codes[std::min(calls++, codes.size() - 1)];
    if (c == kBusy) {
      hint->pushback = milliseconds(pushback_ms);
      c = grpc::StatusCode::RESOURCE_EXHAUSTED;
    }
    return c == grpc::StatusCode::OK ? grpc::Status::OK : grpc::Status(c, "scripted");
  }
  grpc::Status Run(const RetryPolicy &policy, Clock::time_point deadline, int *attempts) {
    return CallWithRetries(
        policy, deadline, [this](RetryHint *hint) { return Next(hint); }, attempts,
        [this](Clock::duration d) { sleeps.push_back(d); });
  }
};

TEST(Retry, CeilingGrowsByTheMultiplierUpToTheCap) {
  const RetryPolicy p{10, milliseconds(100), 2.0, milliseconds(2000)};
  const int expected[] = {100, 200, 400, 800, 1600, 2000, 2000};
  for (int n = 1; n <= 7; ++n) EXPECT_EQ(BackoffCeiling(p, n).count(), expected[n - 1]) << n;
}

TEST(Retry, TransientCodesAreRetriedWithinTheirCeilings) {
  Script s{{grpc::StatusCode::UNAVAILABLE, Script::kBusy, grpc::StatusCode::OK}};
  int attempts = 0;
  EXPECT_TRUE(s.Run(RetryPolicy{}, Clock::time_point::max(), &attempts).ok());
  EXPECT_EQ(attempts, 3);
  ASSERT_EQ(s.sleeps.size(), 2u);
  EXPECT_LE(s.sleeps[0], milliseconds(100));  // uniform(0, 100 ms)
  EXPECT_LE(s.sleeps[1], milliseconds(200));  // uniform(0, 200 ms)
}

// RESOURCE_EXHAUSTED without the server's pushback is a limit (--max-request-cost, message size,
// memory budget): the same request would be refused again.
TEST(Retry, OtherCodesAreReturnedAtOnce) {
  for (const auto code : {grpc::StatusCode::INVALID_ARGUMENT, grpc::StatusCode::UNAUTHENTICATED,
                          grpc::StatusCode::INTERNAL, grpc::StatusCode::DEADLINE_EXCEEDED,
                          grpc::StatusCode::RESOURCE_EXHAUSTED}) {
    Script s({code, grpc::StatusCode::OK});
    int attempts = 0;
    EXPECT_EQ(s.Run(RetryPolicy{}, Clock::time_point::max(), &attempts).error_code(), code);
    EXPECT_EQ(attempts, 1);
    EXPECT_TRUE(s.sleeps.empty());
  }
}

TEST(Retry, AttemptsAreBounded) {
  Script s({grpc::StatusCode::UNAVAILABLE});
  int attempts = 0;
  RetryPolicy p;
  p.max_attempts = 4;
  EXPECT_EQ(s.Run(p, Clock::time_point::max(), &attempts).error_code(),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(attempts, 4);
  EXPECT_EQ(s.sleeps.size(), 3u);
  p.max_attempts = 1;
  Script once({Script::kBusy});
  EXPECT_EQ(once.Run(p, Clock::time_point::max(), &attempts).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(attempts, 1);
}

// The server's pushback is a lower bound of the wait: 300 ms above a first ceiling of 100 ms.
TEST(Retry, PushbackLengthensTheWait) {
  Script s({Script::kBusy, Script::kBusy, grpc::StatusCode::OK}, 300);
  int attempts = 0;
  EXPECT_TRUE(s.Run(RetryPolicy{}, Clock::time_point::max(), &attempts).ok());
  EXPECT_EQ(attempts, 3);
  ASSERT_EQ(s.sleeps.size(), 2u);
  for (const auto wait : s.sleeps) EXPECT_EQ(wait, milliseconds(300));
}

// A deadline that has passed: no wait can end before it, so no retry is made.
TEST(Retry, NoRetryPastTheDeadline) {
  Script s({grpc::StatusCode::UNAVAILABLE, grpc::StatusCode::OK});
  int attempts = 0;
  EXPECT_EQ(s.Run(RetryPolicy{}, Clock::now(), &attempts).error_code(),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(attempts, 1);
  EXPECT_TRUE(s.sleeps.empty());
}

// Full jitter: the wait before the first retry is uniform on [0, 100 ms]. Over n = 4000 draws
// the mean is 50 ms with standard error 100 / sqrt(12 n) = 0.46 ms (5 SE = 2.3 ms), and the
// extreme deciles are both hit (probability of missing one: 2 x 0.9^4000, nil).
TEST(Retry, JitterIsUniformOverTheWholeCeiling) {
  const int n = 4000;
  RetryPolicy p;
  p.max_attempts = 2;
  double sum = 0.0, lo = 1e9, hi = 0.0;
  for (int i = 0; i < n; ++i) {
    Script s({grpc::StatusCode::UNAVAILABLE});
    int attempts = 0;
    s.Run(p, Clock::time_point::max(), &attempts);
    ASSERT_EQ(s.sleeps.size(), 1u);
    const double ms = std::chrono::duration<double, std::milli>(s.sleeps[0]).count();
    ASSERT_GE(ms, 0.0);
    ASSERT_LE(ms, 100.0);
    sum += ms;
    lo = std::min(lo, ms);
    hi = std::max(hi, ms);
  }
  const double standard_error = 100.0 / std::sqrt(12.0 * n);
  EXPECT_NEAR(sum / n, 50.0, 5 * standard_error);
  EXPECT_LT(lo, 10.0);
  EXPECT_GT(hi, 90.0);
}

}  // namespace
}  // namespace glint::client
