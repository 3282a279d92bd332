// GlintClient against an in-process fake GlintService: transport choice (unary vs stream),
// chunk protocol (indices, material only on the first chunk, limits), result assembly,
// error propagation, health waiting. The fake shades each query with a fixed function of the
// query's own data, so correct reassembly is checkable value by value.
#include "client/lib/glint_client.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/reflection.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace glint::client {
namespace {

using glint::v1::EvaluateChunk;
using glint::v1::EvaluateChunkResult;
using glint::v1::EvaluateRequest;
using glint::v1::QueryBatch;

// Radiance of query i of `q`: depends on the query's data and the request settings only (not
// on its index or chunk), like the real server's determinism contract.
void Shade(const EvaluateRequest &settings, const QueryBatch &q, uint32_t i, float out[3]) {
  auto at = [&](const google::protobuf::RepeatedField<float> &a, int comps, int c) {
    return a.empty() ? 0.0f : a.Get(static_cast<int>(i) * comps + c);
  };
  out[0] = at(q.wo(), 3, 2) * settings.material().alpha_x() + at(q.uv(), 2, 0);
  out[1] = at(q.wi(), 3, 0) + at(q.footprint(), 4, 3) + static_cast<float>(settings.seed());
  out[2] = at(q.uv(), 2, 1) - at(q.wo(), 3, 0) + static_cast<float>(settings.lights_size());
}

class FakeGlint final : public glint::v1::GlintService::Service {
 public:
  uint32_t max_batch = 1 << 20;
  uint64_t max_message_bytes = 64u << 20;
  // Misbehaviours, for the client's checks.
  int fail_at_chunk = -1;          // answer INVALID_ARGUMENT when this chunk arrives
  bool wrong_first_query = false;  // report first_query off by one from chunk 1 on
  bool drop_last_result = false;   // finish OK without answering the last chunk

  std::atomic<int> capability_calls{0};
  std::atomic<int> unary_calls{0};
  std::atomic<int> stream_calls{0};
  std::mutex mu;
  std::vector<uint32_t> chunk_counts;    // queries per received chunk
  std::vector<size_t> chunk_bytes;       // serialized size per received chunk
  std::vector<std::string> violations;   // protocol rules the client broke
  EvaluateRequest first_chunk_settings;  // the first chunk's request without its queries

  grpc::Status GetCapabilities(grpc::ServerContext *, const glint::v1::GetCapabilitiesRequest *,
                               glint::v1::Capabilities *caps) override {
    ++capability_calls;
    caps->set_max_batch(max_batch);
    caps->set_max_message_bytes(max_message_bytes);
    caps->set_device_name("fake");
    return grpc::Status::OK;
  }

  grpc::Status Evaluate(grpc::ServerContext *, const EvaluateRequest *request,
                        glint::v1::EvaluateResponse *response) override {
    ++unary_calls;
    if (request->queries().count() > max_batch) {
      return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "batch over max_batch");
    }
    ShadeAll(*request, request->queries(), response);
    response->mutable_stats()->set_device("fake-unary");
    return grpc::Status::OK;
  }

