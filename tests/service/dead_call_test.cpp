// A queued call that is cancelled, or whose deadline passes, leaves the queue at once (issue 12):
// its reactor's OnCancel asks the scheduler to drop the dead queued jobs
// (Scheduler::DropDeadJobs), so its --max-pending slot and the queue-depth gauge are freed then,
// not when the queue is next full or the worker takes the job. With the one worker busy on a
// long request (~30 s of REFERENCE work, cancelled at the end) and room in the queue, the gauge
// (glintd --metrics-listen, scraped with cpp-httplib) must fall back to 1 while the long request
// still runs. Before, it stayed at 2 until the worker was free again. Each dropped call's
// queries are counted as abandoned (glint_abandoned_queries_total, all of them, exactly once:
// none of them ran) under "cancelled", or for a call past its deadline under "cancelled" or
// "deadline" (the client's cancellation at its deadline may reach the server first), never
// "shutdown"; the long request, cancelled at the end, adds between 1 and 600.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <httplib.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <regex>
#include <string>
#include <thread>

#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "inference/grpc_service.grpc.pb.h"
#include "kserve_queries.h"
#include "queue_depth_gauge.h"
#include "scraped_metric.h"
#include "test_queries.h"

namespace {

namespace v1 = glint::v1;
using Clock = std::chrono::steady_clock;

std::string GlintdPath() {
  return glint::test::GlintdUnderTest(GLINTD_PATH);
}

v1::Material Smooth() {
  return glint::test::SmoothTestMaterial(0.2f);
}

v1::EvaluateRequest LongRequest(uint32_t n) {
  return glint::test::FourQuadReferenceRequest(Smooth(), n);
}

using glint::test::QueueDepth;

// Polls the gauge until it equals `want` or `stop()` or 120 s; returns the last value read. The
// poll ends at the event, so the bound only decides when a server that never gets there is
// reported (10 s was a guess a loaded machine could exceed).
template <class Stop>
double WaitForDepth(httplib::Client &http, double want, Stop &&stop) {
  return glint::test::WaitForQueueDepth(http, want, stop, std::chrono::seconds(120));
}

TEST(DeadCall, CancelledQueuedCallLeavesTheQueueAtOnce) {
  glint::test::TempDir dir("glint_dead_call_test");
  std::string error;
  auto server = glint::test::Glintd::Start(
      GlintdPath(), dir, "dead_call",
      {"--workers", "1", "--max-pending", "8", "--slice-ms", "50", "--metrics-listen",
       "127.0.0.1:0", "--model",
       "probe=" + std::string(GLINT_EXAMPLES_DIR) + "/materials/gold_aniso.json"},
      &error);
  ASSERT_NE(server, nullptr) << error;
  const int metrics_port = server->MetricsPort();  // --metrics-listen 127.0.0.1:0
  ASSERT_GT(metrics_port, 0) << server->Stderr();
  httplib::Client http("127.0.0.1", metrics_port);
  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  auto stub = v1::GlintService::NewStub(channel);
  auto kserve = inference::GRPCInferenceService::NewStub(channel);
  ASSERT_EQ(QueueDepth(http), 0);

  {  // Compile the long request's kernel first: a compile is not sliced, so a cancelled long
     // request would hold its slot until a cold compile ended (over 10 s under load).
    grpc::ClientContext ctx;
    v1::EvaluateResponse res;
    ASSERT_TRUE(stub->Evaluate(&ctx, LongRequest(1), &res).ok());
  }

  grpc::ClientContext long_ctx;
  long_ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(300));
  std::atomic<bool> long_done{false};
  grpc::Status long_status;
  std::thread long_call([&] {
    v1::EvaluateResponse res;
    long_status = stub->Evaluate(&long_ctx, LongRequest(600), &res);
    long_done = true;
  });
  auto long_ended = [&] { return long_done.load(); };
  if (WaitForDepth(http, 1, long_ended) != 1) {
    // An ASSERT here would leave long_call joinable (std::terminate, glintd left running).
    ADD_FAILURE() << "the long request was never admitted";
    long_ctx.TryCancel();
    long_call.join();
    return;
  }

