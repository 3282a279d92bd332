// One query batch evaluated under several settings (materials, lights, ...) over ONE
// EvaluateStream: the batch is cut into chunks once per setting, and the first chunk of each
// setting carries that setting's material, lights, precision, seed and area method, which the
// server keeps for the chunks that follow (glint.proto, EvaluateChunk). This is what batch
// material previews need: one connection, one stream, the scene's queries built once, and each
// material's result handed over as soon as its last chunk is back.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "client/lib/glint_client.h"

namespace glint::client {

// Called on the calling thread with the index of a setting and its radiance (3 floats per
// query, query order) as soon as all its chunks are back, in order of the settings.
using SeriesResultFn = std::function<void(size_t setting, std::vector<float> &&radiance)>;

struct SeriesInfo {
  uint64_t chunks = 0;         // chunks over the whole stream
  uint32_t chunk_queries = 0;  // queries per chunk (the last of each setting may be smaller)
  // Settings whose results on_result received, also when the series failed: the server answers
  // every chunk before a refused one, so a refusal of a chunk is a refusal of setting
  // `delivered` (glint preview skips it and goes on with the next ones).
  size_t delivered = 0;
};

// `settings[k]` holds everything of an EvaluateRequest but the queries (its `queries` field is
// ignored). Each setting's results are bit-identical to client.Evaluate of that setting with
// `queries` (the server's determinism contract; chunking does not change results). `progress`
// counts queries over all settings (total = settings.size() * queries.count()). Stops at the
// first error: an INVALID_ARGUMENT for setting k arrives after on_result was called for the
// settings before k (info->delivered == k).
grpc::Status EvaluateSeries(GlintClient &client,
                            const std::vector<glint::v1::EvaluateRequest> &settings,
                            const glint::v1::QueryBatch &queries, const SeriesResultFn &on_result,
                            const ProgressFn &progress = {}, SeriesInfo *info = nullptr);

}  // namespace glint::client
