// Same-host shared memory (glint.proto SharedMemoryIo, server/shm_regions.h, client/lib/
// shm_transport.h) and unix-domain sockets, against real glintd processes on this host:
//  - every refusal of a bad region (name, key, offset, size, unknown region, another token's
//    region, a region used after unregistering, the per-owner limits) is a clean status naming
//    the field, and the server goes on serving;
//  - results read back from the output region are bit-identical to the same queries sent as
//    arrays (every input block present, lights and probes, several calls per batch, the client
//    library's pipelined pieces of any size, an output window over the input window);
//  - a client that unlinks its object mid-session, truncates it before a call, or truncates it
//    while the call runs gets a clean answer and the server survives;
//  - the SIGBUS guard itself (server/shm_guard.h) on a truncated mapping;
//  - glintd --listen unix:PATH serves Evaluate, and `--transport auto` picks shared memory there.
#include <fcntl.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <thread>

#include "client/lib/glint_client.h"
#include "client/lib/shm_transport.h"
#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "server/shm_guard.h"
#include "test_queries.h"

namespace {

using glint::client::ShmBuffer;
using glint::v1::EvaluateRequest;
using grpc::StatusCode;

constexpr const char *kAlpha = "Bearer alpha-token";
constexpr const char *kBeta = "Bearer beta-token";

EvaluateRequest Probe(uint32_t n, uint32_t seed) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  *r.mutable_queries() = glint::test::RandomQueries(n, true, true, seed);
  return r;
}

// Queries without wi, lit by a directional and a point light (the light path's blocks).
EvaluateRequest Lit(uint32_t n, uint32_t seed) {
  EvaluateRequest r = Probe(n, seed);
  *r.mutable_queries() = glint::test::RandomQueries(n, false, true, seed);
  auto *d = r.add_lights()->mutable_directional();
  for (float v : {0.0f, 0.6f, 0.8f}) d->add_direction(v);
  for (float v : {1.0f, 2.0f, 3.0f}) d->add_irradiance(v);
  auto *p = r.add_lights()->mutable_point();
  for (float v : {0.5f, 0.5f, 2.0f}) p->add_position(v);
  for (float v : {3.0f, 2.0f, 1.0f}) p->add_intensity(v);
  return r;
}

class Caller {
 public:
  Caller(const std::string &address, std::string authorization)
      : stub_(glint::v1::GlintService::NewStub(
            glint::client::MakeChannel(address, 64 << 20, glint::client::ChannelSecurity{}))),
        authorization_(std::move(authorization)) {}

  void Prepare(grpc::ClientContext *c) const {
    if (!authorization_.empty()) c->AddMetadata("authorization", authorization_);
    c->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  }
  grpc::Status Register(const std::string &name, const std::string &key, uint64_t offset,
                        uint64_t bytes) const {
    grpc::ClientContext c;
    Prepare(&c);
    glint::v1::RegisterSharedMemoryRequest r;
    r.set_name(name);
    r.set_key(key);
    r.set_offset(offset);
    r.set_byte_size(bytes);
    glint::v1::RegisterSharedMemoryResponse out;
    return stub_->RegisterSharedMemory(&c, r, &out);
  }
  grpc::Status Unregister(const std::string &name) const {
    grpc::ClientContext c;
    Prepare(&c);
    glint::v1::UnregisterSharedMemoryRequest r;
    r.set_name(name);
    glint::v1::UnregisterSharedMemoryResponse out;
    return stub_->UnregisterSharedMemory(&c, r, &out);
  }
  std::vector<std::string> List() const {
    grpc::ClientContext c;
    Prepare(&c);
    glint::v1::ListSharedMemoryResponse out;
    EXPECT_TRUE(stub_->ListSharedMemory(&c, {}, &out).ok());
    std::vector<std::string> names;
    for (const auto &r : out.regions()) names.push_back(r.name());
    return names;
  }
  grpc::Status Evaluate(const EvaluateRequest &r, glint::v1::EvaluateResponse *out) const {
    grpc::ClientContext c;
    Prepare(&c);
    return stub_->Evaluate(&c, r, out);
  }
  glint::v1::Capabilities Capabilities() const {
    grpc::ClientContext c;
    Prepare(&c);
    glint::v1::Capabilities caps;
    EXPECT_TRUE(stub_->GetCapabilities(&c, {}, &caps).ok());
    return caps;
  }

