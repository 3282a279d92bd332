// --max-undelivered-mb covers every unary reply that waits on its client (issue 12): Sample and
// KServe ModelInfer replies are held in the same DeliveryBudget as Evaluate's from Finish until
// gRPC's OnDone (server/delivery_budget.h), and new Evaluate, Sample and ModelInfer calls are
// refused at the limit. A client that sends a request and never reads its reply (a channel
// whose HTTP/2 receive window stays at 64 KiB: no BDP probing) leaves a multi-MB reply on the
// server; with a 1 MiB budget one such reply fills it. (Before: only Evaluate replies were
// counted, so any number of unread Sample / ModelInfer replies were admitted.)
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "inference/grpc_service.grpc.pb.h"
#include "kserve_queries.h"
#include "test_queries.h"

namespace {

namespace v1 = glint::v1;
using Clock = std::chrono::steady_clock;

std::string GlintdPath() {
  return glint::test::GlintdUnderTest(GLINTD_PATH);
}

v1::Material Smooth() {
  return glint::test::SmoothTestMaterial(0.3f);
}

// `queries` x `k` samples: 28 bytes per sample in the reply.
v1::SampleRequest SampleRequest(uint32_t queries, uint32_t k) {
  v1::SampleRequest r;
  *r.mutable_material() = Smooth();
  *r.mutable_queries() = glint::test::RandomQueries(queries, false, false, 5);
  r.set_samples_per_query(k);
  return r;
}

v1::EvaluateRequest EvaluateRequest(uint32_t queries) {
  v1::EvaluateRequest r;
  *r.mutable_material() = Smooth();
  *r.mutable_queries() = glint::test::RandomQueries(queries, true, false, 6);
  return r;
}

inference::ModelInferRequest InferRequest(uint32_t queries) {
  return glint::test::KServeProbeRequest(queries, 7);
}

grpc::ByteBuffer Serialized(const google::protobuf::Message &m) {
  const std::string bytes = m.SerializeAsString();
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

// A unary call made by a client that never reads the reply: its own connection (a local
// subchannel pool), receive window held at 64 KiB. Cancelled on destruction.
class UnreadCall {
 public:
  UnreadCall(const std::string &address, const std::string &method, grpc::ByteBuffer request) {
    grpc::ChannelArguments args;
    args.SetInt("grpc.http2.lookahead_bytes", 65536);
    args.SetInt("grpc.http2.bdp_probe", 0);
    args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
    args.SetMaxReceiveMessageSize(64 << 20);
    channel_ = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
    stub_ = std::make_unique<grpc::GenericStub>(channel_);
    call_ = stub_->PrepareCall(&ctx_, method, &cq_);
    Step([&](void *t) { call_->StartCall(t); });
    Step([&](void *t) { call_->Write(request, t); });
    Step([&](void *t) { call_->WritesDone(t); });
  }
  ~UnreadCall() {
    ctx_.TryCancel();
    grpc::Status status;
    Step([&](void *t) { call_->Finish(&status, t); });
    cq_.Shutdown();
    void *tag;
    bool ok;
    while (cq_.Next(&tag, &ok)) {
    }
  }

 private:
  template <class Start>
  void Step(Start &&start) {
    void *want = reinterpret_cast<void *>(intptr_t(++tag_));
    start(want);
    void *tag = nullptr;
    bool ok = false;
    EXPECT_TRUE(cq_.Next(&tag, &ok));
    EXPECT_EQ(tag, want);
  }
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<grpc::GenericStub> stub_;
  grpc::ClientContext ctx_;
  grpc::CompletionQueue cq_;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call_;
  int tag_ = 0;
};

struct Outcome {
  grpc::Status status;
  bool pushback = false;
};

class Undelivered : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new glint::test::TempDir("glint_undelivered_test");
    std::string error;
    server_ = glint::test::Glintd::Start(
                  GlintdPath(), *dir_, "glintd",
                  {"--device", "host", "--max-pending", "4", "--max-undelivered-mb", "1", "--model",
                   "probe=" + std::string(GLINT_EXAMPLES_DIR) + "/materials/gold_aniso.json"},
                  &error)
                  .release();
    ASSERT_NE(server_, nullptr) << error;
    channel_ = new std::shared_ptr<grpc::Channel>(
        grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials()));
  }
  static void TearDownTestSuite() {
    delete channel_;
    delete server_;
    delete dir_;
  }

  // One small call of each method that the budget gates; `refused` of them must be
  // RESOURCE_EXHAUSTED naming the flag with a retry pushback, the others OK.
  static std::vector<Outcome> SmallCalls() {
    std::vector<Outcome> out(3);
    auto glint = v1::GlintService::NewStub(*channel_);
    auto kserve = inference::GRPCInferenceService::NewStub(*channel_);
    auto run = [](Outcome *o, const std::function<grpc::Status(grpc::ClientContext *)> &call) {
      grpc::ClientContext ctx;
      ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
      o->status = call(&ctx);
      for (const auto &[k, v] : ctx.GetServerTrailingMetadata())
        if (k == "glint-retry-pushback-ms") o->pushback = true;
    };
    run(&out[0], [&](grpc::ClientContext *ctx) {
      v1::EvaluateResponse r;
      return glint->Evaluate(ctx, EvaluateRequest(4), &r);
    });
    run(&out[1], [&](grpc::ClientContext *ctx) {
      v1::SampleResponse r;
      return glint->Sample(ctx, SampleRequest(4, 2), &r);
    });
    run(&out[2], [&](grpc::ClientContext *ctx) {
      inference::ModelInferResponse r;
      return kserve->ModelInfer(ctx, InferRequest(4), &r);
    });
    return out;
  }

  // Polls SmallCalls until all three are refused by the budget (at most `seconds`).
  static bool AllRefusedWithin(double seconds, std::vector<Outcome> *last) {
    const auto until = Clock::now() + std::chrono::duration<double>(seconds);
    for (;;) {
      *last = SmallCalls();
      bool all = true;
      for (const Outcome &o : *last)
        all = all && o.status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED;
      if (all || Clock::now() > until) return all;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }

  static bool AllAnsweredWithin(double seconds) {
    const auto until = Clock::now() + std::chrono::duration<double>(seconds);
    for (;;) {
      bool all = true;
      for (const Outcome &o : SmallCalls()) all = all && o.status.ok();
      if (all || Clock::now() > until) return all;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }

  static glint::test::TempDir *dir_;
  static glint::test::Glintd *server_;
  static std::shared_ptr<grpc::Channel> *channel_;
};
glint::test::TempDir *Undelivered::dir_ = nullptr;
glint::test::Glintd *Undelivered::server_ = nullptr;
std::shared_ptr<grpc::Channel> *Undelivered::channel_ = nullptr;

// One unread reply of each kind (~3.7 MB of samples, ~2.4 MB of KServe radiance) fills the
// 1 MiB budget: every new Evaluate, Sample and ModelInfer is then refused, naming the flag, with
// the retry pushback; once the reader is gone its reply is released and all three are answered.
TEST_F(Undelivered, UnreadSampleAndModelInferRepliesFillTheBudget) {
  ASSERT_TRUE(AllAnsweredWithin(120)) << "the server does not answer small calls while idle";
  struct Case {
    const char *what, *method;
    grpc::ByteBuffer request;
  };
  for (const Case &c :
       {Case{"Sample", "/glint.v1.GlintService/Sample", Serialized(SampleRequest(4096, 32))},
        Case{"ModelInfer", "/inference.GRPCInferenceService/ModelInfer",
             Serialized(InferRequest(200000))},
        // A 480 KB reply alone is under the budget, but gRPC keeps the typed request (960 KB of
        // input tensors) and response until the call ends: they count too.
        Case{"ModelInfer with its request", "/inference.GRPCInferenceService/ModelInfer",
             Serialized(InferRequest(40000))}}) {
    std::vector<Outcome> last;
    {
      UnreadCall unread(server_->address(), c.method, c.request);
      // Answered on the host path in well under a second when idle. The poll ends as soon as
      // the server refuses, so its bound only decides when a server that never counts the
      // reply is reported: 120 s, not a guess at the loaded machine's speed (15 s was).
      const bool refused = AllRefusedWithin(120, &last);
      EXPECT_TRUE(refused) << "an unread " << c.what << " reply was not counted: small calls "
                           << "were still admitted";
      for (const Outcome &o : last) {
        EXPECT_NE(o.status.error_message().find("--max-undelivered-mb 1)"), std::string::npos)
            << c.what << ": " << o.status.error_message();
        EXPECT_TRUE(o.pushback) << c.what << ": no glint-retry-pushback-ms";
      }
    }
    EXPECT_TRUE(AllAnsweredWithin(120)) << c.what << ": the reply was not released on cancel";
  }
  EXPECT_TRUE(server_->Alive());
}

}  // namespace
