// Shared memory read in place (server/shm_io.h EvaluatesInPlace, server/query_view.h): the
// engine and the validation work on views of the mapped region, the kernels write the output
// region, and a SIGBUS in a watched mapping is survived (server/shm_guard.h WatchMapping).
//  - which calls run in place: float-aligned input, SMOOTH without polygon lights, on the device;
//    a misaligned input offset, polygon lights or another model fall back to a copy;
//  - results are bit-identical to the same queries sent as arrays over TCP, in place (input at
//    offset 0 and at a float-aligned offset that is not 128-byte aligned) and copied (offset 2);
//  - a refusal of bad values in the region names the field and the first bad query index, also
//    when the bad values lie in the part of a large batch scanned by a second thread;
//  - the in-place kernels are safe on any bytes (the reason they may read a region its client can
//    still write): queries of NaN, Inf, huge, denormal and random bit patterns mixed into a batch
//    leave the other queries' results bit-identical to a batch without them;
//  - a region whose object is truncated under the kernels (PoCL's threads fault) is lost, not
//    fatal: the engine returns, the region reads zeros and refuses every later call;
//  - the client library's zero-copy blocks (ShmSession::PrepareInPlace) give the TCP results;
//  - glintd: a client truncating its region mid-call gets a clean refusal, the lost region stays
//    refused, a fresh one works, and the server goes on serving.
#include <fcntl.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <ctime>
#include <random>
#include <thread>

#include "client/lib/glint_client.h"
#include "client/lib/shm_transport.h"
#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/shm_io.h"
#include "server/shm_regions.h"
#include "server/validation.h"
#include "test_queries.h"

namespace {

using glint::client::ShmBuffer;
using glint::v1::EvaluateRequest;
using grpc::StatusCode;

EvaluateRequest Probe(uint32_t n, uint32_t seed, bool framed = true) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  *r.mutable_queries() = glint::test::RandomQueries(n, true, framed, seed);
  return r;
}

void AddPointLight(EvaluateRequest *r) {
  auto *p = r->add_lights()->mutable_point();
  for (float v : {0.5f, 0.5f, 2.0f}) p->add_position(v);
  for (float v : {3.0f, 2.0f, 1.0f}) p->add_intensity(v);
  p->set_radius(0.1f);
}

// Queries without wi, lit by a directional and a point light.
EvaluateRequest Lit(uint32_t n, uint32_t seed) {
  EvaluateRequest r = Probe(n, seed);
  *r.mutable_queries() = glint::test::RandomQueries(n, false, true, seed);
  auto *d = r.add_lights()->mutable_directional();
  for (float v : {0.0f, 0.6f, 0.8f}) d->add_direction(v);
  for (float v : {1.0f, 2.0f, 3.0f}) d->add_irradiance(v);
  AddPointLight(&r);
  return r;
}

EvaluateRequest Quad(uint32_t n, uint32_t seed) {
  EvaluateRequest r = Probe(n, seed);
  *r.mutable_queries() = glint::test::RandomQueries(n, false, false, seed);
  auto *p = r.add_lights()->mutable_polygon();
  for (float v : {-1.0f, -1.0f, 2.0f, 1.0f, -1.0f, 2.0f, 1.0f, 1.0f, 2.0f, -1.0f, 1.0f, 2.0f})
    p->add_vertices(v);
  for (float v : {1.0f, 1.0f, 1.0f}) p->add_radiance(v);
  p->set_two_sided(true);
  return r;
}

std::unique_ptr<ShmBuffer> Buffer(size_t bytes) {
  std::string error;
  auto b = ShmBuffer::Create(bytes, &error);
  EXPECT_TRUE(b) << error;
  return b;
}