 private:
  std::unique_ptr<glint::v1::GlintService::Stub> stub_;
  std::string authorization_;
};

// `request`'s queries packed into `buffer` at 0, output right after: the request to send.
EvaluateRequest SharedRequest(const EvaluateRequest &request, const ShmBuffer &buffer,
                              const std::string &region, uint64_t *out_offset) {
  EvaluateRequest r = request;
  r.clear_queries();
  auto *io = r.mutable_shared_memory();
  glint::client::PackSharedQueries(request.queries(), 0, request.queries().count(), buffer.data(),
                                   io);
  io->set_input_region(region);
  io->set_output_region(region);
  *out_offset = (io->input_byte_size() + 63) / 64 * 64;
  io->set_output_offset(*out_offset);
  return r;
}

size_t RegionBytes(const EvaluateRequest &r) {
  const uint32_t n = r.queries().count();
  return (glint::client::SharedMemoryInputBytes(r.queries(), n) + 63) / 64 * 64 + 12 * size_t(n);
}

class ShmTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new glint::test::TempDir("glint_shm_test");
    {
      std::ofstream tokens(dir_->File("tokens"));
      tokens << "alpha-token\nbeta-token\n";
    }
    std::string error;
    server_ = glint::test::Glintd::Start(GLINTD_PATH, *dir_, "glintd",
                                         {"--auth-tokens", dir_->File("tokens"),
                                          "--max-shm-regions", "3", "--max-shm-mb", "64"},
                                         &error)
                  .release();
    ASSERT_NE(server_, nullptr) << error;
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }
  static std::unique_ptr<ShmBuffer> Buffer(size_t bytes) {
    std::string error;
    auto b = ShmBuffer::Create(bytes, &error);
    EXPECT_TRUE(b) << error;
    return b;
  }

  static glint::test::TempDir *dir_;
  static glint::test::Glintd *server_;
};
glint::test::TempDir *ShmTest::dir_ = nullptr;
glint::test::Glintd *ShmTest::server_ = nullptr;

#define EXPECT_REFUSED(call, code, text)                                               \
  do {                                                                                 \
    const grpc::Status s_ = (call);                                                    \
    EXPECT_EQ(s_.error_code(), code) << s_.error_message();                            \
    EXPECT_NE(s_.error_message().find(text), std::string::npos) << s_.error_message(); \
  } while (0)

