// glintd end to end: a real server process on a free loopback port, spoken to
// over gRPC. Unary and streamed batches (the stream must be bit-identical to
// unary), every refusal over the wire, and the server still serving after them.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <thread>

#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "test_queries.h"

namespace {

using glint::v1::EvaluateChunk;
using glint::v1::EvaluateChunkResult;
using glint::v1::EvaluateRequest;
using glint::v1::EvaluateResponse;

constexpr uint32_t kMaxBatch = 5000;  // small, so the stream path is exercised

class ServiceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new glint::test::TempDir("glint_service_test");
    std::string error;
    server_ = glint::test::Glintd::Start(GLINTD_PATH, *dir_, "glintd",
                                         {"--max-batch", std::to_string(kMaxBatch)}, &error)
                  .release();
    ASSERT_NE(server_, nullptr) << error;
    const std::string address = server_->address();
    grpc::ChannelArguments args;
    args.SetMaxReceiveMessageSize(64 << 20);
    stub_ = glint::v1::GlintService::NewStub(
        grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
  }
  static void TearDownTestSuite() {
    stub_.reset();
    delete server_;
    delete dir_;
  }

  static EvaluateRequest Request(uint32_t n, uint32_t seed = 1) {
    EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(glint::v1::SMOOTH);
    m->set_ndf(glint::v1::GGX);
    m->set_alpha_x(0.3f);
    m->set_alpha_y(0.1f);
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
    *r.mutable_queries() = glint::test::RandomQueries(n, true, false, seed);
    return r;
  }

  static grpc::Status Unary(const EvaluateRequest &r, EvaluateResponse *out) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    return stub_->Evaluate(&ctx, r, out);
  }

  // Sends `r` as chunks of `chunk` queries; later chunks carry queries only.
  static grpc::Status Stream(const EvaluateRequest &r, uint32_t chunk, std::vector<float> *out,
                             std::vector<EvaluateChunkResult> *results = nullptr) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    auto stream = stub_->EvaluateStream(&ctx);
    // Writes on this thread, reads on another: neither side blocks the other.
    std::thread reader([&] {
      EvaluateChunkResult res;
      while (stream->Read(&res)) {
        out->insert(out->end(), res.result().radiance().begin(), res.result().radiance().end());
        if (results) results->push_back(res);
      }
    });
    const auto &q = r.queries();
    uint64_t index = 0;
    for (uint32_t begin = 0; begin < q.count(); begin += chunk, ++index) {
      uint32_t end = std::min(q.count(), begin + chunk);
      EvaluateChunk c;
      c.set_chunk_index(index);
      if (index == 0) {
        *c.mutable_request() = r;
        c.mutable_request()->clear_queries();
      }
      auto *cq = c.mutable_request()->mutable_queries();
      cq->set_count(end - begin);
      for (uint32_t i = 3 * begin; i < 3 * end; ++i) {
        cq->add_wo(q.wo(int(i)));
        cq->add_wi(q.wi(int(i)));
      }
      if (!stream->Write(c)) break;
    }
    stream->WritesDone();
    reader.join();
    return stream->Finish();
  }

  static glint::test::TempDir *dir_;
  static glint::test::Glintd *server_;
  static std::unique_ptr<glint::v1::GlintService::Stub> stub_;
};
glint::test::TempDir *ServiceTest::dir_ = nullptr;
glint::test::Glintd *ServiceTest::server_ = nullptr;
std::unique_ptr<glint::v1::GlintService::Stub> ServiceTest::stub_;

TEST_F(ServiceTest, CapabilitiesDescribeDeviceAndLimits) {
  grpc::ClientContext ctx;
  glint::v1::Capabilities caps;
  ASSERT_TRUE(stub_->GetCapabilities(&ctx, {}, &caps).ok());
  EXPECT_FALSE(caps.device_name().empty());
  EXPECT_FALSE(caps.device_opencl_version().empty());
  EXPECT_EQ(caps.max_batch(), kMaxBatch);
  EXPECT_EQ(caps.max_message_bytes(), 64ull << 20);
  ASSERT_GE(caps.models_size(), 1);
  EXPECT_EQ(caps.models(0), "SMOOTH");
}

TEST_F(ServiceTest, UnaryReturnsFiniteRadiancePerQuery) {
  EvaluateResponse res;
  grpc::Status s = Unary(Request(1000), &res);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(res.count(), 1000u);
  ASSERT_EQ(res.radiance_size(), 3000);
  int positive = 0;
  for (float v : res.radiance()) {
    ASSERT_TRUE(std::isfinite(v) && v >= 0.0f);
    positive += v > 0.0f;
  }
  EXPECT_GT(positive, 1500);
}

TEST_F(ServiceTest, PolygonLightEndToEnd) {
  EvaluateRequest r = Request(200);
  r.mutable_queries()->clear_wi();  // lit, not a BRDF probe
  auto *p = r.add_lights()->mutable_polygon();
  for (float v : {-2.0f, -2.0f, 3.0f, -2.0f, 2.0f, 3.0f, 2.0f, 2.0f, 3.0f, 2.0f, -2.0f, 3.0f})
    p->add_vertices(v);  // overhead, counter-clockwise seen from below: faces the surface
  for (float v : {1.0f, 1.0f, 1.0f}) p->add_radiance(v);
  EvaluateResponse ltc, ref;
  grpc::Status s = Unary(r, &ltc);
  ASSERT_TRUE(s.ok()) << s.error_message();
  r.set_area_method(glint::v1::REFERENCE);
  s = Unary(r, &ref);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(ltc.radiance_size(), 600);
  ASSERT_EQ(ref.radiance_size(), 600);
  int positive = 0;
  for (int i = 0; i < 600; ++i) {
    ASSERT_TRUE(std::isfinite(ltc.radiance(i)) && ltc.radiance(i) >= 0.0f);
    ASSERT_TRUE(std::isfinite(ref.radiance(i)) && ref.radiance(i) >= 0.0f);
    positive += ref.radiance(i) > 0.0f;
  }
  EXPECT_GT(positive, 300);
  // Unknown methods are refused over the wire.
  r.set_area_method(static_cast<glint::v1::AreaMethod>(9));
  s = Unary(r, &ref);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("area_method: unknown value 9"), std::string::npos);
}