// `request`'s queries packed into `buffer` at `in_offset`, the output after them at a multiple
// of 64 bytes: the request to send, naming region `region` for both.
EvaluateRequest SharedRequest(const EvaluateRequest &request, const ShmBuffer &buffer,
                              const std::string &region, uint64_t in_offset, uint64_t *out_offset) {
  EvaluateRequest r = request;
  r.clear_queries();
  auto *io = r.mutable_shared_memory();
  glint::client::PackSharedQueries(request.queries(), 0, request.queries().count(),
                                   buffer.data() + in_offset, io);
  io->set_input_region(region);
  io->set_input_offset(in_offset);
  io->set_output_region(region);
  *out_offset = (in_offset + io->input_byte_size() + 63) / 64 * 64;
  io->set_output_offset(*out_offset);
  return r;
}

size_t RegionBytes(const EvaluateRequest &r, uint64_t in_offset) {
  const uint32_t n = r.queries().count();
  return (in_offset + glint::client::SharedMemoryInputBytes(r.queries(), n) + 63) / 64 * 64 +
         12 * size_t(n);
}

// The byte offset in the packed input (SharedMemoryIo layout) of float `k` of query `i` of
// block `block` (0 uv, 1 footprint, 2 wo, 3 wi, 4 position, 5 normal, 6 tangent) of `q`.
size_t FloatOffset(const glint::v1::QueryBatch &q, int block, uint32_t i, int k) {
  const int per[] = {2, 4, 3, 3, 3, 3, 3};
  const bool present[] = {!q.uv().empty(),     !q.footprint().empty(), true,
                          !q.wi().empty(),     !q.position().empty(),  !q.normal().empty(),
                          !q.tangent().empty()};
  size_t at = 0;
  for (int b = 0; b < block; ++b)
    if (present[b]) at += size_t(q.count()) * per[b] * sizeof(float);
  return at + (size_t(i) * per[block] + k) * sizeof(float);
}

void PutFloat(uint8_t *at, float v) {
  std::memcpy(at, &v, sizeof v);
}

class ShmViewEngine : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    glint::DeviceEngineOptions o;
    o.workers = 1;
    if (const char *d = std::getenv("GLINT_CACHE_DIR")) o.cache_dir = d;
    glint::Status s = glint::DeviceEngine::Create(o, &engine_);
    ASSERT_TRUE(s.ok()) << s.message();
  }
  static void TearDownTestSuite() { engine_.reset(); }
  static std::unique_ptr<glint::DeviceEngine> engine_;
};
std::unique_ptr<glint::DeviceEngine> ShmViewEngine::engine_;

// A region registered with an in-process registry, and the call of `shared` resolved on it.
struct Resolved {
  glint::ShmRegistry registry;
  glint::SharedMemoryCall call;
};

void Resolve(const ShmBuffer &buffer, const EvaluateRequest &shared, Resolved *out) {
  glint::v1::RegisterSharedMemoryRequest reg;
  reg.set_name("io");
  reg.set_key(buffer.key());
  reg.set_byte_size(buffer.size());
  ASSERT_TRUE(out->registry.Register("", reg).ok());
  glint::Status s =
      glint::ResolveSharedMemoryCall(out->registry, "", shared.shared_memory(), &out->call);
  ASSERT_TRUE(s.ok()) << s.message();
}

TEST(ShmInPlacePolicy, AlignedSmoothWithoutPolygonsOnTheDeviceOnly) {
  struct Case {
    EvaluateRequest request;
    uint64_t in_offset;
    bool on_device, want;
  };
  EvaluateRequest kemppinen = Probe(64, 1);
  kemppinen.mutable_material()->set_model(glint::v1::KEMPPINEN);
  const Case cases[] = {{Probe(64, 1), 0, true, true},   {Probe(64, 1), 4, true, true},
                        {Lit(64, 1), 0, true, true},     {Probe(64, 1), 2, true, false},
                        {Probe(64, 1), 0, false, false}, {Quad(64, 1), 0, true, false},
                        {kemppinen, 0, true, false}};
  for (const Case &c : cases) {
    auto buffer = Buffer(RegionBytes(c.request, c.in_offset));
    uint64_t out_offset = 0;
    const EvaluateRequest shared =
        SharedRequest(c.request, *buffer, "io", c.in_offset, &out_offset);
    Resolved r;
    Resolve(*buffer, shared, &r);
    EXPECT_EQ(glint::EvaluatesInPlace(r.call, shared, c.on_device), c.want)
        << "offset " << c.in_offset << " device " << c.on_device << " lights "
        << c.request.lights_size() << " model " << c.request.material().model();
  }
}