TEST_F(ShmTest, RegistrationRefusalsNameTheField) {
  Caller alpha(server_->address(), kAlpha);
  auto buffer = Buffer(4096);
  const std::string key = buffer->key();
  EXPECT_REFUSED(alpha.Register("", key, 0, 16), StatusCode::INVALID_ARGUMENT, "name");
  EXPECT_REFUSED(alpha.Register("a/b", key, 0, 16), StatusCode::INVALID_ARGUMENT, "name");
  EXPECT_REFUSED(alpha.Register(std::string(65, 'x'), key, 0, 16), StatusCode::INVALID_ARGUMENT,
                 "name");
  EXPECT_REFUSED(alpha.Register("r", key.substr(1), 0, 16), StatusCode::INVALID_ARGUMENT,
                 "key: \"" + key.substr(1) + "\" must start with '/'");
  EXPECT_REFUSED(alpha.Register("r", "/dev/shm" + key, 0, 16), StatusCode::INVALID_ARGUMENT,
                 "has a '/' after the first character");
  EXPECT_REFUSED(alpha.Register("r", "/" + std::string(255, 'k'), 0, 16),
                 StatusCode::INVALID_ARGUMENT, "key");
  EXPECT_REFUSED(alpha.Register("r", key + "-missing", 0, 16), StatusCode::NOT_FOUND, "key");
  EXPECT_REFUSED(alpha.Register("r", key, 4096, 16), StatusCode::INVALID_ARGUMENT, "offset");
  EXPECT_REFUSED(alpha.Register("r", key, 4000, 97), StatusCode::INVALID_ARGUMENT, "byte_size");
  EXPECT_REFUSED(alpha.Register("r", key, 0, 0), StatusCode::INVALID_ARGUMENT, "byte_size");
  EXPECT_REFUSED(alpha.Register("r", key, 0, uint64_t(65) << 20), StatusCode::RESOURCE_EXHAUSTED,
                 "--max-shm-mb");
  // A window at an unaligned offset is fine (mapped from its page).
  ASSERT_TRUE(alpha.Register("r", key, 4000, 96).ok());
  EXPECT_REFUSED(alpha.Register("r", key, 0, 16), StatusCode::INVALID_ARGUMENT, "already");
  ASSERT_TRUE(alpha.Register("r2", key, 0, 16).ok());
  ASSERT_TRUE(alpha.Register("r3", key, 0, 16).ok());
  EXPECT_REFUSED(alpha.Register("r4", key, 0, 16), StatusCode::RESOURCE_EXHAUSTED,
                 "--max-shm-regions");
  EXPECT_EQ(alpha.List(), (std::vector<std::string>{"r", "r2", "r3"}));
  EXPECT_REFUSED(alpha.Unregister("nope"), StatusCode::NOT_FOUND, "nope");
  ASSERT_TRUE(alpha.Unregister("").ok());  // all of alpha's
  EXPECT_TRUE(alpha.List().empty());
  // Without a token every shared-memory RPC is refused like every other glint.v1 call.
  Caller anonymous(server_->address(), "");
  EXPECT_EQ(anonymous.Register("r", key, 0, 16).error_code(), StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(anonymous.Unregister("").error_code(), StatusCode::UNAUTHENTICATED);
  const auto caps = alpha.Capabilities();
  EXPECT_EQ(caps.max_shared_memory_regions(), 3u);
  EXPECT_EQ(caps.max_shared_memory_bytes(), uint64_t(64) << 20);
}

TEST_F(ShmTest, EvaluateRefusalsAndOwnership) {
  Caller alpha(server_->address(), kAlpha);
  Caller beta(server_->address(), kBeta);
  const EvaluateRequest request = Probe(1000, 3);
  auto buffer = Buffer(RegionBytes(request));
  ASSERT_TRUE(alpha.Register("io", buffer->key(), 0, buffer->size()).ok());
  uint64_t out_offset = 0;
  const EvaluateRequest shared = SharedRequest(request, *buffer, "io", &out_offset);
  glint::v1::EvaluateResponse response;
  ASSERT_TRUE(alpha.Evaluate(shared, &response).ok());
  EXPECT_EQ(response.count(), 1000u);
  EXPECT_EQ(response.radiance_size(), 0);  // the radiance is in the region

  // Beta cannot see, use or unregister alpha's region; the same name is free for beta.
  EXPECT_TRUE(beta.List().empty());
  EXPECT_REFUSED(beta.Evaluate(shared, &response), StatusCode::NOT_FOUND,
                 "shared_memory.input_region: no region \"io\"");
  EXPECT_REFUSED(beta.Unregister("io"), StatusCode::NOT_FOUND, "io");
  EXPECT_EQ(alpha.List(), std::vector<std::string>{"io"});

  auto with = [&](auto edit) {
    EvaluateRequest r = shared;
    edit(r.mutable_shared_memory());
    return alpha.Evaluate(r, &response);
  };
  using Io = glint::v1::SharedMemoryIo;
  EXPECT_REFUSED(with([](Io *io) { io->set_input_region("other"); }), StatusCode::NOT_FOUND,
                 "shared_memory.input_region");
  EXPECT_REFUSED(with([](Io *io) { io->set_output_region("bad/name"); }),
                 StatusCode::INVALID_ARGUMENT, "shared_memory.output_region");
  EXPECT_REFUSED(with([](Io *io) { io->set_input_byte_size(io->input_byte_size() - 4); }),
                 StatusCode::INVALID_ARGUMENT, "shared_memory.input_byte_size");
  EXPECT_REFUSED(with([](Io *io) { io->set_wi(false); }), StatusCode::INVALID_ARGUMENT,
                 "shared_memory.input_byte_size");  // the layout no longer adds up
  EXPECT_REFUSED(with([&](Io *io) { io->set_input_offset(buffer->size() - 100); }),
                 StatusCode::INVALID_ARGUMENT, "shared_memory.input_offset");
  EXPECT_REFUSED(with([&](Io *io) { io->set_output_offset(buffer->size() - 11996); }),
                 StatusCode::INVALID_ARGUMENT, "shared_memory.output_offset");
  EXPECT_REFUSED(with([&](Io *io) { io->set_output_offset(out_offset + 2); }),
                 StatusCode::INVALID_ARGUMENT, "shared_memory.output_offset");
  EXPECT_REFUSED(with([](Io *io) { io->set_count(0); }), StatusCode::INVALID_ARGUMENT,
                 "shared_memory.count");
  {
    EvaluateRequest both = shared;
    *both.mutable_queries() = request.queries();
    EXPECT_REFUSED(alpha.Evaluate(both, &response), StatusCode::INVALID_ARGUMENT, "queries");
  }
  // A non-unit wo inside the region: the same validation as the array path, same message.
  {
    float bad[3] = {0.0f, 0.0f, 2.0f};
    // wo is the third block (after uv and footprint); query 17.
    const size_t wo = size_t(1000) * (2 + 4) * 4;
    std::vector<uint8_t> saved(buffer->data() + wo + 17 * 12, buffer->data() + wo + 18 * 12);
    std::memcpy(buffer->data() + wo + 17 * 12, bad, sizeof bad);
    EXPECT_REFUSED(alpha.Evaluate(shared, &response), StatusCode::INVALID_ARGUMENT,
                   "queries.wo[17]");
    std::memcpy(buffer->data() + wo + 17 * 12, saved.data(), saved.size());
  }
  // Unregistered, then used: refused; registered again, served again.
  ASSERT_TRUE(alpha.Unregister("io").ok());
  EXPECT_REFUSED(alpha.Evaluate(shared, &response), StatusCode::NOT_FOUND, "no region \"io\"");
  ASSERT_TRUE(alpha.Register("io", buffer->key(), 0, buffer->size()).ok());
  EXPECT_TRUE(alpha.Evaluate(shared, &response).ok());
  ASSERT_TRUE(alpha.Unregister("").ok());
}

// Bit-identical to arrays: probes with a world frame (blocks uv, footprint, wo, wi, position,
// normal, tangent) and lit queries (no wi), through the client library's session.
TEST_F(ShmTest, BitIdenticalToArrays) {
  glint::client::ClientOptions options;
  options.security.token = "alpha-token";
  glint::client::GlintClient client(server_->address(), options);
  for (const EvaluateRequest &request : {Probe(20000, 5), Lit(7000, 6)}) {
    std::vector<float> tcp, shm;
    ASSERT_TRUE(client.Evaluate(request, &tcp).ok());
    glint::client::ShmSession session(&client);
    ASSERT_TRUE(session.Evaluate(request, &shm).ok());
    ASSERT_EQ(tcp.size(), shm.size());
    EXPECT_EQ(std::memcmp(tcp.data(), shm.data(), tcp.size() * sizeof(float)), 0);
    // Sanity: the result is not trivially zero.
    double sum = 0;
    for (float v : shm) sum += v;
    EXPECT_GT(sum, 0.0);
  }
}

// An output window over the input window (one region, the radiance written over the queries it
// came from, or shifted by one float into them) is accepted and gives the bits of the same
// queries sent as arrays: glintd copies the queries out of the region before writing any
// radiance instead of reading them in place (server/shm_io.h EvaluatesInPlace). Read in place,
// the 4-byte shift evaluated ~19% of the queries from other queries' radiance (session 9).
// SMOOTH probes on the device are the in-place shape; the lit batch is copied anyway.
TEST_F(ShmTest, OverlappingWindowsGiveTheArrayResults) {
  Caller alpha(server_->address(), kAlpha);
  for (const EvaluateRequest &request : {Probe(20000, 8), Lit(7000, 9)}) {
    const uint32_t n = request.queries().count();
    const uint64_t in_bytes = glint::client::SharedMemoryInputBytes(request.queries(), n);
    glint::v1::EvaluateResponse arrays;
    ASSERT_TRUE(alpha.Evaluate(request, &arrays).ok());
    double sum = 0;
    for (float v : arrays.radiance()) sum += v;
    EXPECT_GT(sum, 0.0) << "an all-zero result compares nothing";
    // Output at the input's start (over uv and footprint, which SMOOTH does not read), one
    // float into the wo block (what the session 9 probe did), and straddling the input's end
    // (the frame's blocks, or wo's for the lit batch).
    const uint64_t wo =
        4 * uint64_t(request.queries().uv_size() + request.queries().footprint_size());
    for (const uint64_t out : {uint64_t{0}, wo + 4, in_bytes - 6 * uint64_t{n}}) {
      SCOPED_TRACE("output at " + std::to_string(out) + " of " + std::to_string(in_bytes));
      auto buffer = Buffer(std::max(in_bytes, out + 12 * uint64_t{n}));
      ASSERT_TRUE(alpha.Register("overlap", buffer->key(), 0, buffer->size()).ok());
      uint64_t unused = 0;
      EvaluateRequest shared = SharedRequest(request, *buffer, "overlap", &unused);
      shared.mutable_shared_memory()->set_output_offset(out);
      glint::v1::EvaluateResponse response;
      const grpc::Status s = alpha.Evaluate(shared, &response);
      ASSERT_TRUE(s.ok()) << s.error_message();
      EXPECT_EQ(std::memcmp(buffer->data() + out, arrays.radiance().data(), 12 * size_t(n)), 0);
      ASSERT_TRUE(alpha.Unregister("overlap").ok());
    }
  }
}

// One session reused by requests with different arrays: a request with more arrays per query
// than the one that sized the region must still find its output inside the region (the
// benchmark met "output_offset ... lie beyond region" when the session kept the larger chunk).
TEST_F(ShmTest, ReusedSessionFitsRequestsWithMoreArrays) {
  glint::client::ClientOptions options;
  options.security.token = "alpha-token";
  glint::client::GlintClient client(server_->address(), options);
  glint::client::ShmSession session(&client);
  for (const EvaluateRequest &request : {Lit(20000, 6), Probe(15000, 5), Lit(3000, 7)}) {
    std::vector<float> tcp, shm;
    ASSERT_TRUE(client.Evaluate(request, &tcp).ok());
    const grpc::Status s = session.Evaluate(request, &shm);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_EQ(tcp.size(), shm.size());
    EXPECT_EQ(std::memcmp(tcp.data(), shm.data(), tcp.size() * sizeof(float)), 0);
  }
}

// ShmSession::Evaluate cut into pipelined pieces (two slots of the region in flight, packed
// and read out while the other evaluates): every piece size gives the bits of the array path
// (queries sent over the connection, no region), the progress callback sees each piece's end
// in order, a piece glintd refuses names its range of the batch (glintd counts indices from the
// piece's first query), and the session evaluates again afterwards.
TEST_F(ShmTest, PipelinedPiecesMatchArraysAndNameARefusedRange) {
  glint::client::ClientOptions options;
  options.security.token = "alpha-token";
  glint::client::GlintClient client(server_->address(), options);
  for (const EvaluateRequest &request : {Probe(20011, 12), Lit(9001, 13)}) {
    const uint32_t n = request.queries().count();
    std::vector<float> tcp;
    ASSERT_TRUE(client.Evaluate(request, &tcp).ok());
    for (uint32_t piece : {4096u, 7000u, glint::client::ShmSession::kDefaultPieceQueries}) {
      glint::client::ShmSession session(&client);
      session.set_piece_queries(piece);
      std::vector<float> shm;
      std::vector<uint64_t> ends;
      glint::client::EvaluateInfo info;
      const grpc::Status s = session.Evaluate(
          request, &shm, [&](uint64_t done, uint64_t) { ends.push_back(done); }, &info);
      ASSERT_TRUE(s.ok()) << s.error_message();
      std::vector<uint64_t> want;
      for (uint64_t end = piece; want.empty() || want.back() < n; end += piece)
        want.push_back(std::min<uint64_t>(end, n));
      EXPECT_EQ(ends, want) << "pieces of " << piece;
      EXPECT_EQ(info.chunks, want.size());
      ASSERT_EQ(tcp.size(), shm.size());
      EXPECT_EQ(std::memcmp(tcp.data(), shm.data(), tcp.size() * sizeof(float)), 0)
          << "pieces of " << piece;
    }
  }
  // Query 15000 lies in the fourth piece of 4096, [12288, 16384), at index 2712 of it.
  EvaluateRequest bad = Probe(20011, 14);
  bad.mutable_queries()->mutable_wo()->Set(3 * 15000 + 1, std::nanf(""));
  glint::client::ShmSession session(&client);
  session.set_piece_queries(4096);
  std::vector<float> shm;
  const grpc::Status refused = session.Evaluate(bad, &shm);
  EXPECT_REFUSED(refused, StatusCode::INVALID_ARGUMENT,
                 "shared-memory call for queries [12288, 16384) of the batch: queries.wo[2712]");
  const EvaluateRequest good = Probe(20011, 12);
  std::vector<float> tcp;
  ASSERT_TRUE(client.Evaluate(good, &tcp).ok());
  ASSERT_TRUE(session.Evaluate(good, &shm).ok());
  ASSERT_EQ(tcp.size(), shm.size());
  EXPECT_EQ(std::memcmp(tcp.data(), shm.data(), tcp.size() * sizeof(float)), 0);
}

TEST_F(ShmTest, ClientThatUnlinksOrTruncatesDoesNotHurtTheServer) {
  Caller alpha(server_->address(), kAlpha);
  glint::v1::EvaluateResponse response;
  // Unlinked after registration: the server's mapping keeps the object alive; the call works.
  {
    const EvaluateRequest request = Probe(2000, 7);
    auto buffer = Buffer(RegionBytes(request));
    ASSERT_TRUE(alpha.Register("gone", buffer->key(), 0, buffer->size()).ok());
    uint64_t out_offset = 0;
    const EvaluateRequest shared = SharedRequest(request, *buffer, "gone", &out_offset);
    ASSERT_EQ(shm_unlink(buffer->key().c_str()), 0);
    ASSERT_TRUE(alpha.Evaluate(shared, &response).ok());
    glint::v1::EvaluateResponse arrays;
    ASSERT_TRUE(alpha.Evaluate(request, &arrays).ok());
    EXPECT_EQ(std::memcmp(arrays.radiance().data(), buffer->data() + out_offset,
                          size_t(arrays.radiance_size()) * 4),
              0);
    ASSERT_TRUE(alpha.Unregister("gone").ok());
  }
  // Truncated before the call: the fstat at call time refuses it.
  {
    const EvaluateRequest request = Probe(2000, 8);
    auto buffer = Buffer(RegionBytes(request));
    ASSERT_TRUE(alpha.Register("short", buffer->key(), 0, buffer->size()).ok());
    uint64_t out_offset = 0;
    const EvaluateRequest shared = SharedRequest(request, *buffer, "short", &out_offset);
    const int fd = shm_open(buffer->key().c_str(), O_RDWR, 0);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(ftruncate(fd, 4096), 0);
    EXPECT_REFUSED(alpha.Evaluate(shared, &response), StatusCode::INVALID_ARGUMENT,
                   "truncated since registration");
    // Truncated while the call runs (a slow lit batch; the truncation lands during the
    // kernels): the guarded copy into the region fails cleanly, or the call had finished.
    ASSERT_EQ(ftruncate(fd, off_t(buffer->size())), 0);
    EvaluateRequest slow = Lit(200000, 9);
    for (int i = 0; i < 30; ++i) *slow.add_lights() = slow.lights(1);
    auto big = Buffer(RegionBytes(slow));
    ASSERT_TRUE(alpha.Register("slow", big->key(), 0, big->size()).ok());
    const EvaluateRequest shared_slow = SharedRequest(slow, *big, "slow", &out_offset);
    const int big_fd = shm_open(big->key().c_str(), O_RDWR, 0);
    ASSERT_GE(big_fd, 0);
    std::thread truncate([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(150));
      EXPECT_EQ(ftruncate(big_fd, 0), 0);
    });
    const grpc::Status s = alpha.Evaluate(shared_slow, &response);
    truncate.join();
    EXPECT_TRUE(s.ok() || s.error_code() == StatusCode::INVALID_ARGUMENT) << s.error_message();
    if (!s.ok()) {
      EXPECT_TRUE(s.error_message().find("truncated") != std::string::npos ||
                  s.error_message().find("lost pages") != std::string::npos)
          << s.error_message();
    }
    std::printf("truncated mid-call: %s\n",
                s.ok() ? "OK (finished first)" : s.error_message().c_str());
    close(fd);
    close(big_fd);
    ASSERT_TRUE(alpha.Unregister("").ok());
  }
  // Still serving, with the right answer.
  EXPECT_TRUE(server_->Alive());
  ASSERT_TRUE(alpha.Evaluate(Probe(100, 10), &response).ok());
  EXPECT_EQ(response.radiance_size(), 300);
}