TEST_F(ServiceTest, StreamIsBitIdenticalToUnaryForAnyChunking) {
  EvaluateRequest r = Request(kMaxBatch, 2);
  EvaluateResponse unary;
  ASSERT_TRUE(Unary(r, &unary).ok());
  for (uint32_t chunk : {kMaxBatch, 1000u, 777u, 1u << 12}) {
    std::vector<float> streamed;
    std::vector<EvaluateChunkResult> results;
    grpc::Status s = Stream(r, chunk, &streamed, &results);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_EQ(streamed.size(), size_t(unary.radiance_size()));
    EXPECT_EQ(
        0, std::memcmp(streamed.data(), unary.radiance().data(), streamed.size() * sizeof(float)))
        << "chunk " << chunk;
    for (size_t k = 0; k < results.size(); ++k) {
      EXPECT_EQ(results[k].chunk_index(), k);
      EXPECT_EQ(results[k].first_query(), k * chunk);
    }
  }
}

TEST_F(ServiceTest, BatchLargerThanLimitIsRefusedWithAHintAndStreamsFine) {
  EvaluateRequest r = Request(kMaxBatch + 1, 3);
  EvaluateResponse res;
  grpc::Status s = Unary(r, &res);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("EvaluateStream"), std::string::npos) << s.error_message();
  std::vector<float> streamed;
  ASSERT_TRUE(Stream(r, kMaxBatch, &streamed).ok());
  EXPECT_EQ(streamed.size(), size_t(3 * (kMaxBatch + 1)));
}

TEST_F(ServiceTest, RefusalsOverTheWireNameFieldAndIndex) {
  struct Bad {
    std::function<void(EvaluateRequest &)> mutate;
    const char *field;
  };
  const std::vector<Bad> bad = {
      {[](auto &r) { r.mutable_queries()->set_wo(3 * 17 + 1, std::nanf("")); }, "queries.wo[17]"},
      {[](auto &r) { r.mutable_queries()->set_wi(3 * 5, 3.0f); }, "queries.wi[5]"},
      {[](auto &r) { r.mutable_material()->set_alpha_x(2.0f); }, "material.alpha_x"},
      {[](auto &r) { r.mutable_material()->set_ndf(glint::v1::Ndf(9)); }, "material.ndf"},
      {[](auto &r) { r.mutable_queries()->mutable_wi()->RemoveLast(); }, "queries.wi"},
      {[](auto &r) { r.mutable_queries()->set_count(0); }, "queries.count"},
  };
  for (const Bad &b : bad) {
    EvaluateRequest r = Request(100, 4);
    b.mutate(r);
    EvaluateResponse res;
    grpc::Status s = Unary(r, &res);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << b.field;
    EXPECT_NE(s.error_message().find(b.field), std::string::npos)
        << "'" << s.error_message() << "' lacks " << b.field;
  }
  // A bad query in a later stream chunk is reported with its global index.
  EvaluateRequest r = Request(300, 5);
  r.mutable_queries()->set_wo(3 * 250, std::nanf(""));
  std::vector<float> out;
  grpc::Status s = Stream(r, 100, &out);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("queries.wo[250]"), std::string::npos) << s.error_message();
  EXPECT_EQ(out.size(), 600u);  // the two good chunks were answered

  // And the server still serves.
  EvaluateResponse ok;
  EXPECT_TRUE(Unary(Request(10), &ok).ok());
  EXPECT_TRUE(server_->Alive());
}

TEST_F(ServiceTest, ChunkIndicesMustCountUp) {
  grpc::ClientContext ctx;
  auto stream = stub_->EvaluateStream(&ctx);
  EvaluateChunk c;
  c.set_chunk_index(3);
  *c.mutable_request() = Request(10);
  stream->Write(c);
  stream->WritesDone();
  EvaluateChunkResult res;
  while (stream->Read(&res)) {
  }
  grpc::Status s = stream->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("chunk_index"), std::string::npos) << s.error_message();
}

TEST_F(ServiceTest, ConcurrentClientsAreUnaffectedByABadOne) {
  EvaluateRequest good = Request(2000, 6);
  EvaluateResponse reference;
  ASSERT_TRUE(Unary(good, &reference).ok());
  std::vector<std::thread> clients;
  std::atomic<int> identical{0}, refused{0};
  for (int c = 0; c < 6; ++c) {
    clients.emplace_back([&, c] {
      EvaluateRequest r = good;
      if (c % 2) r.mutable_queries()->set_wi(0, std::nanf(""));
      EvaluateResponse res;
      grpc::Status s = Unary(r, &res);
      if (c % 2) {
        refused += s.error_code() == grpc::StatusCode::INVALID_ARGUMENT;
      } else if (s.ok() && res.radiance_size() == reference.radiance_size() &&
                 std::memcmp(res.radiance().data(), reference.radiance().data(),
                             sizeof(float) * size_t(res.radiance_size())) == 0) {
        ++identical;
      }
    });
  }
  for (auto &t : clients) t.join();
  EXPECT_EQ(identical.load(), 3);
  EXPECT_EQ(refused.load(), 3);
}

}  // namespace