// Any bytes in the in-place kernels' inputs change only their own query's result: each query's
// result in a batch where every third query is garbage equals its result in a batch of the
// valid queries alone (and the engine returns OK, without crashing or hanging).
TEST_F(ShmViewEngine, GarbageQueriesLeaveTheOthersBitIdentical) {
  std::mt19937 rng(7);
  const float specials[] = {std::nanf(""), -std::nanf(""), INFINITY, -INFINITY, 3.4e38f,
                            -3.4e38f,      1e-45f,         -1e-40f,  0.0f,      -0.0f};
  auto garbage = [&]() {
    if (rng() % 3 == 0) {
      uint32_t bits = uint32_t(rng());
      float f;
      std::memcpy(&f, &bits, sizeof f);
      return f;
    }
    return specials[rng() % (sizeof specials / sizeof *specials)];
  };
  EvaluateRequest conductor = Probe(1, 1);
  auto *c = conductor.mutable_material()->mutable_conductor();
  for (float v : {0.2f, 0.9f, 1.1f}) c->add_eta(v);
  for (float v : {3.9f, 2.4f, 2.2f}) c->add_k(v);
  EvaluateRequest dielectric = Probe(1, 1);
  dielectric.mutable_material()->mutable_dielectric()->set_ior(1.5f);
  EvaluateRequest fp64 = Probe(1, 1);
  fp64.set_precision(glint::v1::FP64);
  std::vector<EvaluateRequest> settings = {Probe(1, 1), Probe(1, 1, false), Lit(1, 1), conductor,
                                           dielectric};
  if (engine_->info().fp64) settings.push_back(fp64);
  for (const EvaluateRequest &base : settings) {
    const uint32_t n = 3000;
    EvaluateRequest valid = base;
    const bool probe = base.lights_size() == 0;
    const bool framed = base.queries().normal_size() > 0;
    *valid.mutable_queries() = glint::test::RandomQueries(n, probe, framed, 11);
    // The mixed batch: query i is the valid batch's query i when i % 3 != 0, garbage otherwise.
    EvaluateRequest mixed = valid;
    glint::v1::QueryBatch &q = *mixed.mutable_queries();
    for (auto *field : {q.mutable_uv(), q.mutable_footprint(), q.mutable_wo(), q.mutable_wi(),
                        q.mutable_position(), q.mutable_normal(), q.mutable_tangent()}) {
      if (field->empty()) continue;
      const int per = field->size() / int(n);
      for (uint32_t i = 0; i < n; i += 3)
        for (int k = 0; k < per; ++k) field->Set(int(i) * per + k, garbage());
    }
    const glint::EvalPlan plan = glint::MakeEvalPlan(valid, valid.queries());
    std::vector<float> want(size_t(n) * 3), got(size_t(n) * 3);
    glint::Status s = engine_->Evaluate(0, plan, valid.queries(), want.data());
    ASSERT_TRUE(s.ok()) << s.message();
    s = engine_->Evaluate(0, plan, glint::QueryView::Of(q), got.data());
    ASSERT_TRUE(s.ok()) << s.message();
    for (uint32_t i = 0; i < n; ++i) {
      if (i % 3 == 0) continue;
      ASSERT_EQ(std::memcmp(&want[3 * size_t(i)], &got[3 * size_t(i)], 3 * sizeof(float)), 0)
          << plan.spec.Describe() << " query " << i;
    }
  }
}

