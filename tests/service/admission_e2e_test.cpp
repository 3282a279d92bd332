// Admission against a real glintd, as the outside-client probe found it (issue 12):
//  - queued calls that already died (deadline passed, cancelled) give up their --max-pending
//    slot, whatever their kind (unary Evaluate as a batch member, Sample, a stream chunk,
//    KServe ModelInfer), so live clients are admitted while a long request holds the worker;
//  - Sample has the same cost admission as Evaluate (--max-query-cost, --max-request-cost).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <httplib.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "inference/grpc_service.grpc.pb.h"
#include "queue_depth_gauge.h"
#include "test_queries.h"

namespace {

namespace v1 = glint::v1;

// GLINTD_UNDER_TEST runs the tests against another glintd binary (e.g. main's, to see them fail).
std::string GlintdPath() {
  return glint::test::GlintdUnderTest(GLINTD_PATH);
}

v1::Material Smooth() {
  return glint::test::SmoothTestMaterial(0.2f);
}

v1::EvaluateRequest Probes(uint32_t n, uint32_t seed) {
  v1::EvaluateRequest r;
  *r.mutable_material() = Smooth();
  *r.mutable_queries() = glint::test::RandomQueries(n, true, false, seed);
  return r;
}

// Holds the one worker for minutes if run to the end (~3e6 BRDF evaluations per query, ~50 ms a
// query on the loaded 2-core PoCL device, 4000 queries): the test cancels it when done, so it
// is still running however slow or fast the machine.
v1::EvaluateRequest LongRequest() {
  return glint::test::FourQuadReferenceRequest(Smooth(), 4000);
}

v1::SampleRequest SmallSample(uint32_t n, uint32_t k) {
  v1::SampleRequest r;
  *r.mutable_material() = Smooth();
  *r.mutable_queries() = glint::test::RandomQueries(n, false, false, 9);
  r.set_samples_per_query(k);
  return r;
}

// A ModelInfer of the "probe" preset (a material without lights): wo and wi, one row each.
inference::ModelInferRequest InferProbe() {
  inference::ModelInferRequest r;
  r.set_model_name("probe");
  for (const char *name : {"wo", "wi"}) {
    auto *in = r.add_inputs();
    in->set_name(name);
    in->set_datatype("FP32");
    in->add_shape(1);
    in->add_shape(3);
    for (float v : {0.f, 0.6f, 0.8f}) in->mutable_contents()->add_fp32_contents(v);
  }
  return r;
}

void SetDeadline(grpc::ClientContext *ctx, std::chrono::milliseconds ms) {
  ctx->set_deadline(std::chrono::system_clock::now() + ms);
}

// Bug A. --workers 1 --max-pending 5: the long request runs; four more calls (an Evaluate that
// dynamic batching may gather, a Sample, a one-chunk stream, a ModelInfer) queue behind it and
// die, first by their deadline, then by the client's cancellation. Each round then admits a
// new Evaluate (it gets DEADLINE_EXCEEDED after waiting in the queue, not RESOURCE_EXHAUSTED
// "server busy", which every new request got before: 1 running + 4 dead = 5 slots), and at the
// end a live request queued behind the long one gets its result once the long one is
// cancelled, bit-identical to the same request on the idle server.
// No step assumes the server has done something by a guessed time: the queue-depth gauge of
// /metrics (requests queued or running) shows the long request admitted, the four calls queued
// behind it before they die, their slots freed after, and the live request queued before the
// long one is cancelled. The deadline round starts with deadlines of 1.5 s and doubles them
// (up to 4 times) while the four calls are not all queued before they expire, since a loaded
// machine may take that long to admit them; a round where they never were would prove nothing.
TEST(DeadQueuedCalls, GiveUpTheirPendingSlotsToLiveClients) {
  glint::test::TempDir dir("glint_admission_test");
  const std::string examples = GLINT_EXAMPLES_DIR;
  std::string error;
  auto server = glint::test::Glintd::Start(
      GlintdPath(), dir, "admission",
      {"--workers", "1", "--max-pending", "5", "--slice-ms", "50", "--batch-max-queries", "4096",
       "--batch-delay-us", "1000", "--metrics-listen", "127.0.0.1:0", "--model",
       "probe=" + examples + "/materials/gold_aniso.json"},
      &error);
  ASSERT_NE(server, nullptr) << error;
  const int metrics_port = server->MetricsPort();  // --metrics-listen 127.0.0.1:0
  ASSERT_GT(metrics_port, 0) << server->Stderr();
  httplib::Client http("127.0.0.1", metrics_port);
  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  auto stub = v1::GlintService::NewStub(channel);
  auto kserve = inference::GRPCInferenceService::NewStub(channel);
  ASSERT_EQ(glint::test::QueueDepth(http), 0);

  grpc::ClientContext long_ctx;
  SetDeadline(&long_ctx, std::chrono::minutes(10));
  grpc::Status long_status;
  std::atomic<bool> long_done{false};
  const v1::EvaluateRequest long_request = LongRequest();
  std::thread long_call([&] {
    v1::EvaluateResponse res;
    long_status = stub->Evaluate(&long_ctx, long_request, &res);
    long_done = true;
  });
  // An ASSERT below returns early: the long call must not outlive its context and thread.
  struct EndLongCall {
    grpc::ClientContext &ctx;
    std::thread &call;
    ~EndLongCall() {
      if (!call.joinable()) return;
      ctx.TryCancel();
      call.join();
    }
  } end_long_call{long_ctx, long_call};
  const auto long_ended = [&] { return long_done.load(); };
  // Admitted, so on the one worker (nothing else is queued).
  ASSERT_EQ(glint::test::WaitForQueueDepth(http, 1, long_ended, std::chrono::seconds(120)), 1)
      << long_status.error_message();

  const v1::EvaluateRequest small = Probes(64, 11);
  for (bool by_deadline : {true, false}) {
    SCOPED_TRACE(by_deadline ? "deadline passed" : "cancelled");
    std::chrono::milliseconds wait =
        by_deadline ? std::chrono::milliseconds(1500) : std::chrono::milliseconds(120000);
    for (int attempt = 0;; ++attempt) {
      grpc::ClientContext c[4];
      for (auto &ctx : c) SetDeadline(&ctx, wait);
      grpc::Status st[4];
      std::atomic<int> answered{0};
      std::vector<std::thread> calls;
      calls.emplace_back([&] {
        v1::EvaluateResponse res;
        st[0] = stub->Evaluate(&c[0], small, &res);
        ++answered;
      });
      calls.emplace_back([&] {
        v1::SampleResponse res;
        st[1] = stub->Sample(&c[1], SmallSample(8, 4), &res);
        ++answered;
      });
      calls.emplace_back([&] {
        auto stream = stub->EvaluateStream(&c[2]);
        v1::EvaluateChunk chunk;
        chunk.set_chunk_index(0);
        *chunk.mutable_request() = small;
        stream->Write(chunk);
        stream->WritesDone();
        v1::EvaluateChunkResult result;
        while (stream->Read(&result)) {
        }
        st[2] = stream->Finish();
        ++answered;
      });
      calls.emplace_back([&] {
        inference::ModelInferResponse res;
        st[3] = kserve->ModelInfer(&c[3], InferProbe(), &res);
        ++answered;
      });
      // All four queued behind the long request (1 + 4 = --max-pending).
      const double queued = glint::test::WaitForQueueDepth(
          http, 5, [&] { return answered > 0 || long_done; }, std::chrono::seconds(120));
      if (!by_deadline) {
        EXPECT_EQ(queued, 5) << "the four calls were not all queued";
        for (auto &ctx : c) ctx.TryCancel();
      }
      for (auto &t : calls) t.join();
      EXPECT_FALSE(long_done) << "the long request ended early: " << long_status.error_message();
      if (by_deadline && queued != 5 && attempt < 4) {
        // Expired before all were admitted: inconclusive, so again with twice the deadline once
        // the queue is back to the long request alone.
        wait *= 2;
        EXPECT_EQ(glint::test::WaitForQueueDepth(http, 1, long_ended, std::chrono::seconds(60)), 1);
        continue;
      }
      EXPECT_EQ(queued, 5) << "the four calls were never all queued before their deadline";
      const grpc::StatusCode dead =
          by_deadline ? grpc::StatusCode::DEADLINE_EXCEEDED : grpc::StatusCode::CANCELLED;
      const char *kind[4] = {"Evaluate", "Sample", "EvaluateStream", "ModelInfer"};
      for (int i = 0; i < 4; ++i)
        EXPECT_EQ(st[i].error_code(), dead) << kind[i] << ": " << st[i].error_message();
      break;
    }
    // The dead calls' slots are freed while the long request still runs (the client saw them
    // end; the server's OnCancel may come a moment later).
    EXPECT_EQ(glint::test::WaitForQueueDepth(http, 1, long_ended, std::chrono::seconds(60)), 1)
        << "the dead calls kept their slots";

    // Admitted: it waits behind the long request until its own deadline passes.
    grpc::ClientContext ctx;
    SetDeadline(&ctx, std::chrono::milliseconds(1000));
    v1::EvaluateResponse res;
    grpc::Status s = stub->Evaluate(&ctx, small, &res);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED)
        << "a new request while the dead calls' slots should be free: " << s.error_message();
    EXPECT_EQ(glint::test::WaitForQueueDepth(http, 1, long_ended, std::chrono::seconds(60)), 1);
  }