// The SIGBUS guard on its own: a mapping whose object was truncated to 0 faults on every page;
// the guarded copies report it in both directions and the process goes on.
TEST(ShmGuard, CopyFromAndToATruncatedMappingFailsCleanly) {
  std::string error;
  auto buffer = ShmBuffer::Create(1 << 16, &error);
  ASSERT_TRUE(buffer) << error;
  std::vector<uint8_t> local(1 << 16, 7);
  EXPECT_TRUE(glint::GuardedCopy(buffer->data(), local.data(), local.size()));
  EXPECT_TRUE(glint::GuardedCopy(local.data(), buffer->data(), local.size()));
  const int fd = shm_open(buffer->key().c_str(), O_RDWR, 0);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(ftruncate(fd, 0), 0);
  EXPECT_FALSE(glint::GuardedCopy(local.data(), buffer->data(), local.size()));
  EXPECT_FALSE(glint::GuardedCopy(buffer->data(), local.data(), local.size()));
  // Restored: copies work again (the handler stays installed and the signal unblocked).
  ASSERT_EQ(ftruncate(fd, 1 << 16), 0);
  EXPECT_TRUE(glint::GuardedCopy(buffer->data(), local.data(), local.size()));
  close(fd);
}

TEST(ShmTransport, SameHostAddresses) {
  using glint::client::IsSameHostAddress;
  for (const char *a : {"127.0.0.1:50051", "localhost:1", "[::1]:50051", "ipv4:127.0.0.1:5",
                        "dns:///localhost:50051", "unix:/tmp/g.sock", "unix-abstract:glint"})
    EXPECT_TRUE(IsSameHostAddress(a)) << a;
  for (const char *a : {"10.0.0.1:50051", "glint.example:50051", "ipv4:127.0.0.1:1,127.0.0.1:2",
                        "[2001:db8::1]:50051"})
    EXPECT_FALSE(IsSameHostAddress(a)) << a;
  EXPECT_THROW(glint::client::ParseTransport("udp"), std::invalid_argument);
}

