#include "client/lib/evaluate_series.h"

#include <algorithm>
#include <atomic>
#include <string>
#include <thread>

namespace glint::client {
namespace {

// As in glint_client.cpp: gRPC's default receive limit when the server does not advertise
// one, the response bytes per query (3 packed floats) and room for framing and stats.
constexpr uint64_t kDefaultMessageBytes = 4u << 20;
constexpr size_t kResponseBytesPerQuery = 3 * sizeof(float);
constexpr size_t kEnvelopeBytes = 4096;

}  // namespace

grpc::Status EvaluateSeries(GlintClient &client,
                            const std::vector<glint::v1::EvaluateRequest> &settings,
                            const glint::v1::QueryBatch &queries, const SeriesResultFn &on_result,
                            const ProgressFn &progress, SeriesInfo *info) {
  const uint32_t count = queries.count();
  if (settings.empty()) return grpc::Status::OK;
  if (count == 0) {
    for (size_t k = 0; k < settings.size(); ++k) on_result(k, {});
    if (info) info->delivered = settings.size();
    return grpc::Status::OK;
  }
  glint::v1::Capabilities caps;
  if (grpc::Status status = client.GetCapabilities(&caps); !status.ok()) return status;
  const ClientOptions &options = client.options();
  // The same chunk budget as GlintClient::Evaluate: half the smaller message limit, at most
  // max_chunk_bytes, at most max_batch queries.
  uint64_t limit = caps.max_message_bytes() ? caps.max_message_bytes() : kDefaultMessageBytes;
  limit = std::min<uint64_t>(limit, static_cast<uint64_t>(options.max_message_bytes));
  const uint64_t budget = std::min<uint64_t>(limit / 2, options.max_chunk_bytes);
  uint32_t max_batch = caps.max_batch() ? caps.max_batch() : UINT32_MAX;
  if (options.max_chunk_queries) max_batch = std::min(max_batch, options.max_chunk_queries);
  size_t settings_bytes = 0;
  for (const auto &s : settings) {
    settings_bytes = std::max(settings_bytes, s.ByteSizeLong() - s.queries().ByteSizeLong());
  }
  const size_t overhead = settings_bytes + kEnvelopeBytes;
  if (budget <= overhead) {
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                        "material and lights alone (" + std::to_string(settings_bytes) +
                            " bytes) exceed the chunk size budget of " + std::to_string(budget) +
                            " bytes");
  }
  const size_t per_query = std::max(BytesPerQuery(queries), kResponseBytesPerQuery);
  const auto chunk_queries = static_cast<uint32_t>(
      std::min<uint64_t>(std::max<uint64_t>(1, (budget - overhead) / per_query), max_batch));
  const uint64_t per_setting = (uint64_t{count} + chunk_queries - 1) / chunk_queries;
  const uint64_t chunks = per_setting * settings.size();
  if (info) *info = {chunks, chunk_queries};

  grpc::ClientContext context;
  client.PrepareContext(&context);  // the bearer token, when one is configured
  auto stub = glint::v1::GlintService::NewStub(client.channel());
  auto stream = stub->EvaluateStream(&context);

  // Writer and reader run concurrently (see GlintClient::EvaluateStreamed: a client that only
  // reads after writing everything can deadlock on full flow-control windows). Slices are
  // built lazily, so only the chunks in flight exist at once.
  std::atomic<bool> writer_failed{false};
  std::string writer_error;
  std::thread writer([&] {
    try {
      for (uint64_t k = 0; k < chunks; ++k) {
        const uint64_t setting = k / per_setting;
        const uint64_t local = k % per_setting;
        glint::v1::EvaluateChunk chunk;
        chunk.set_chunk_index(k);
        glint::v1::EvaluateRequest *part = chunk.mutable_request();
        if (local == 0) {
          *part = settings[setting];
          part->clear_queries();
        }
        const auto begin = static_cast<uint32_t>(local * chunk_queries);
        const auto end =
            static_cast<uint32_t>(std::min<uint64_t>(uint64_t{begin} + chunk_queries, count));
        *part->mutable_queries() = SliceQueries(queries, begin, end);
        if (!stream->Write(chunk)) return;  // the call is over; Finish says why
      }
      stream->WritesDone();
    } catch (const std::exception &e) {
      writer_error = e.what();
      writer_failed = true;
      context.TryCancel();
    }
  });

  grpc::Status protocol_error;
  std::vector<float> out(uint64_t{count} * 3);
  uint64_t received = 0;
  uint64_t stream_query = 0;  // the server numbers queries over the whole stream
  glint::v1::EvaluateChunkResult result;
  while (stream->Read(&result)) {
    const uint64_t local = received % per_setting;
    const uint64_t first = local * chunk_queries;
    const uint64_t n = std::min<uint64_t>(chunk_queries, count - first);
    const std::string problem = ChunkResultProblem(result, received, chunks, stream_query, n);
    if (!problem.empty()) {
      protocol_error = grpc::Status(grpc::StatusCode::INTERNAL, problem);
      context.TryCancel();
      break;
    }
    std::copy(result.result().radiance().begin(), result.result().radiance().end(),
              out.begin() + static_cast<std::ptrdiff_t>(first * 3));
    ++received;
    stream_query += n;
    if (progress) progress(stream_query, uint64_t{count} * settings.size());
    if (local + 1 == per_setting) {
      if (info) info->delivered = static_cast<size_t>(received / per_setting);
      on_result(static_cast<size_t>(received / per_setting - 1), std::move(out));
      out.assign(uint64_t{count} * 3, 0.0f);
    }
  }
  if (!protocol_error.ok()) {
    while (stream->Read(&result)) {
    }
  }
  writer.join();
  grpc::Status status = stream->Finish();
  if (writer_failed) return grpc::Status(grpc::StatusCode::INTERNAL, writer_error);
  if (!protocol_error.ok()) return protocol_error;
  if (!status.ok()) return status;
  if (received != chunks) {
    return grpc::Status(grpc::StatusCode::DATA_LOSS, "stream ended after " +
                                                         std::to_string(received) + " of " +
                                                         std::to_string(chunks) + " chunk results");
  }
  return grpc::Status::OK;
}

}  // namespace glint::client