// The truncation tests' region: 100000 BRDF probes (seed `seed`) in a region of their own,
// resolved and evaluated in place; Truncate() then cuts the object to 0 bytes under it.
struct InPlaceProbes {
  std::unique_ptr<ShmBuffer> buffer;
  EvaluateRequest shared;
  Resolved r;
  glint::QueryView view;
  glint::EvalPlan plan;
  int fd = -1;
  ~InPlaceProbes() {
    if (fd >= 0) close(fd);
  }
};

void PrepareInPlaceProbes(uint32_t seed, InPlaceProbes *p) {
  const EvaluateRequest request = Probe(100000, seed);
  p->buffer = Buffer(RegionBytes(request, 0));
  uint64_t out_offset = 0;
  p->shared = SharedRequest(request, *p->buffer, "io", 0, &out_offset);
  Resolve(*p->buffer, p->shared, &p->r);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_TRUE(glint::EvaluatesInPlace(p->r.call, p->shared, true));
  p->view = glint::SharedQueryView(p->r.call, p->shared.shared_memory());
  glint::v1::QueryBatch shape;  // what the plan needs to know of the queries: probes, normals
  shape.add_wi(0.0f);
  shape.add_normal(0.0f);
  p->plan = glint::MakeEvalPlan(p->shared, shape);
}

// Truncates the region's object to 0 bytes: every later access to its pages faults.
void Truncate(InPlaceProbes *p) {
  p->fd = shm_open(p->buffer->key().c_str(), O_RDWR, 0);
  ASSERT_GE(p->fd, 0);
  ASSERT_EQ(ftruncate(p->fd, 0), 0);
}

// The object truncated to 0 before the kernels run: every access to the region faults, on the
// engine's own threads too. The handler maps zero pages over the region, the engine returns,
// the region is lost and every later range check refuses it.
TEST_F(ShmViewEngine, RegionTruncatedUnderTheKernelsIsLostNotFatal) {
  InPlaceProbes p;
  PrepareInPlaceProbes(3, &p);
  if (HasFatalFailure()) return;
  Truncate(&p);
  if (HasFatalFailure()) return;
  EXPECT_FALSE(p.r.call.in->lost());
  glint::Status s = engine_->Evaluate(0, p.plan, p.view, p.r.call.output);
  EXPECT_TRUE(s.ok()) << s.message();
  EXPECT_TRUE(p.r.call.in->lost());
  EXPECT_EQ(p.view.wo[0], 0.0f);  // zero pages now
  const glint::Status again = p.r.call.in->CheckRange(0, 16, "shared_memory.input_offset");
  EXPECT_EQ(again.code(), glint::Status::Code::kFailedPrecondition);
  EXPECT_NE(again.message().find("lost its pages"), std::string::npos) << again.message();
}

// A SIGBUS handler like the one LLVM (inside PoCL) installs the first time it writes a file:
// SA_RESETHAND, so the action is the default from the moment it is entered until it puts back
// the handler it displaced. It lingers 200 ms before doing so, long enough for the other PoCL
// thread to fault inside that window.
struct sigaction g_displaced;
volatile sig_atomic_t g_foreign_ran = 0;
void LingeringResetHandler(int) {
  g_foreign_ran = 1;
  const timespec linger = {0, 200 * 1000 * 1000};
  nanosleep(&linger, nullptr);
  sigaction(SIGBUS, &g_displaced, nullptr);
}