  // A live request behind the long one: answered once the long one is cancelled.
  grpc::ClientContext live_ctx;
  SetDeadline(&live_ctx, std::chrono::minutes(5));
  v1::EvaluateResponse live;
  grpc::Status live_status;
  std::atomic<bool> live_done{false};
  std::thread live_call([&] {
    live_status = stub->Evaluate(&live_ctx, small, &live);
    live_done = true;
  });
  EXPECT_EQ(glint::test::WaitForQueueDepth(
                http, 2, [&] { return live_done || long_done; }, std::chrono::seconds(120)),
            2)
      << "the live request was not queued behind the long one";
  long_ctx.TryCancel();
  long_call.join();
  live_call.join();
  EXPECT_EQ(long_status.error_code(), grpc::StatusCode::CANCELLED)
      << "the long request must have held the worker throughout: " << long_status.error_message();
  ASSERT_TRUE(live_status.ok()) << live_status.error_message();
  grpc::ClientContext alone_ctx;
  SetDeadline(&alone_ctx, std::chrono::minutes(2));
  v1::EvaluateResponse alone;
  ASSERT_TRUE(stub->Evaluate(&alone_ctx, small, &alone).ok());
  ASSERT_EQ(live.radiance_size(), 64 * 3);
  ASSERT_EQ(alone.radiance_size(), 64 * 3);
  for (int i = 0; i < 64 * 3; ++i) EXPECT_EQ(live.radiance(i), alone.radiance(i)) << i;
  EXPECT_TRUE(server->Alive());
}

