// glintd probed as an outside client would (session 8 probe, issue 12): bytes that are not the
// method's message sent to the typed services beside glint.v1 (KServe v2, grpc.health.v1), a
// unary call that ends before one whole message arrived, and method paths no service defines
// against /metrics. Everything goes over the wire through grpc::GenericStub, which sends any
// byte buffer (or none) as a method's body; /metrics is read with cpp-httplib's client.
//
// GLINTD_UNDER_TEST runs the tests against another glintd binary (e.g. an older build, to see
// them fail there).
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <future>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "glint/v1/glint.pb.h"
#include "glintd_process.h"
#include "inference/grpc_service.pb.h"
#include "raw_call.h"

namespace {

std::string GlintdPath() {
  return glint::test::GlintdUnderTest(GLINTD_PATH);
}

grpc::ByteBuffer Bytes(const std::string &bytes) {
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

// Field 2, length-delimited, claiming 2^28 bytes that never come: no message parses it (the
// proto parser must read past the end whatever the message type).
std::string BadBytes() {
  return std::string("\x12\x80\x80\x80\x80\x01\x01\x02\x03", 9);
}

grpc::Status RawUnary(const std::shared_ptr<grpc::Channel> &channel, const std::string &method,
                      const grpc::ByteBuffer &request) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&ctx, method, grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status s) { done.set_value(std::move(s)); });
  return done.get_future().get();
}

// A call to `method` that half-closes without sending any message: the server's handler gets
// no body at all (what it also gets when a client's length prefix promises more bytes than
// arrive before END_STREAM: gRPC drops the partial message).
grpc::Status NoMessageCall(const std::shared_ptr<grpc::Channel> &channel,
                           const std::string &method) {
  glint::test::RawCall call(channel, method);
  call.WriteAllThenClose({});
  grpc::ByteBuffer reply;
  EXPECT_FALSE(call.Read(&reply)) << method << " answered";
  return call.Finish();
}

// The value of the exposition line for `series` (exact name and labels), or -1 when absent.
double Sample(const std::string &text, const std::string &series) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(series + " ", 0) == 0) return std::stod(line.substr(series.size() + 1));
  return -1;
}

int CountLines(const std::string &text, const std::regex &pattern) {
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) n += std::regex_search(line, pattern) ? 1 : 0;
  return n;
}

class OutsideClient : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new glint::test::TempDir("glint_outside_client_test");
    std::string error;
    server_ =
        glint::test::Glintd::Start(GlintdPath(), *dir_, "glintd",
                                   {"--device", "host", "--metrics-listen", "127.0.0.1:0"}, &error)
            .release();
    ASSERT_NE(server_, nullptr) << error;
    metrics_port_ = server_->MetricsPort();  // --metrics-listen 127.0.0.1:0
    ASSERT_GT(metrics_port_, 0) << server_->Stderr();
    channel_ = new std::shared_ptr<grpc::Channel>(
        grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials()));
  }
  static void TearDownTestSuite() {
    delete channel_;
    delete server_;
    delete dir_;
  }
  static const std::shared_ptr<grpc::Channel> &channel() { return *channel_; }
  static std::string Scrape() {
    httplib::Client http("127.0.0.1", metrics_port_);
    auto res = http.Get("/metrics");
    EXPECT_TRUE(res) << "no answer from /metrics";
    return res ? res->body : std::string();
  }

  static glint::test::TempDir *dir_;
  static glint::test::Glintd *server_;
  static std::shared_ptr<grpc::Channel> *channel_;
  static int metrics_port_;
};
glint::test::TempDir *OutsideClient::dir_ = nullptr;
glint::test::Glintd *OutsideClient::server_ = nullptr;
std::shared_ptr<grpc::Channel> *OutsideClient::channel_ = nullptr;
int OutsideClient::metrics_port_ = 0;