// The same truncation with such a handler installed over the guard after the region was
// registered (in glintd the engine's first compile can do that). Before, the first faulting
// thread entered it, the second met the default action, and the process died with "Bus error"
// (seen in CI: the engine's device enumeration installed LLVM's handler after an earlier test
// had installed the guard). The engine now puts the guard first again before its kernels run, so
// the foreign handler must never run: that also fails without the fix when only one PoCL thread
// faults (it would then put the guard back itself and the access would be rescued).
TEST_F(ShmViewEngine, RegionTruncatedWithAForeignHandlerInstalledOverTheGuard) {
  InPlaceProbes p;
  PrepareInPlaceProbes(4, &p);
  if (HasFatalFailure()) return;
  struct sigaction foreign {};
  foreign.sa_handler = LingeringResetHandler;
  foreign.sa_flags = SA_RESETHAND | SA_NODEFER;
  sigemptyset(&foreign.sa_mask);
  ASSERT_EQ(sigaction(SIGBUS, &foreign, &g_displaced), 0);
  g_foreign_ran = 0;
  Truncate(&p);
  if (HasFatalFailure()) return;
  const glint::Status s = engine_->Evaluate(0, p.plan, p.view, p.r.call.output);
  EXPECT_TRUE(s.ok()) << s.message();
  EXPECT_TRUE(p.r.call.in->lost());
  EXPECT_EQ(g_foreign_ran, 0) << "a fault reached the handler installed over the guard";
}

class Caller {
 public:
  Caller(const std::string &address)
      : stub_(glint::v1::GlintService::NewStub(
            glint::client::MakeChannel(address, 64 << 20, glint::client::ChannelSecurity{}))) {}
  void Prepare(grpc::ClientContext *c) const {
    c->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  }
  grpc::Status Register(const std::string &name, const ShmBuffer &buffer) const {
    grpc::ClientContext c;
    Prepare(&c);
    glint::v1::RegisterSharedMemoryRequest r;
    r.set_name(name);
    r.set_key(buffer.key());
    r.set_byte_size(buffer.size());
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
  grpc::Status Evaluate(const EvaluateRequest &r, glint::v1::EvaluateResponse *out) const {
    grpc::ClientContext c;
    Prepare(&c);
    return stub_->Evaluate(&c, r, out);
  }

 private:
  std::unique_ptr<glint::v1::GlintService::Stub> stub_;
};

class ShmViewServer : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new glint::test::TempDir("glint_shm_view_test");
    std::string error;
    server_ = glint::test::Glintd::Start(GLINTD_PATH, *dir_, "glintd",
                                         {"--max-request-cost", "1e15"}, &error)
                  .release();
    ASSERT_NE(server_, nullptr) << error;
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }
  static glint::test::TempDir *dir_;
  static glint::test::Glintd *server_;
};
glint::test::TempDir *ShmViewServer::dir_ = nullptr;
glint::test::Glintd *ShmViewServer::server_ = nullptr;

// In place at offsets 0 and 4 (float-aligned, not 128-byte aligned), copied at offset 2, and
// copied for a polygon light: every result bit-identical to the arrays sent over TCP.
TEST_F(ShmViewServer, InPlaceAndCopiedAreBitIdenticalToTcp) {
  Caller caller(server_->address());
  EvaluateRequest no_uv = Probe(5000, 4, false);
  no_uv.mutable_queries()->clear_uv();
  no_uv.mutable_queries()->clear_footprint();
  for (const EvaluateRequest &request : {Probe(20000, 5), no_uv, Lit(7000, 6), Quad(3000, 7)}) {
    glint::v1::EvaluateResponse tcp;
    ASSERT_TRUE(caller.Evaluate(request, &tcp).ok());
    double sum = 0;
    for (float v : tcp.radiance()) sum += v;
    EXPECT_GT(sum, 0.0);  // not trivially zero
    for (uint64_t in_offset : {0, 4, 2}) {
      auto buffer = Buffer(RegionBytes(request, in_offset));
      ASSERT_TRUE(caller.Register("io", *buffer).ok());
      uint64_t out_offset = 0;
      const EvaluateRequest shared = SharedRequest(request, *buffer, "io", in_offset, &out_offset);
      glint::v1::EvaluateResponse response;
      const grpc::Status s = caller.Evaluate(shared, &response);
      ASSERT_TRUE(s.ok()) << s.error_message();
      EXPECT_EQ(std::memcmp(tcp.radiance().data(), buffer->data() + out_offset,
                            size_t(tcp.radiance_size()) * sizeof(float)),
                0)
          << "input offset " << in_offset << ", " << request.lights_size() << " lights";
      ASSERT_TRUE(caller.Unregister("io").ok());
    }
  }
}