  enum Method { kEvaluate, kSample, kModelInfer };
  struct Case {
    const char *what;
    Method method;
    bool use_deadline;
  };
  // The case past its deadline last: a retried call of it (below) may still be dropped and
  // counted after its round, which the case's own count accounts for, but a later case's would
  // not.
  for (const Case &c :
       {Case{"Evaluate cancelled", kEvaluate, false}, Case{"Sample cancelled", kSample, false},
        Case{"ModelInfer cancelled", kModelInfer, false},
        Case{"Evaluate past its deadline", kEvaluate, true}}) {
    SCOPED_TRACE(c.what);
    // Past its deadline: 1.5 s, doubled (up to 4 times) while the call expires before the gauge
    // has shown it queued, which a loaded machine can take that long to do; such a round
    // would prove nothing. Its call may still reach glintd, be queued and dropped, and be
    // counted during a later round, so the count is taken over the whole case and each round's
    // call has its own size, 16 x 3^round queries: the count over 16, in base 3, has one digit
    // per round saying how many times that round's call was counted. The round that saw its call
    // queued must be counted exactly once, an earlier one at most once (never, if it expired
    // before reaching glintd), a later one does not exist. (Before, each round counted from its
    // own start, and a retried call counted late read as 32 in the next round.)
    const auto abandoned = [&] {
      const double cancelled =
          glint::test::ScrapedValue(http, glint::test::AbandonedSeries("cancelled"));
      const double deadline =
          glint::test::ScrapedValue(http, glint::test::AbandonedSeries("deadline"));
      const double shutdown =
          glint::test::ScrapedValue(http, glint::test::AbandonedSeries("shutdown"));
      return std::array<double, 3>{cancelled, deadline, shutdown};
    };
    const std::array<double, 3> abandoned_before = abandoned();
    for (int attempt = 0, deadline_ms = 1500, size = 16;; ++attempt, deadline_ms *= 2, size *= 3) {
      grpc::ClientContext ctx;
      ctx.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::milliseconds(c.use_deadline ? deadline_ms : 60000));
      grpc::Status status;
      std::atomic<bool> answered{false};
      std::thread queued([&] {
        if (c.method == kModelInfer) {
          inference::ModelInferResponse res;
          status =
              kserve->ModelInfer(&ctx, glint::test::KServeProbeRequest(uint32_t(size), 7), &res);
        } else if (c.method == kSample) {
          v1::SampleRequest req;
          *req.mutable_material() = Smooth();
          *req.mutable_queries() = glint::test::RandomQueries(uint32_t(size), false, false, 3);
          req.set_samples_per_query(4);
          v1::SampleResponse res;
          status = stub->Sample(&ctx, req, &res);
        } else {
          v1::EvaluateRequest req;
          *req.mutable_material() = Smooth();
          *req.mutable_queries() = glint::test::RandomQueries(uint32_t(size), true, false, 7);
          v1::EvaluateResponse res;
          status = stub->Evaluate(&ctx, req, &res);
        }
        answered = true;
      });
      // Queued behind the long request: the gauge counts it.
      const double depth = WaitForDepth(http, 2, [&] { return long_done || answered; });
      if (!c.use_deadline) ctx.TryCancel();
      queued.join();
      if (c.use_deadline && depth != 2 && attempt < 4 && !long_done) {
        EXPECT_EQ(WaitForDepth(http, 1, long_ended), 1);
        continue;
      }
      EXPECT_EQ(depth, 2) << "never saw the call queued";
      EXPECT_EQ(status.error_code(),
                c.use_deadline ? grpc::StatusCode::DEADLINE_EXCEEDED : grpc::StatusCode::CANCELLED);
      EXPECT_EQ(WaitForDepth(http, 1, long_ended), 1) << "the dead call kept its slot";
      // Counted when it was dropped, before the gauge fell.
      const std::array<double, 3> abandoned_after = abandoned();
      const double cancelled = abandoned_after[0] - abandoned_before[0];
      const double deadline = abandoned_after[1] - abandoned_before[1];
      const double counted = cancelled + deadline;
      // EXPECT, not ASSERT: an ASSERT would leave long_call joinable.
      EXPECT_EQ(std::fmod(counted, 16.0), 0) << counted << " queries counted";
      long digits = long(counted / 16);
      for (int round = 0; round <= attempt; ++round, digits /= 3) {
        if (round == attempt) {
          EXPECT_EQ(digits % 3, 1) << "this round's call counted " << digits % 3 << " times";
        } else {
          EXPECT_LE(digits % 3, 1) << "round " << round << "'s call counted twice";
        }
      }
      EXPECT_EQ(digits, 0) << counted << " queries counted: more than this case's calls";
      if (!c.use_deadline) {
        EXPECT_EQ(deadline, 0);
      }
      EXPECT_EQ(abandoned_after[2] - abandoned_before[2], 0);
      EXPECT_FALSE(long_done) << "the long request ended first, so the check proved nothing ("
                              << long_status.error_message() << ")";
      break;
    }
  }
  const double cancelled_before =
      glint::test::ScrapedValue(http, glint::test::AbandonedSeries("cancelled"));
  long_ctx.TryCancel();
  long_call.join();
  EXPECT_EQ(long_status.error_code(), grpc::StatusCode::CANCELLED) << long_status.error_message();
  const double long_abandoned =
      glint::test::WaitForScrapedValue(http, glint::test::AbandonedSeries("cancelled"),
                                       cancelled_before + 1, std::chrono::seconds(120)) -
      cancelled_before;
  EXPECT_GE(long_abandoned, 1) << "the long request ran to its end";
  EXPECT_LE(long_abandoned, 600);
  EXPECT_EQ(WaitForDepth(http, 0, [] { return false; }), 0);
  EXPECT_TRUE(server->Alive());
}

}  // namespace
