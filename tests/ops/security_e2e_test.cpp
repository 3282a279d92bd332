// TLS, mutual TLS and bearer tokens against real glintd processes (--device host, loopback).
// Certificates are made at test time with the openssl command-line tool: a CA, a server
// certificate for 127.0.0.1 and a client certificate signed by it, and a second ("rogue") CA
// with a client certificate of its own. Each case is one accept and the matching denies.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "client/lib/glint_client.h"
#include "client/lib/load_runner.h"
#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "inference/grpc_service.grpc.pb.h"
#include "server/ops.h"

namespace {

using glint::client::ChannelSecurity;
using glint::client::LoadChannelSecurity;
using glint::test::Glintd;
using glint::test::ReadFile;
using glint::test::Spawn;
using glint::test::TempDir;

int RunProgram(const TempDir &dir, const std::vector<std::string> &args,
               std::string *output = nullptr) {
  const pid_t pid = Spawn(args, dir.File("run.out"), dir.File("run.err"));
  int status = 0;
  waitpid(pid, &status, 0);
  if (output) *output = ReadFile(dir.File("run.out")) + ReadFile(dir.File("run.err"));
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

void Write(const std::string &path, const std::string &text) {
  std::ofstream(path) << text;
}

// A CA (name.pem/.key) and leaves signed by it.
class Pki {
 public:
  explicit Pki(const TempDir &dir) : dir_(dir) {}

  bool Ca(const std::string &name) {
    return Openssl({"req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
                    "-nodes", "-keyout", dir_.File(name + ".key"), "-out", dir_.File(name + ".pem"),
                    "-days", "2", "-subj", "/CN=" + name});
  }

  // A leaf for `name` signed by `ca`, with the given X.509 v3 extensions.
  bool Leaf(const std::string &name, const std::string &ca, const std::string &extensions) {
    Write(dir_.File(name + ".ext"), extensions + "\n");
    return Openssl({"req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
                    "-keyout", dir_.File(name + ".key"), "-out", dir_.File(name + ".csr"), "-subj",
                    "/CN=" + name}) &&
           Openssl({"x509", "-req", "-in", dir_.File(name + ".csr"), "-CA", dir_.File(ca + ".pem"),
                    "-CAkey", dir_.File(ca + ".key"), "-CAcreateserial", "-out",
                    dir_.File(name + ".pem"), "-days", "2", "-extfile", dir_.File(name + ".ext")});
  }

 private:
  bool Openssl(std::vector<std::string> args) {
    args.insert(args.begin(), "openssl");
    args.insert(args.begin(), "/usr/bin/env");
    std::string output;
    const int code = RunProgram(dir_, args, &output);
    EXPECT_EQ(code, 0) << output;
    return code == 0;
  }
  const TempDir &dir_;
};

// One ServerReflectionInfo exchange asking list_services (ServerReflectionRequest field 7, an
// empty string: bytes 0x3a 0x00, encoded by hand so the test needs no reflection stubs).
// Returns the call's status; `reply` receives the response bytes, which name the services.
grpc::Status ListServicesByReflection(const std::string &address, std::string *reply) {
  auto channel = grpc::CreateChannel(address, grpc::InsecureChannelCredentials());
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  const grpc::internal::RpcMethod method(
      "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
      grpc::internal::RpcMethod::BIDI_STREAMING, channel);
  std::unique_ptr<grpc::ClientReaderWriter<grpc::ByteBuffer, grpc::ByteBuffer>> stream(
      grpc::internal::ClientReaderWriterFactory<grpc::ByteBuffer, grpc::ByteBuffer>::Create(
          channel.get(), method, &context));
  const grpc::Slice request(std::string("\x3a\x00", 2));
  grpc::ByteBuffer out(&request, 1), in;
  stream->Write(out);
  stream->WritesDone();
  reply->clear();
  while (stream->Read(&in)) {
    std::vector<grpc::Slice> slices;
    if (in.Dump(&slices).ok())
      for (const auto &slice : slices)
        reply->append(reinterpret_cast<const char *>(slice.begin()), slice.size());
  }
  return stream->Finish();
}

class Security : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir("glint_security");
    Pki pki(*dir_);
    ASSERT_TRUE(pki.Ca("ca"));
    ASSERT_TRUE(pki.Ca("rogue_ca"));
    ASSERT_TRUE(pki.Leaf("server", "ca", "subjectAltName=IP:127.0.0.1,DNS:localhost"));
    ASSERT_TRUE(pki.Leaf("client", "ca", "extendedKeyUsage=clientAuth"));
    ASSERT_TRUE(pki.Leaf("rogue_client", "rogue_ca", "extendedKeyUsage=clientAuth"));
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string F(const std::string &name) { return dir_->File(name); }

  static std::unique_ptr<Glintd> Start(const std::string &name,
                                       const std::vector<std::string> &extra) {
    std::vector<std::string> args = {"--device", "host"};
    args.insert(args.end(), extra.begin(), extra.end());
    std::string error;
    auto server = Glintd::Start(GLINTD_PATH, *dir_, name, args, &error);
    EXPECT_NE(server, nullptr) << error;
    return server;
  }

  // GetCapabilities through GlintClient with `security`; a short deadline so a refused
  // handshake is reported quickly.
  static grpc::Status Capabilities(const std::string &address, const ChannelSecurity &security) {
    glint::client::ClientOptions options;
    options.security = security;
    options.rpc_timeout = std::chrono::seconds(5);
    glint::client::GlintClient client(address, options);
    return client.GetCapabilities(nullptr);
  }

  static TempDir *dir_;
};

TempDir *Security::dir_ = nullptr;

TEST_F(Security, TlsAcceptsVerifiedClientsAndRefusesPlaintextAndUnknownRoots) {
  auto server = Start("tls", {"--tls-cert", F("server.pem"), "--tls-key", F("server.key")});
  ASSERT_NE(server, nullptr);
  EXPECT_TRUE(Capabilities(server->address(), LoadChannelSecurity(F("ca.pem"), "", "", "")).ok());
  // Plaintext against a TLS port, and a client that trusts another CA: no connection.
  EXPECT_EQ(Capabilities(server->address(), ChannelSecurity{}).error_code(),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(Capabilities(server->address(), LoadChannelSecurity(F("rogue_ca.pem"), "", "", ""))
                .error_code(),
            grpc::StatusCode::UNAVAILABLE);
}

TEST_F(Security, MutualTlsNeedsAClientCertificateFromTheConfiguredCa) {
  auto server = Start("mtls", {"--tls-cert", F("server.pem"), "--tls-key", F("server.key"),
                               "--tls-client-ca", F("ca.pem")});
  ASSERT_NE(server, nullptr);
  EXPECT_TRUE(Capabilities(server->address(),
                           LoadChannelSecurity(F("ca.pem"), F("client.pem"), F("client.key"), ""))
                  .ok());
  EXPECT_EQ(
      Capabilities(server->address(), LoadChannelSecurity(F("ca.pem"), "", "", "")).error_code(),
      grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(Capabilities(server->address(), LoadChannelSecurity(F("ca.pem"), F("rogue_client.pem"),
                                                                F("rogue_client.key"), ""))
                .error_code(),
            grpc::StatusCode::UNAVAILABLE);
}

// Every RPC of the three methods, sent with raw stubs so the authorization value is exactly
// what the test says; returns the three status codes.
std::vector<grpc::StatusCode> CallAll(const std::string &address, const std::string &header) {
  auto channel = glint::client::MakeChannel(address, 64 << 20, ChannelSecurity{});
  auto stub = glint::v1::GlintService::NewStub(channel);
  auto prepare = [&](grpc::ClientContext *c) {
    if (!header.empty()) c->AddMetadata("authorization", header);
    c->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  };
  glint::v1::EvaluateRequest request;
  auto *m = request.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.3f);
  for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(0.5f);
  *request.mutable_queries() = glint::client::MakeLoadQueries(8, true);

  std::vector<grpc::StatusCode> codes;
  {
    grpc::ClientContext c;
    prepare(&c);
    glint::v1::Capabilities caps;
    codes.push_back(stub->GetCapabilities(&c, {}, &caps).error_code());
  }
  {
    grpc::ClientContext c;
    prepare(&c);
    glint::v1::EvaluateResponse response;
    codes.push_back(stub->Evaluate(&c, request, &response).error_code());
  }
  {
    grpc::ClientContext c;
    prepare(&c);
    auto stream = stub->EvaluateStream(&c);
    glint::v1::EvaluateChunk chunk;
    *chunk.mutable_request() = request;
    stream->Write(chunk);
    stream->WritesDone();
    glint::v1::EvaluateChunkResult result;
    while (stream->Read(&result)) {
    }
    codes.push_back(stream->Finish().error_code());
  }
  return codes;
}

// The Open Inference Protocol on the same port: ServerLive (its health call) and
// ServerMetadata (guarded like every other call), with `authorization` as given.
std::vector<grpc::StatusCode> CallKServe(const std::string &address,
                                         const std::string &authorization) {
  auto channel = glint::client::MakeChannel(address, 1 << 20, ChannelSecurity{});
  auto stub = inference::GRPCInferenceService::NewStub(channel);
  std::vector<grpc::StatusCode> codes;
  {
    grpc::ClientContext c;
    if (!authorization.empty()) c.AddMetadata("authorization", authorization);
    inference::ServerLiveResponse response;
    codes.push_back(stub->ServerLive(&c, {}, &response).error_code());
  }
  {
    grpc::ClientContext c;
    if (!authorization.empty()) c.AddMetadata("authorization", authorization);
    inference::ServerMetadataResponse response;
    codes.push_back(stub->ServerMetadata(&c, {}, &response).error_code());
  }
  return codes;
}

grpc::health::v1::HealthCheckResponse::ServingStatus Health(const std::string &address) {
  auto channel = glint::client::MakeChannel(address, 1 << 20, ChannelSecurity{});
  auto health = grpc::health::v1::Health::NewStub(channel);
  grpc::ClientContext c;
  c.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  grpc::health::v1::HealthCheckResponse response;
  EXPECT_TRUE(health->Check(&c, {}, &response).ok());
  return response.status();
}

TEST_F(Security, TokensGuardEveryRpcButHealthAndAreReloadedOnSighup) {
  Write(F("tokens"), "# ops team\n  alpha-token-123  \n\nbeta-token-456\n");
  auto server = Start("tokens", {"--auth-tokens", F("tokens")});
  ASSERT_NE(server, nullptr);
  using C = std::vector<grpc::StatusCode>;
  const C ok(3, grpc::StatusCode::OK), denied(3, grpc::StatusCode::UNAUTHENTICATED);
  const std::string address = server->address();
  EXPECT_EQ(CallAll(address, ""), denied);
  EXPECT_EQ(CallAll(address, "Bearer wrong-token"), denied);
  EXPECT_EQ(CallAll(address, "alpha-token-123"), denied);        // not "Bearer <token>"
  EXPECT_EQ(CallAll(address, "Bearer alpha-token-12"), denied);  // a prefix is not the token
  EXPECT_EQ(CallAll(address, "Bearer alpha-token-123"), ok);
  EXPECT_EQ(CallAll(address, "Bearer beta-token-456"), ok);
  EXPECT_EQ(Health(address), grpc::health::v1::HealthCheckResponse::SERVING);  // no token
  // KServe v2: ServerLive is open like health, everything else needs the token.
  EXPECT_EQ(CallKServe(address, ""), C({grpc::StatusCode::OK, grpc::StatusCode::UNAUTHENTICATED}));
  EXPECT_EQ(CallKServe(address, "Bearer alpha-token-123"), C(2, grpc::StatusCode::OK));
  // Sample: refused before anything else without a token; with one, the empty request reaches
  // validation (INVALID_ARGUMENT), so the token check let it through.
  for (const auto &[authorization, code] :
       {std::pair{std::string(), grpc::StatusCode::UNAUTHENTICATED},
        std::pair{std::string("Bearer alpha-token-123"), grpc::StatusCode::INVALID_ARGUMENT}}) {
    auto stub = glint::v1::GlintService::NewStub(
        glint::client::MakeChannel(address, 1 << 20, ChannelSecurity{}));
    grpc::ClientContext c;
    if (!authorization.empty()) c.AddMetadata("authorization", authorization);
    glint::v1::SampleResponse response;
    EXPECT_EQ(stub->Sample(&c, {}, &response).error_code(), code) << authorization;
  }

  // Reflection is gRPC's own service, which the token check cannot guard: not served at all
  // (the linked plugin registers itself; glintd removes it when tokens are on).
  std::string services;
  EXPECT_EQ(ListServicesByReflection(address, &services).error_code(),
            grpc::StatusCode::UNIMPLEMENTED);
  EXPECT_EQ(services.find("glint.v1.GlintService"), std::string::npos);

  // SIGHUP: the new file replaces the old tokens.
  Write(F("tokens"), "gamma-token-789\n");
  ASSERT_EQ(kill(server->pid(), SIGHUP), 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (CallAll(address, "Bearer gamma-token-789") != ok &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(CallAll(address, "Bearer gamma-token-789"), ok);
  EXPECT_EQ(CallAll(address, "Bearer alpha-token-123"), denied);
  // An empty file on SIGHUP keeps the tokens loaded before.
  Write(F("tokens"), "# nothing\n");
  ASSERT_EQ(kill(server->pid(), SIGHUP), 0);
  const auto deadline2 = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (server->Stderr().find("keeping the 1 tokens") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline2) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(CallAll(address, "Bearer gamma-token-789"), ok);

  const std::string log = server->Stderr();
  EXPECT_NE(log.find("SIGHUP: 1 tokens loaded"), std::string::npos) << log;
  for (const char *secret : {"alpha-token", "beta-token", "gamma-token", "wrong-token"}) {
    EXPECT_EQ(log.find(secret), std::string::npos) << "token in the log:\n" << log;
  }
}

// Without tokens: reflection describes the service to tools like grpcurl, and SIGHUP (an ops
// habit: reload, log rotation) has nothing to reload and leaves the server running (its default
// action used to terminate it without a drain).
TEST_F(Security, WithoutTokensReflectionIsOnAndSighupIsHarmless) {
  auto server = Start("open", {});
  ASSERT_NE(server, nullptr);
  std::string services;
  const grpc::Status listed = ListServicesByReflection(server->address(), &services);
  EXPECT_TRUE(listed.ok()) << listed.error_message();
  EXPECT_NE(services.find("glint.v1.GlintService"), std::string::npos);
  for (int k = 0; k < 3; ++k) ASSERT_EQ(kill(server->pid(), SIGHUP), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(waitpid(server->pid(), nullptr, WNOHANG), 0) << "glintd exited on SIGHUP";
  EXPECT_EQ(Health(server->address()), grpc::health::v1::HealthCheckResponse::SERVING);
  EXPECT_TRUE(Capabilities(server->address(), ChannelSecurity{}).ok());
}

TEST_F(Security, EmptyTokenFileIsRefusedAtStart) {
  Write(F("empty_tokens"), "\n# no tokens here\n");
  std::string error;
  auto server = Glintd::Start(GLINTD_PATH, *dir_, "empty",
                              {"--device", "host", "--auth-tokens", F("empty_tokens")}, &error);
  EXPECT_EQ(server, nullptr);
  EXPECT_NE(error.find("--auth-tokens " + F("empty_tokens") + ": no token in the file"),
            std::string::npos)
      << error;
}

// The CLI end to end over TLS + tokens: --tls-ca with --token-file, or GLINT_TOKEN.
TEST_F(Security, CliTakesTlsAndTokenOptions) {
  Write(F("cli_tokens"), "cli-secret\n");
  Write(F("cli_token_file"), "cli-secret\n");
  auto server = Start("cli", {"--tls-cert", F("server.pem"), "--tls-key", F("server.key"),
                              "--auth-tokens", F("cli_tokens")});
  ASSERT_NE(server, nullptr);
  const std::vector<std::string> info = {GLINT_CLI_PATH,    "info",     "--server",
                                         server->address(), "--tls-ca", F("ca.pem"),
                                         "--timeout-ms",    "3000"};
  std::string out;
  unsetenv("GLINT_TOKEN");
  EXPECT_EQ(RunProgram(*dir_, info, &out), 1) << out;
  EXPECT_NE(out.find("UNAUTHENTICATED"), std::string::npos) << out;
  std::vector<std::string> with_file = info;
  with_file.insert(with_file.end(), {"--token-file", F("cli_token_file")});
  EXPECT_EQ(RunProgram(*dir_, with_file, &out), 0) << out;
  setenv("GLINT_TOKEN", "cli-secret", 1);
  EXPECT_EQ(RunProgram(*dir_, info, &out), 0) << out;
  unsetenv("GLINT_TOKEN");
  // And glint load through the same options.
  std::vector<std::string> load = {GLINT_CLI_PATH, "load",      "--server",     server->address(),
                                   "--tls-ca",     F("ca.pem"), "--token-file", F("cli_token_file"),
                                   "--duration",   "0.2",       "--batch",      "8"};
  EXPECT_EQ(RunProgram(*dir_, load, &out), 0) << out;
}

TEST(ExposureWarnings, OnlyBeyondLoopbackAndOnlyWhenSomethingIsMissing) {
  using glint::ExposureWarnings;
  for (const char *loopback :
       {"127.0.0.1:50051", "127.1.2.3:0", "[::1]:50051", "localhost:1", "unix:/tmp/glintd.sock"}) {
    EXPECT_TRUE(ExposureWarnings(loopback, false, false, false).empty()) << loopback;
  }
  const auto none = ExposureWarnings("0.0.0.0:50051", false, false, false);
  ASSERT_EQ(none.size(), 1u);
  EXPECT_NE(none[0].find("without TLS or tokens"), std::string::npos);
  const auto tokens_only = ExposureWarnings("[::]:50051", false, false, true);
  ASSERT_EQ(tokens_only.size(), 1u);
  EXPECT_NE(tokens_only[0].find("clear text"), std::string::npos);
  EXPECT_EQ(ExposureWarnings("10.0.0.5:50051", true, false, false).size(), 1u);
  EXPECT_TRUE(ExposureWarnings("0.0.0.0:50051", true, false, true).empty());
  EXPECT_TRUE(ExposureWarnings("0.0.0.0:50051", true, true, false).empty());
}

}  // namespace