// The client library's zero-copy use (ShmSession::PrepareInPlace / EvaluateInPlace): queries
// written straight into the blocks, the radiance read where the kernels wrote it, bit-identical
// to the arrays over TCP; one session serving two shapes in turn.
TEST_F(ShmViewServer, ClientInPlaceBlocksAreBitIdenticalToTcp) {
  glint::client::GlintClient client(server_->address());
  glint::client::ShmSession session(&client);
  for (const EvaluateRequest &request : {Probe(30000, 12), Lit(9000, 13), Probe(100, 14, false)}) {
    std::vector<float> tcp;
    ASSERT_TRUE(client.Evaluate(request, &tcp).ok());
    const glint::v1::QueryBatch &q = request.queries();
    glint::client::ShmSession::InPlaceBlocks blocks;
    grpc::Status s = session.PrepareInPlace(q, q.count(), &blocks);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_EQ(blocks.count, q.count());
    for (auto [block, array] : {std::pair{blocks.uv, &q.uv()},
                                {blocks.footprint, &q.footprint()},
                                {blocks.wo, &q.wo()},
                                {blocks.wi, &q.wi()},
                                {blocks.position, &q.position()},
                                {blocks.normal, &q.normal()},
                                {blocks.tangent, &q.tangent()}}) {
      ASSERT_EQ(block == nullptr, array->empty());
      if (block) std::copy(array->begin(), array->end(), block);
    }
    s = session.EvaluateInPlace(request);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(std::memcmp(tcp.data(), blocks.radiance, tcp.size() * sizeof(float)), 0);
  }
}

// Bad values in the region: the refusal names the field and the first bad query, in place (a
// batch large enough for the scan to run on several threads, the first bad value in the second
// thread's range, a later one too) and copied (offset 2); the server answers the next call.
TEST_F(ShmViewServer, RefusalsNameTheFieldAndTheFirstBadQuery) {
  Caller caller(server_->address());
  const EvaluateRequest request = Probe(300000, 8, false);
  const glint::v1::QueryBatch &q = request.queries();
  struct Bad {
    int block;
    uint32_t index;
    int component;
    float value;
    const char *want;
  };
  const Bad cases[][2] = {
      {{3, 290001, 1, std::nanf(""), ""}, {3, 160007, 2, INFINITY, "queries.wi[160007]"}},
      {{2, 250000, 0, 2.0f, ""}, {2, 17, 0, 2.0f, "queries.wo[17]"}},
      {{1, 299999, 3, -INFINITY, "queries.footprint[299999]"}, {1, 299999, 3, -INFINITY, ""}}};
  for (uint64_t in_offset : {0, 2}) {
    auto buffer = Buffer(RegionBytes(request, in_offset));
    ASSERT_TRUE(caller.Register("bad", *buffer).ok());
    for (const auto &pair : cases) {
      uint64_t out_offset = 0;
      const EvaluateRequest shared = SharedRequest(request, *buffer, "bad", in_offset, &out_offset);
      std::string want;
      for (const Bad &b : pair) {
        PutFloat(buffer->data() + in_offset + FloatOffset(q, b.block, b.index, b.component),
                 b.value);
        if (*b.want) want = b.want;
      }
      glint::v1::EvaluateResponse response;
      const grpc::Status s = caller.Evaluate(shared, &response);
      EXPECT_EQ(s.error_code(), StatusCode::INVALID_ARGUMENT) << s.error_message();
      EXPECT_EQ(s.error_message().rfind(want + ":", 0), 0u)
          << "offset " << in_offset << ": " << s.error_message();
    }
    ASSERT_TRUE(caller.Unregister("bad").ok());
  }
  glint::v1::EvaluateResponse response;
  EXPECT_TRUE(caller.Evaluate(Probe(10, 9), &response).ok());
}