  grpc::Status EvaluateStream(
      grpc::ServerContext *,
      grpc::ServerReaderWriter<EvaluateChunkResult, EvaluateChunk> *stream) override {
    ++stream_calls;
    EvaluateChunk chunk;
    EvaluateRequest settings;
    uint64_t expected_index = 0;
    uint64_t first_query = 0;
    std::vector<EvaluateChunkResult> held;
    while (stream->Read(&chunk)) {
      {
        std::lock_guard<std::mutex> lock(mu);
        chunk_counts.push_back(chunk.request().queries().count());
        chunk_bytes.push_back(chunk.ByteSizeLong());
        if (chunk.chunk_index() != expected_index) violations.push_back("chunk_index out of order");
        if (expected_index == 0 && !chunk.request().has_material()) {
          violations.push_back("first chunk without material");
        }
        if (expected_index > 0 && (chunk.request().has_material() ||
                                   chunk.request().lights_size() > 0 || chunk.request().seed())) {
          violations.push_back("later chunk repeats settings");
        }
        if (chunk.request().queries().count() > max_batch)
          violations.push_back("chunk > max_batch");
        if (chunk.ByteSizeLong() > max_message_bytes) violations.push_back("chunk > max message");
      }
      if (static_cast<int>(expected_index) == fail_at_chunk) {
        return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                            "queries.wo[" + std::to_string(first_query) + "] is not unit length");
      }
      if (expected_index == 0) {
        settings = chunk.request();
        std::lock_guard<std::mutex> lock(mu);
        first_chunk_settings = settings;
        first_chunk_settings.clear_queries();
      }
      EvaluateChunkResult result;
      result.set_chunk_index(chunk.chunk_index());
      result.set_first_query(first_query + (wrong_first_query && expected_index > 0 ? 1 : 0));
      ShadeAll(settings, chunk.request().queries(), result.mutable_result());
      result.mutable_result()->mutable_stats()->set_device("fake-stream");
      first_query += chunk.request().queries().count();
      ++expected_index;
      // Answer each chunk as soon as it is read (like a pipelined server): a client that does
      // not read while it writes would stall on flow control here.
      if (drop_last_result) {
        held.push_back(std::move(result));
        continue;
      }
      if (!stream->Write(result)) break;
    }
    if (drop_last_result) {
      for (size_t i = 0; i + 1 < held.size(); ++i) stream->Write(held[i]);
    }
    return grpc::Status::OK;
  }

 private:
  static void ShadeAll(const EvaluateRequest &settings, const QueryBatch &q,
                       glint::v1::EvaluateResponse *response) {
    response->set_count(q.count());
    auto *radiance = response->mutable_radiance();
    radiance->Resize(static_cast<int>(q.count()) * 3, 0.0f);
    for (uint32_t i = 0; i < q.count(); ++i)
      Shade(settings, q, i, radiance->mutable_data() + 3 * i);
  }
};

class FakeServer {
 public:
  FakeServer() {
    grpc::EnableDefaultHealthCheckService(true);
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.SetMaxReceiveMessageSize(64 << 20);
    builder.SetMaxSendMessageSize(64 << 20);
    builder.RegisterService(&service);
    server_ = builder.BuildAndStart();
  }
  ~FakeServer() { server_->Shutdown(std::chrono::system_clock::now()); }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  grpc::Server *server() { return server_.get(); }

  FakeGlint service;