// glintd on a unix-domain socket (no tokens, --shm-direct-output, small max_batch so one batch
// takes several shared-memory calls): arrays and auto (= shared memory here) agree bit for bit.
TEST(UnixSocket, EvaluatesOverArraysAndSharedMemory) {
  glint::test::TempDir dir("glint_unix_test");
  const std::string address = "unix:" + dir.File("glintd.sock");
  std::string error;
  auto server = glint::test::Glintd::Launch(
      GLINTD_PATH, dir, "glintd", 0,
      {"--listen", address, "--max-batch", "5000", "--shm-direct-output"});
  ASSERT_TRUE(server->WaitUntilServing(&error)) << error;
  glint::client::GlintClient client(address);
  const EvaluateRequest request = Probe(12000, 11);
  std::vector<float> tcp, shm;
  glint::client::EvaluateInfo info;
  std::string used;
  ASSERT_TRUE(glint::client::EvaluateWithTransport(client, glint::client::Transport::kTcp, request,
                                                   &tcp, {}, &info, &used)
                  .ok());
  EXPECT_EQ(used, "tcp");
  ASSERT_TRUE(glint::client::EvaluateWithTransport(client, glint::client::Transport::kAuto, request,
                                                   &shm, {}, &info, &used)
                  .ok());
  EXPECT_EQ(used, "shm");
  EXPECT_EQ(info.chunks, 3u);  // 12000 queries in calls of max_batch 5000
  ASSERT_EQ(tcp.size(), shm.size());
  EXPECT_EQ(std::memcmp(tcp.data(), shm.data(), tcp.size() * sizeof(float)), 0);
  // The session unregistered its region when done.
  Caller anyone(address, "");
  EXPECT_TRUE(anyone.List().empty());
}

}  // namespace