// The typed services (KServe v2, health) answer a body that does not parse with
// INVALID_ARGUMENT naming the expected message and its .proto (before: gRPC's callback default,
// UNIMPLEMENTED with an empty message, as for a method that does not exist). /metrics counts the
// status the client got. Methods that do not exist stay UNIMPLEMENTED; good bodies are answered.
TEST_F(OutsideClient, TypedServicesRefuseAnUnparseableBodyNamingTheMessage) {
  struct Case {
    const char *method, *message, *proto;
  };
  for (const Case &c : {Case{"/inference.GRPCInferenceService/ModelInfer",
                             "inference.ModelInferRequest", "inference/grpc_service.proto"},
                        Case{"/inference.GRPCInferenceService/ServerLive",
                             "inference.ServerLiveRequest", "inference/grpc_service.proto"},
                        Case{"/inference.GRPCInferenceService/ModelMetadata",
                             "inference.ModelMetadataRequest", "inference/grpc_service.proto"},
                        Case{"/grpc.health.v1.Health/Check", "grpc.health.v1.HealthCheckRequest",
                             "grpc/health/v1/health.proto"}}) {
    grpc::Status s = RawUnary(channel(), c.method, Bytes(BadBytes()));
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.method;
    EXPECT_NE(s.error_message().find(std::string("is not a whole ") + c.message), std::string::npos)
        << c.method << ": " << s.error_message();
    EXPECT_NE(s.error_message().find(c.proto), std::string::npos) << s.error_message();
  }
  // An empty body is a valid empty message: answered as before.
  EXPECT_TRUE(RawUnary(channel(), "/inference.GRPCInferenceService/ServerLive", Bytes("")).ok());
  EXPECT_TRUE(RawUnary(channel(), "/grpc.health.v1.Health/Check", Bytes("")).ok());
  // A method that does not exist, with bad bytes or good: UNIMPLEMENTED, as gRPC answers it.
  for (const char *method :
       {"/inference.GRPCInferenceService/NoSuchMethod", "/glint.v1.GlintService/NoSuchMethod"})
    for (const std::string &body : {BadBytes(), std::string()})
      EXPECT_EQ(RawUnary(channel(), method, Bytes(body)).error_code(),
                grpc::StatusCode::UNIMPLEMENTED)
          << method;
  const std::string text = Scrape();
  EXPECT_GE(
      Sample(text,
             "glint_grpc_server_handled_total{grpc_service=\"inference.GRPCInferenceService\","
             "grpc_method=\"ModelInfer\",grpc_code=\"INVALID_ARGUMENT\"}"),
      1.0)
      << text;
  EXPECT_EQ(
      Sample(text,
             "glint_grpc_server_handled_total{grpc_service=\"inference.GRPCInferenceService\","
             "grpc_method=\"ModelInfer\",grpc_code=\"UNIMPLEMENTED\"}"),
      -1.0)
      << text;
}

