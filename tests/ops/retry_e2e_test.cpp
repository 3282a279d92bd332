// Client retries against a real glintd with --max-pending 1 (one request queued or running).
// A slow request (REFERENCE quadrature of a polygon light) holds the only slot; while it runs a
// call is refused (RESOURCE_EXHAUSTED with the server's retry pushback), and eight concurrent
// clients with retries all get every answer, each equal to the answer of a quiet server, after
// retrying. A request over --max-request-cost is refused without pushback and not retried.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

#include "client/lib/glint_client.h"
#include "client/lib/load_runner.h"
#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"

namespace {

using glint::client::ClientOptions;
using glint::client::GlintClient;
using glint::test::Glintd;
using glint::test::TempDir;

glint::v1::EvaluateRequest Smooth(uint32_t n) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.3f);
  for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(0.5f);
  *r.mutable_queries() = glint::client::MakeLoadQueries(n, true);
  return r;
}

// Seconds of work on the host path: REFERENCE with 256 x 256 nodes per spherical triangle of a
// square light, i.e. ~1.3e5 BRDF evaluations per query.
glint::v1::EvaluateRequest Slow() {
  glint::v1::EvaluateRequest r = Smooth(1);
  *r.mutable_queries() = glint::client::MakeLoadQueries(200, false);
  auto *polygon = r.add_lights()->mutable_polygon();
  for (const float v : {-1.f, -1.f, 1.f, 1.f, -1.f, 1.f, 1.f, 1.f, 1.f, -1.f, 1.f, 1.f}) {
    polygon->add_vertices(v);
  }
  for (int c = 0; c < 3; ++c) polygon->add_radiance(1.0f);
  polygon->set_two_sided(true);
  r.set_area_method(glint::v1::REFERENCE);
  r.set_area_samples(256);
  return r;
}

TEST(RetryEndToEnd, ConcurrentClientsOfAFullServerAllSucceed) {
  TempDir dir("glint_retry");
  std::string error;
  auto server = Glintd::Start(GLINTD_PATH, dir, "glintd",
                              {"--device", "host", "--max-pending", "1", "--workers", "1"}, &error);
  ASSERT_NE(server, nullptr) << error;
  const glint::v1::EvaluateRequest small = Smooth(1024);
  std::vector<float> expected;
  {
    GlintClient quiet(server->address());
    ASSERT_TRUE(quiet.Evaluate(small, &expected).ok());
  }

  // The slow request takes the slot; wait until a retry-less probe is refused, which proves
  // the slot is held (it cannot be the probe's own earlier request: there is none).
  std::atomic<bool> slow_done{false};
  grpc::Status slow_status;
  std::thread slow([&] {
    // Retries: the impatient probe below may hold the slot for a moment when the slow request
    // arrives; the slow request must get the slot eventually, not give up.
    ClientOptions o;
    o.retry.max_attempts = 20;
    GlintClient client(server->address(), o);
    std::vector<float> rgb;
    slow_status = client.Evaluate(Slow(), &rgb);
    slow_done = true;
  });
  auto stub = glint::v1::GlintService::NewStub(
      grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials()));
  grpc::Status refused;
  std::string pushback;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  do {
    grpc::ClientContext context;
    glint::v1::EvaluateResponse response;
    refused = stub->Evaluate(&context, small, &response);
    const auto &trailers = context.GetServerTrailingMetadata();
    const auto it = trailers.find(glint::client::kRetryPushbackMetadata);
    pushback = it == trailers.end() ? "" : std::string(it->second.data(), it->second.size());
  } while (refused.ok() && !slow_done && std::chrono::steady_clock::now() < give_up);
  ASSERT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED)
      << "the slow request never held the slot; slow finished: " << slow_done;
  // --slice-ms's default: the pushback glintd sends with a full queue.
  EXPECT_EQ(pushback, "50") << refused.error_message();

  // Eight clients, three requests each, while the slot is taken: they are refused and retry.
  // Budget: the 120 s deadline of each request, not a count of attempts. 60 attempts with waits
  // up to 500 ms (~15 s) was a guess at how long the slow request holds the slot, which a loaded
  // machine can exceed (it is seconds of one core's work); the retry loop stops at the deadline
  // (Retry.NoRetryPastTheDeadline), so the attempts bound is only a backstop.
  constexpr int kClients = 8, kRequests = 3;
  std::vector<grpc::Status> statuses(kClients * kRequests);
  std::vector<int> attempts(kClients * kRequests, 0);
  std::vector<bool> equal(kClients * kRequests, false);
  std::vector<std::thread> clients;
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      ClientOptions o;
      o.retry.max_attempts = 1000;
      o.retry.initial_backoff = std::chrono::milliseconds(20);
      o.retry.max_backoff = std::chrono::milliseconds(500);
      o.evaluate_timeout = std::chrono::seconds(120);
      GlintClient client(server->address(), o);
      for (int k = 0; k < kRequests; ++k) {
        std::vector<float> out;
        glint::client::EvaluateInfo info;
        const size_t i = static_cast<size_t>(c * kRequests + k);
        statuses[i] = client.Evaluate(small, &out, {}, &info);
        attempts[i] = info.attempts;
        equal[i] = out.size() == expected.size() &&
                   std::memcmp(out.data(), expected.data(), out.size() * sizeof(float)) == 0;
      }
    });
  }
  for (auto &t : clients) t.join();
  slow.join();
  EXPECT_TRUE(slow_status.ok()) << glint::client::FormatStatus(slow_status);
  int retried = 0;
  for (size_t i = 0; i < statuses.size(); ++i) {
    EXPECT_TRUE(statuses[i].ok()) << i << ": " << glint::client::FormatStatus(statuses[i]);
    EXPECT_TRUE(equal[i]) << i;
    retried += attempts[i] > 1;
  }
  // Each client's first request started while the slow one held the slot.
  EXPECT_GE(retried, 1);
}

}  // namespace

// A limit, not a full queue: refused with RESOURCE_EXHAUSTED naming the cost, without pushback,
// so a client with retries enabled asks once instead of max_attempts times.
TEST(RetryEndToEnd, CostRefusalIsNotRetried) {
  TempDir dir("glint_retry_cost");
  std::string error;
  auto server = Glintd::Start(GLINTD_PATH, dir, "glintd",
                              {"--device", "host", "--max-request-cost", "100"}, &error);
  ASSERT_NE(server, nullptr) << error;
  ClientOptions o;
  o.retry.max_attempts = 5;
  GlintClient client(server->address(), o);
  std::vector<float> rgb;
  glint::client::EvaluateInfo info;
  const grpc::Status s = client.Evaluate(Smooth(1024), &rgb, {}, &info);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("--max-request-cost"), std::string::npos) << s.error_message();
  EXPECT_EQ(info.attempts, 1);

  auto stub = glint::v1::GlintService::NewStub(
      grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  glint::v1::EvaluateResponse response;
  EXPECT_EQ(stub->Evaluate(&context, Smooth(1024), &response).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(context.GetServerTrailingMetadata().count(glint::client::kRetryPushbackMetadata), 0u);
}