// A client truncating its region while its call runs (a lit batch long enough for the
// truncation to land in it): a clean refusal, the region refused from then on, a fresh region
// works, and the server goes on serving.
TEST_F(ShmViewServer, TruncationMidCallIsRefusedAndTheRegionStaysRefused) {
  Caller caller(server_->address());
  // ~170 ms on two idle cores (400000 queries x 41 lights took 44 ms: a truncation at 40 ms
  // could land after the call), truncated after 10 ms: either the call's fstat sees the
  // truncation or its reads and writes do.
  EvaluateRequest slow = Lit(1000000, 10);
  for (int i = 0; i < 62; ++i) AddPointLight(&slow);
  auto buffer = Buffer(RegionBytes(slow, 0));
  ASSERT_TRUE(caller.Register("slow", *buffer).ok());
  uint64_t out_offset = 0;
  const EvaluateRequest shared = SharedRequest(slow, *buffer, "slow", 0, &out_offset);
  const int fd = shm_open(buffer->key().c_str(), O_RDWR, 0);
  ASSERT_GE(fd, 0);
  std::thread truncate([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_EQ(ftruncate(fd, 0), 0);
  });
  glint::v1::EvaluateResponse response;
  const auto t0 = std::chrono::steady_clock::now();
  const grpc::Status s = caller.Evaluate(shared, &response);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  truncate.join();
  // A refusal either way: the fstat at the start of the call ("truncated since registration")
  // when the truncation came first, else the lost pages seen by the validation or the kernels.
  ASSERT_FALSE(s.ok()) << "the call finished in " << ms << " ms, before the truncation";
  EXPECT_EQ(s.error_code(), StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_TRUE(s.error_message().find("lost its pages") != std::string::npos ||
              s.error_message().find("truncated since registration") != std::string::npos)
      << s.error_message();
  std::printf("truncated mid-call after %.0f ms: %s\n", ms, s.error_message().c_str());
  // The object grown back: the region still refuses (its mapping shows zero pages now, or the
  // fstat sees it; either way not the client's bytes silently).
  ASSERT_EQ(ftruncate(fd, off_t(buffer->size())), 0);
  const grpc::Status again = caller.Evaluate(shared, &response);
  if (s.error_message().find("lost its pages") != std::string::npos) {
    EXPECT_EQ(again.error_code(), StatusCode::FAILED_PRECONDITION) << again.error_message();
    EXPECT_NE(again.error_message().find("lost its pages in an earlier call"), std::string::npos)
        << again.error_message();
  }
  close(fd);
  ASSERT_TRUE(caller.Unregister("slow").ok());
  // A fresh region works, with the right answer.
  const EvaluateRequest small = Probe(1000, 11);
  auto fresh = Buffer(RegionBytes(small, 0));
  ASSERT_TRUE(caller.Register("fresh", *fresh).ok());
  const EvaluateRequest shared_small = SharedRequest(small, *fresh, "fresh", 0, &out_offset);
  ASSERT_TRUE(caller.Evaluate(shared_small, &response).ok());
  glint::v1::EvaluateResponse arrays;
  ASSERT_TRUE(caller.Evaluate(small, &arrays).ok());
  EXPECT_EQ(std::memcmp(arrays.radiance().data(), fresh->data() + out_offset,
                        size_t(arrays.radiance_size()) * sizeof(float)),
            0);
  ASSERT_TRUE(caller.Unregister("fresh").ok());
  EXPECT_TRUE(server_->Alive());
}

}  // namespace