// With --auth-tokens, a bad body to a typed method that needs a token is refused for the missing
// token first, as the raw glint.v1 handlers do (a caller without a token learns nothing about
// the body); with the token it gets the INVALID_ARGUMENT above. Health needs no token either way.
TEST(OutsideClientWithTokens, UnparseableBodyWithoutATokenIsUnauthenticated) {
  glint::test::TempDir dir("glint_outside_client_tokens");
  const std::string tokens = dir.File("tokens");
  std::ofstream(tokens) << "probe-token-1\n";
  std::string error;
  auto server = glint::test::Glintd::Start(GlintdPath(), dir, "glintd",
                                           {"--device", "host", "--auth-tokens", tokens}, &error);
  ASSERT_NE(server, nullptr) << error;
  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  auto call = [&](const char *method, const char *token) {
    grpc::GenericStub stub(channel);
    grpc::ClientContext ctx;
    if (token) ctx.AddMetadata("authorization", std::string("Bearer ") + token);
    grpc::ByteBuffer request = Bytes(BadBytes()), response;
    std::promise<grpc::Status> done;
    stub.UnaryCall(&ctx, method, grpc::StubOptions(), &request, &response,
                   [&done](grpc::Status s) { done.set_value(std::move(s)); });
    return done.get_future().get();
  };
  const char *infer = "/inference.GRPCInferenceService/ModelInfer";
  EXPECT_EQ(call(infer, nullptr).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(call(infer, "wrong-token").error_code(), grpc::StatusCode::UNAUTHENTICATED);
  grpc::Status s = call(infer, "probe-token-1");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_NE(s.error_message().find("inference.ModelInferRequest"), std::string::npos);
  for (const char *open :
       {"/grpc.health.v1.Health/Check", "/inference.GRPCInferenceService/ServerLive"}) {
    s = call(open, nullptr);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
        << open << ": " << s.error_message();
  }
}

// glintd's request log (without --quiet) shows client-chosen strings as one escaped, bounded
// line: a normal-map file name with a newline cannot forge a log line, a 6 KB name does not
// make a 6 KB line (before: both were written raw).
TEST(OutsideClientLog, ClientStringsCannotForgeOrFloodLogLines) {
  glint::test::TempDir dir("glint_outside_client_log");
  const std::string port_file = dir.File("port"), log = dir.File("glintd.log");
  const pid_t pid = glint::test::Spawn({GlintdPath(), "--listen", "127.0.0.1:0", "--port-file",
                                        port_file, "--device", "host", "--warm", "none"},
                                       log + ".out", log);
  ASSERT_GT(pid, 0);
  std::string error;
  bool reaped = false;
  if (!glint::test::WaitForPortFile(pid, port_file, log, &error, &reaped)) {
    if (!reaped) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
    FAIL() << error;
  }
  const std::string port = glint::test::ReadFile(port_file);
  auto channel = grpc::CreateChannel("127.0.0.1:" + port, grpc::InsecureChannelCredentials());
  // UploadNormalMap with one chunk: file name `name`, 8 bytes that are no PNG (refused, logged).
  auto upload = [&](const std::string &name) {
    glint::v1::NormalMapChunk chunk;
    chunk.set_filename(name);
    chunk.set_data("notapng!");
    grpc::GenericStub stub(channel);
    grpc::CompletionQueue cq;
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    auto call = stub.PrepareCall(&ctx, "/glint.v1.GlintService/UploadNormalMap", &cq);
    grpc::ByteBuffer frame = Bytes(chunk.SerializeAsString()), reply;
    grpc::Status status;
    int tag = 0;
    auto step = [&](auto &&start) {
      start(reinterpret_cast<void *>(intptr_t(++tag)));
      void *got;
      bool ok;
      EXPECT_TRUE(cq.Next(&got, &ok));
    };
    step([&](void *t) { call->StartCall(t); });
    step([&](void *t) { call->Write(frame, t); });
    step([&](void *t) { call->WritesDone(t); });
    step([&](void *t) { call->Read(&reply, t); });
    step([&](void *t) { call->Finish(&status, t); });
    cq.Shutdown();
    void *got;
    bool ok;
    while (cq.Next(&got, &ok)) {
    }
    return status;
  };
  EXPECT_EQ(upload("evil\nglintd: FORGED line\n.png").error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  // 6000 bytes: beyond the log's 4096 but within the client's 8 KiB metadata limit, which the
  // refusal (it quotes the name) must fit to reach the client.
  const grpc::Status long_name = upload(std::string(6000, 'a') + ".png");
  EXPECT_EQ(long_name.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
      << long_name.error_message().substr(0, 300);
  kill(pid, SIGTERM);
  int wstatus = 0;
  waitpid(pid, &wstatus, 0);
  std::istringstream lines(glint::test::ReadFile(log));
  int uploads = 0;
  for (std::string line; std::getline(lines, line);) {
    EXPECT_NE(line.rfind("glintd: FORGED", 0), 0u) << line;
    EXPECT_LE(line.size(), 8 + 4096 + 40) << line.substr(0, 200);
    if (line.rfind("glintd: UploadNormalMap ", 0) == 0) ++uploads;
  }
  EXPECT_EQ(uploads, 2) << glint::test::ReadFile(log).substr(0, 2000);
  EXPECT_NE(glint::test::ReadFile(log).find("UploadNormalMap evil\\nglintd: FORGED line\\n.png"),
            std::string::npos);
}

// A refusal that quotes a long client-chosen string still reaches the client with its own code
// and a message that names the problem (before: the message exceeded the client's 16 KiB
// metadata limit, the client's transport dropped the call and reported RESOURCE_EXHAUSTED
// "received metadata size exceeds hard limit", a code the glint client retries).
TEST_F(OutsideClient, RefusalQuotingALongClientStringReachesTheClient) {
  // KServe ModelInfer for a model named by 20000 'x': NOT_FOUND quotes the name.
  inference::ModelInferRequest request;
  request.set_model_name(std::string(20000, 'x'));
  const std::string body = request.SerializeAsString();
  grpc::Status s = RawUnary(channel(), "/inference.GRPCInferenceService/ModelInfer", Bytes(body));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND) << s.error_message().substr(0, 200);
  EXPECT_EQ(s.error_message().rfind("model 'xxxx", 0), 0u) << s.error_message().substr(0, 200);
  EXPECT_NE(s.error_message().find("bytes in all)"), std::string::npos);
  EXPECT_LE(s.error_message().size(), 2048u + 40u);
}

// A unary call that ends before one whole message arrived is refused naming the message that
// did not arrive (before: parsed as an empty request and refused as "material: unset", or
// "material.model: unset" for Sample, which sends the client looking for a field it did set).
TEST_F(OutsideClient, UnaryCallWithoutAWholeMessageIsRefusedSayingSo) {
  for (auto [method, message] :
       {std::pair{"/glint.v1.GlintService/Evaluate", "glint.v1.EvaluateRequest"},
        std::pair{"/glint.v1.GlintService/Sample", "glint.v1.SampleRequest"},
        std::pair{"/glint.v1.GlintService/DeleteNormalMap", "glint.v1.DeleteNormalMapRequest"}}) {
    grpc::Status s = NoMessageCall(channel(), method);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << method;
    EXPECT_NE(s.error_message().find(std::string("request: no complete ") + message + " arrived"),
              std::string::npos)
        << method << ": " << s.error_message();
  }
  // A zero-length message is a whole (empty) message: still parsed and answered on its merits.
  grpc::Status s = RawUnary(channel(), "/glint.v1.GlintService/Evaluate", Bytes(""));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(s.error_message(), "material: unset");
}

// Method paths no service defines are counted in one series, however many distinct ones
// clients send (before: one series per path for the life of the server, so a client could grow
// the server's memory and every scrape without bound, with or without a token).
TEST_F(OutsideClient, InventedMethodPathsShareOneMetricsSeries) {
  const std::string unknown =
      "glint_grpc_server_handled_total{grpc_service=\"unknown\",grpc_method=\"unknown\","
      "grpc_code=\"UNIMPLEMENTED\"}";
  const double before = std::max(0.0, Sample(Scrape(), unknown));
  constexpr int kPaths = 40;
  for (int i = 0; i < kPaths; ++i)
    EXPECT_EQ(
        RawUnary(channel(), "/probe" + std::to_string(i) + ".Svc/M" + std::to_string(i), Bytes(""))
            .error_code(),
        grpc::StatusCode::UNIMPLEMENTED);
  const std::string text = Scrape();
  EXPECT_EQ(Sample(text, unknown), before + kPaths) << text;
  EXPECT_EQ(CountLines(text, std::regex("grpc_service=\"probe[0-9]+\\.Svc\"")), 0) << text;
}

}  // namespace