 private:
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

// A batch with uv, footprint, wo, wi (no frame), values distinct per query.
EvaluateRequest MakeRequest(uint32_t count) {
  EvaluateRequest request;
  request.mutable_material()->set_model(glint::v1::SMOOTH);
  request.mutable_material()->set_alpha_x(0.5f);
  request.set_seed(7);
  QueryBatch *q = request.mutable_queries();
  q->set_count(count);
  for (uint32_t i = 0; i < count; ++i) {
    const auto f = static_cast<float>(i);
    q->add_uv(f * 0.25f);
    q->add_uv(-f);
    for (int c = 0; c < 4; ++c) q->add_footprint(f * 0.001f + static_cast<float>(c));
    q->add_wo(f * 1e-6f);
    q->add_wo(0.0f);
    q->add_wo(1.0f - f * 1e-7f);
    q->add_wi(f * 3.0f);
    q->add_wi(0.0f);
    q->add_wi(1.0f);
  }
  return request;
}

std::vector<float> Expected(const EvaluateRequest &request) {
  std::vector<float> out(request.queries().count() * 3);
  for (uint32_t i = 0; i < request.queries().count(); ++i) {
    Shade(request, request.queries(), i, out.data() + 3 * i);
  }
  return out;
}

bool BitEqual(const std::vector<float> &a, const std::vector<float> &b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// ---- SliceQueries ---------------------------------------------------------------------------

TEST(SliceQueries, CutsEveryArrayByItsComponentCount) {
  QueryBatch batch = MakeRequest(5).queries();
  for (int i = 0; i < 15; ++i) {
    batch.add_position(static_cast<float>(100 + i));
    batch.add_normal(static_cast<float>(200 + i));
    batch.add_tangent(static_cast<float>(300 + i));
  }
  const QueryBatch s = SliceQueries(batch, 1, 4);
  EXPECT_EQ(s.count(), 3u);
  ASSERT_EQ(s.uv_size(), 6);
  EXPECT_EQ(s.uv(0), batch.uv(2));
  EXPECT_EQ(s.uv(5), batch.uv(7));
  ASSERT_EQ(s.footprint_size(), 12);
  EXPECT_EQ(s.footprint(0), batch.footprint(4));
  EXPECT_EQ(s.footprint(11), batch.footprint(15));
  ASSERT_EQ(s.wo_size(), 9);
  EXPECT_EQ(s.wo(0), batch.wo(3));
  ASSERT_EQ(s.position_size(), 9);
  EXPECT_EQ(s.position(0), 103.0f);
  EXPECT_EQ(s.normal(8), 211.0f);
  EXPECT_EQ(s.tangent(4), 307.0f);
}

TEST(SliceQueries, EmptyArraysStayEmptyAndEmptyRangesWork) {
  QueryBatch batch;
  batch.set_count(4);
  for (int i = 0; i < 12; ++i) batch.add_wo(static_cast<float>(i));
  const QueryBatch s = SliceQueries(batch, 2, 4);
  EXPECT_EQ(s.wo_size(), 6);
  EXPECT_EQ(s.wo(0), 6.0f);
  EXPECT_TRUE(s.uv().empty());
  EXPECT_TRUE(s.wi().empty());
  EXPECT_TRUE(s.position().empty());
  const QueryBatch none = SliceQueries(batch, 4, 4);
  EXPECT_EQ(none.count(), 0u);
  EXPECT_EQ(none.wo_size(), 0);
}

TEST(SliceQueries, RejectsBadRangesAndMalformedArrays) {
  QueryBatch batch = MakeRequest(3).queries();
  EXPECT_THROW(SliceQueries(batch, 2, 1), std::out_of_range);
  EXPECT_THROW(SliceQueries(batch, 0, 4), std::out_of_range);
  batch.add_wi(1.0f);  // 10 floats for 3 queries
  EXPECT_THROW(SliceQueries(batch, 0, 1), std::invalid_argument);
}

// Guards against a field added to QueryBatch but forgotten by SliceQueries (which would drop
// it from streamed batches): fill every repeated float field through reflection and check
// that each one survives slicing, whatever its name.
TEST(SliceQueries, HandlesEveryRepeatedFloatFieldOfQueryBatch) {
  const auto *descriptor = QueryBatch::descriptor();
  const auto *reflection = QueryBatch::GetReflection();
  QueryBatch batch;
  const uint32_t count = 4;
  batch.set_count(count);
  int repeated_fields = 0;
  for (int f = 0; f < descriptor->field_count(); ++f) {
    const auto *field = descriptor->field(f);
    if (!field->is_repeated()) continue;
    ASSERT_EQ(field->cpp_type(), google::protobuf::FieldDescriptor::CPPTYPE_FLOAT) << field->name();
    ++repeated_fields;
  }
  EXPECT_EQ(repeated_fields, 7) << "QueryBatch changed: update SliceQueries and this test";
  // Components per field, as documented in glint.proto.
  const std::map<std::string, int> components = {{"uv", 2},     {"footprint", 4}, {"wo", 3},
                                                 {"wi", 3},     {"position", 3},  {"normal", 3},
                                                 {"tangent", 3}};
  for (int f = 0; f < descriptor->field_count(); ++f) {
    const auto *field = descriptor->field(f);
    if (!field->is_repeated()) continue;
    ASSERT_TRUE(components.count(field->name())) << "unknown array " << field->name();
    const int n = components.at(field->name()) * static_cast<int>(count);
    for (int i = 0; i < n; ++i)
      reflection->AddFloat(&batch, field, static_cast<float>(f * 100 + i));
  }
  const QueryBatch s = SliceQueries(batch, 1, 3);
  for (int f = 0; f < descriptor->field_count(); ++f) {
    const auto *field = descriptor->field(f);
    if (!field->is_repeated()) continue;
    const int comps = components.at(field->name());
    ASSERT_EQ(reflection->FieldSize(s, field), 2 * comps) << field->name();
    for (int i = 0; i < 2 * comps; ++i) {
      EXPECT_EQ(reflection->GetRepeatedFloat(s, field, i),
                reflection->GetRepeatedFloat(batch, field, comps + i))
          << field->name() << "[" << i << "]";
    }
  }
}

// glint sample's calls: count x K within max_batch, and the request (settings + each query's
// arrays) and the reply (7 floats per sample) within half the smaller of the server's and the
// client's message limit, checked here against the message sizes protobuf itself computes.
TEST(SampleQueriesPerCall, BothMessagesFitHalfTheSmallerLimit) {
  auto sizes = [](uint32_t n, uint32_t k, bool frame) {
    glint::v1::SampleRequest request;
    request.mutable_material()->set_model(glint::v1::SMOOTH);
    request.mutable_material()->set_alpha_x(0.3f);
    request.mutable_material()->mutable_schlick()->add_f0(0.9f);
    request.set_samples_per_query(k);
    QueryBatch *q = request.mutable_queries();
    q->set_count(n);
    for (uint32_t i = 0; i < n; ++i) {
      for (float v : {0.5f, 0.5f}) q->add_uv(v);
      for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) q->add_footprint(v);
      for (float v : {0.0f, 0.6f, 0.8f}) q->add_wo(v);
      if (frame) {
        for (float v : {1.0f, 2.0f, 3.0f}) q->add_position(v);
        for (float v : {0.0f, 0.0f, 1.0f}) q->add_normal(v);
        for (float v : {1.0f, 0.0f, 0.0f}) q->add_tangent(v);
      }
    }
    glint::v1::SampleResponse reply;
    reply.set_count(n);
    reply.set_samples_per_query(k);
    for (uint64_t j = 0; j < uint64_t(n) * k; ++j) {
      for (float v : {0.1f, 0.2f, 0.97f}) reply.add_wi(v);
      reply.add_pdf(1.5f);
      for (float v : {0.3f, 0.3f, 0.3f}) reply.add_weight(v);
    }
    reply.mutable_stats()->set_device("a device name of some length, as PoCL reports");
    return std::pair<size_t, size_t>{request.ByteSizeLong(), reply.ByteSizeLong()};
  };
  for (uint32_t server_mb : {1u, 64u}) {
    for (uint32_t k : {1u, 64u}) {
      for (bool frame : {false, true}) {
        glint::v1::Capabilities caps;
        caps.set_max_batch(1u << 20);
        caps.set_max_message_bytes(uint64_t{server_mb} << 20);
        glint::v1::SampleRequest settings;
        settings.mutable_material()->set_model(glint::v1::SMOOTH);
        settings.mutable_material()->set_alpha_x(0.3f);
        settings.mutable_material()->mutable_schlick()->add_f0(0.9f);
        settings.set_samples_per_query(k);
        const size_t query_bytes = frame ? 72 : 36;
        const uint32_t count = 4u << 20;
        const uint32_t n =
            SampleQueriesPerCall(caps, 64 << 20, k, query_bytes, settings.ByteSizeLong(), count);
        SCOPED_TRACE("server " + std::to_string(server_mb) + " MiB, K " + std::to_string(k) +
                     (frame ? ", frame" : ""));
        EXPECT_LE(uint64_t(n) * k, caps.max_batch());
        const auto [request, reply] = sizes(n, k, frame);
        const uint64_t half = caps.max_message_bytes() / 2;
        EXPECT_LE(request, half);
        EXPECT_LE(reply, half);
        // Not needlessly small: one more query per call would pass a bound by at most a few
        // percent, or the batch limit caps it.
        const auto [request1, reply1] = sizes(n + n / 16 + 1, k, frame);
        EXPECT_TRUE(request1 > half || reply1 > half ||
                    uint64_t(n + n / 16 + 1) * k > caps.max_batch());
      }
    }
  }
  glint::v1::Capabilities none;  // a server that reports no limits: gRPC's 4 MiB default
  EXPECT_LE(uint64_t(SampleQueriesPerCall(none, 64 << 20, 8, 36, 100, 1u << 30)) * 8 * 28,
            uint64_t{2} << 20);
  EXPECT_EQ(SampleQueriesPerCall(none, 64 << 20, 65536, 72, 100, 10), 1u);  // never 0
  EXPECT_EQ(SampleQueriesPerCall(none, 64 << 20, 1, 36, 100, 3), 3u);
}

TEST(StatusNames, CodesAreSpelledAsInTheSpec) {
  EXPECT_STREQ(StatusCodeName(grpc::StatusCode::INVALID_ARGUMENT), "INVALID_ARGUMENT");
  EXPECT_STREQ(StatusCodeName(grpc::StatusCode::RESOURCE_EXHAUSTED), "RESOURCE_EXHAUSTED");
  EXPECT_EQ(FormatStatus(grpc::Status(grpc::StatusCode::UNAVAILABLE, "down")), "UNAVAILABLE: down");
}

// ---- Evaluate against the fake server -------------------------------------------------------

TEST(GlintClient, SmallBatchGoesUnary) {
  FakeServer server;
  GlintClient client(server.address());
  const EvaluateRequest request = MakeRequest(100);
  std::vector<float> rgb;
  EvaluateInfo info;
  std::vector<uint64_t> progress;
  ASSERT_TRUE(client
                  .Evaluate(
                      request, &rgb, [&](uint64_t d, uint64_t) { progress.push_back(d); }, &info)
                  .ok());
  EXPECT_FALSE(info.streamed);
  EXPECT_EQ(info.device, "fake-unary");
  EXPECT_EQ(server.service.unary_calls, 1);
  EXPECT_EQ(server.service.stream_calls, 0);
  EXPECT_TRUE(BitEqual(rgb, Expected(request)));
  EXPECT_EQ(progress, (std::vector<uint64_t>{100}));
}

TEST(GlintClient, OverMaxBatchStreamsInOrderedChunksAndMatchesUnary) {
  FakeServer small;
  small.service.max_batch = 1000;
  FakeServer big;
  const EvaluateRequest request = MakeRequest(25500);

  GlintClient streamed_client(small.address());
  std::vector<float> streamed;
  EvaluateInfo info;
  std::vector<std::pair<uint64_t, uint64_t>> progress;
  const grpc::Status status = streamed_client.Evaluate(
      request, &streamed, [&](uint64_t d, uint64_t t) { progress.emplace_back(d, t); }, &info);
  ASSERT_TRUE(status.ok()) << FormatStatus(status);
  EXPECT_TRUE(info.streamed);
  EXPECT_EQ(info.chunks, 26u);
  EXPECT_EQ(info.chunk_queries, 1000u);
  EXPECT_EQ(info.device, "fake-stream");
  EXPECT_EQ(small.service.unary_calls, 0);
  EXPECT_EQ(small.service.stream_calls, 1);
  EXPECT_TRUE(small.service.violations.empty()) << small.service.violations.front();
  ASSERT_EQ(small.service.chunk_counts.size(), 26u);
  EXPECT_EQ(small.service.chunk_counts.back(), 500u);
  for (size_t k = 0; k + 1 < 26; ++k) EXPECT_EQ(small.service.chunk_counts[k], 1000u);
  ASSERT_EQ(progress.size(), 26u);
  EXPECT_EQ(progress.front(), std::make_pair(uint64_t{1000}, uint64_t{25500}));
  EXPECT_EQ(progress.back(), std::make_pair(uint64_t{25500}, uint64_t{25500}));

  GlintClient unary_client(big.address());
  std::vector<float> unary;
  ASSERT_TRUE(unary_client.Evaluate(request, &unary).ok());
  EXPECT_EQ(big.service.unary_calls, 1);
  EXPECT_TRUE(BitEqual(streamed, unary));
  EXPECT_TRUE(BitEqual(streamed, Expected(request)));
}

// Every setting of the request reaches the server in the first chunk: a streamed batch must be
// evaluated exactly as the unary call would (area method and samples included).
TEST(GlintClient, FirstChunkCarriesEverySetting) {
  FakeServer server;
  server.service.max_batch = 100;
  EvaluateRequest request = MakeRequest(250);
  request.add_lights()->mutable_polygon()->add_radiance(1.0f);
  request.set_precision(glint::v1::FP64);
  request.set_seed(99);
  request.set_area_method(glint::v1::MONTE_CARLO);
  request.set_area_samples(32);
  GlintClient client(server.address());
  std::vector<float> rgb;
  EvaluateInfo info;
  ASSERT_TRUE(client.Evaluate(request, &rgb, {}, &info).ok());
  ASSERT_TRUE(info.streamed);
  EvaluateRequest expected = request;
  expected.clear_queries();
  EXPECT_EQ(server.service.first_chunk_settings.DebugString(), expected.DebugString());
}

TEST(GlintClient, ChunksStayUnderTheByteBudget) {
  FakeServer server;  // max_batch large: only bytes force the split
  ClientOptions options;
  options.max_chunk_bytes = 256 << 10;
  GlintClient client(server.address(), options);
  const EvaluateRequest request = MakeRequest(60000);  // ~2.9 MB of queries
  std::vector<float> rgb;
  EvaluateInfo info;
  ASSERT_TRUE(client.Evaluate(request, &rgb, {}, &info).ok());
  EXPECT_TRUE(info.streamed);
  EXPECT_GT(info.chunks, 10u);
  for (size_t bytes : server.service.chunk_bytes) EXPECT_LE(bytes, size_t{256} << 10);
  EXPECT_TRUE(BitEqual(rgb, Expected(request)));
}

TEST(GlintClient, ServerMessageLimitForcesStreaming) {
  FakeServer server;
  server.service.max_message_bytes = 1 << 20;  // a server with a 1 MiB limit
  GlintClient client(server.address());
  const EvaluateRequest request = MakeRequest(40000);  // ~1.9 MB: too big for one message
  std::vector<float> rgb;
  EvaluateInfo info;
  ASSERT_TRUE(client.Evaluate(request, &rgb, {}, &info).ok());
  EXPECT_TRUE(info.streamed);
  EXPECT_TRUE(server.service.violations.empty()) << server.service.violations.front();
  for (size_t bytes : server.service.chunk_bytes) EXPECT_LE(bytes, size_t{1} << 19);
  EXPECT_TRUE(BitEqual(rgb, Expected(request)));
}

// Many small chunks with both directions busy: deadlocks if the client does not read while
// writing (ctest's timeout catches a hang).
TEST(GlintClient, LongStreamDoesNotStallOnFlowControl) {
  FakeServer server;
  server.service.max_batch = 500;
  GlintClient client(server.address());
  const EvaluateRequest request = MakeRequest(200000);
  std::vector<float> rgb;
  EvaluateInfo info;
  ASSERT_TRUE(client.Evaluate(request, &rgb, {}, &info).ok());
  EXPECT_EQ(info.chunks, 400u);
  EXPECT_TRUE(BitEqual(rgb, Expected(request)));
}

TEST(GlintClient, CapabilitiesAreFetchedOnce) {
  FakeServer server;
  GlintClient client(server.address());
  std::vector<float> rgb;
  ASSERT_TRUE(client.Evaluate(MakeRequest(10), &rgb).ok());
  ASSERT_TRUE(client.Evaluate(MakeRequest(20), &rgb).ok());
  EXPECT_EQ(server.service.capability_calls, 1);
  EXPECT_EQ(rgb.size(), 60u);
}

TEST(GlintClient, ServerErrorMidStreamIsReturned) {
  FakeServer server;
  server.service.max_batch = 100;
  server.service.fail_at_chunk = 3;
  GlintClient client(server.address());
  std::vector<float> rgb = {42.0f};
  // 1000 chunks: the client is still writing (and may be blocked on flow control) when the
  // server gives up; the writer must be released rather than hang.
  const grpc::Status status = client.Evaluate(MakeRequest(100000), &rgb);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "queries.wo[300] is not unit length");
  EXPECT_EQ(rgb, (std::vector<float>{42.0f})) << "output must be untouched on failure";
}