// Bug B. Sample is admitted by cost as Evaluate is: with --max-query-cost 1e5 one smooth query
// of 65536 samples (65536 x 2 = 1.31e5 units) is refused, with --max-request-cost 1e6 512
// queries of 1024 samples (1.05e6) are, each with RESOURCE_EXHAUSTED naming the cost and the
// flag; an ordinary request (8 queries x 16 samples) is answered in full.
TEST(SampleAdmission, OverCostRefusedNamingCostAndFlagOrdinaryAnswered) {
  glint::test::TempDir dir("glint_sample_admission_test");
  std::string error;
  auto server = glint::test::Glintd::Start(
      GlintdPath(), dir, "sample_admission",
      {"--workers", "1", "--max-query-cost", "1e5", "--max-request-cost", "1e6"}, &error);
  ASSERT_NE(server, nullptr) << error;
  auto stub = v1::GlintService::NewStub(
      grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials()));
  struct Case {
    uint32_t queries, k;
    const char *cost, *flag;
  };
  for (const Case &c : {Case{1, 65536, "1.31e+05", "--max-query-cost 1e+05"},
                        Case{512, 1024, "1.05e+06", "--max-request-cost 1e+06"}}) {
    grpc::ClientContext ctx;
    SetDeadline(&ctx, std::chrono::minutes(2));
    v1::SampleResponse res;
    grpc::Status s = stub->Sample(&ctx, SmallSample(c.queries, c.k), &res);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
    EXPECT_NE(s.error_message().find(c.cost), std::string::npos) << s.error_message();
    EXPECT_NE(s.error_message().find(c.flag), std::string::npos) << s.error_message();
    EXPECT_NE(s.error_message().find("samples_per_query"), std::string::npos) << s.error_message();
  }
  grpc::ClientContext ctx;
  SetDeadline(&ctx, std::chrono::minutes(2));
  v1::SampleResponse res;
  grpc::Status s = stub->Sample(&ctx, SmallSample(8, 16), &res);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(res.count(), 8u);
  EXPECT_EQ(res.pdf_size(), 8 * 16);
  EXPECT_EQ(res.wi_size(), 8 * 16 * 3);
}

}  // namespace