TEST(GlintClient, WrongFirstQueryIsDetected) {
  FakeServer server;
  server.service.max_batch = 100;
  server.service.wrong_first_query = true;
  GlintClient client(server.address());
  std::vector<float> rgb;
  const grpc::Status status = client.Evaluate(MakeRequest(1000), &rgb);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_NE(status.error_message().find("first_query"), std::string::npos)
      << status.error_message();
}

TEST(GlintClient, MissingChunkResultIsDataLoss) {
  FakeServer server;
  server.service.max_batch = 100;
  server.service.drop_last_result = true;
  GlintClient client(server.address());
  std::vector<float> rgb;
  const grpc::Status status = client.Evaluate(MakeRequest(1000), &rgb);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DATA_LOSS) << FormatStatus(status);
  EXPECT_NE(status.error_message().find("9 of 10"), std::string::npos) << status.error_message();
}

TEST(GlintClient, MalformedArraysInAStreamedBatchAreRefusedLocally) {
  FakeServer server;
  server.service.max_batch = 100;
  GlintClient client(server.address());
  EvaluateRequest request = MakeRequest(1000);
  request.mutable_queries()->add_uv(1.0f);
  std::vector<float> rgb;
  const grpc::Status status = client.Evaluate(request, &rgb);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("queries.uv"), std::string::npos) << status.error_message();
  EXPECT_EQ(server.service.stream_calls, 0);
}

TEST(GlintClient, UnreachableServerIsUnavailable) {
  FakeServer server;
  const std::string address = server.address();
  server.server()->Shutdown(std::chrono::system_clock::now());
  ClientOptions options;
  options.rpc_timeout = std::chrono::milliseconds(2000);
  GlintClient client(address, options);
  glint::v1::Capabilities caps;
  const grpc::Status status = client.GetCapabilities(&caps);
  EXPECT_FALSE(status.ok());
  std::vector<float> rgb;
  EXPECT_FALSE(client.Evaluate(MakeRequest(3), &rgb).ok());
}

// ---- Health ---------------------------------------------------------------------------------

// WaitUntilServing is checked by what it returns and says, not by how long it took (a loaded
// machine makes wall-clock bounds flaky). "not SERVING after N ms: <last answer>" is the only
// message of the exit at its timeout (the early exit, a server without grpc.health.v1, says
// "does not implement"), so it shows the call kept checking until its timeout; the last answer
// shows what it saw. A call that never returned would be caught by the test's ctest TIMEOUT.

TEST(GlintClient, WaitUntilServingSeesServingAndNotServing) {
  FakeServer server;
  GlintClient client(server.address());
  std::string why;
  EXPECT_TRUE(client.WaitUntilServing(std::chrono::milliseconds(3000), &why)) << why;

  server.server()->GetHealthCheckService()->SetServingStatus(false);
  EXPECT_FALSE(client.WaitUntilServing(std::chrono::milliseconds(500), &why));
  EXPECT_EQ(why, "not SERVING after 500 ms: health status NOT_SERVING");
}

TEST(GlintClient, WaitUntilServingGivesUpOnADeadAddress) {
  // A loopback port bound and held but never listening: connections to it are refused for the
  // whole test. (A port learnt from a server and then closed could be taken meanwhile by a
  // server of another test running at the same time.)
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr *>(&addr), sizeof addr), 0);
  ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr *>(&addr), &len), 0);
  struct Close {
    int fd;
    ~Close() { close(fd); }
  } close_fd{fd};
  const int port = ntohs(addr.sin_port);
  GlintClient client("127.0.0.1:" + std::to_string(port));
  std::string why;
  EXPECT_FALSE(client.WaitUntilServing(std::chrono::milliseconds(400), &why));
  EXPECT_EQ(why.rfind("not SERVING after 400 ms: ", 0), 0u) << why;
  EXPECT_NE(why.find("UNAVAILABLE"), std::string::npos) << why;
}

}  // namespace
}  // namespace glint::client
