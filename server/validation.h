// Request validation: every input is checked here before it can reach a
// kernel. Messages name the field path, the first bad query index and what was
// expected, e.g. "queries.wo[17]: (nan, 0, 1) is not finite".
#pragma once

#include <cstdint>

#include "glint/v1/glint.pb.h"
#include "server/query_view.h"
#include "server/status.h"

namespace glint {

struct ValidationLimits {
  uint32_t max_batch = 1u << 20;  // queries per unary call or stream chunk
  uint32_t max_lights = 64;
  bool fp64_available = true;
  // Unit vectors may deviate from length 1 by this much (float data that was
  // normalised in another program); kernels renormalise them.
  double unit_tolerance = 1e-3;
  // Tangent and normal count as parallel when |t . n| exceeds this.
  double max_tangent_normal_cos = 0.999;
  // The gRPC message limit of replies (glintd --max-message-mb; 0 = none): a Sample reply grows
  // with count x samples_per_query, not with its request, so it is checked before the work.
  uint64_t max_message_bytes = 0;
};

// Checks material, lights and precision (the settings of a request or of a
// stream's first chunk).
Status ValidateSettings(const glint::v1::EvaluateRequest &request, const ValidationLimits &limits);

// Checks a query batch against the settings it will run with. Indices in
// messages are offset by `first_query` (a stream chunk's position).
Status ValidateQueries(const glint::v1::QueryBatch &queries, bool has_lights,
                       const ValidationLimits &limits, uint64_t first_query = 0,
                       bool streamed = false);

// ValidateQueries on raw arrays (server/query_view.h; e.g. views into a shared-memory region):
// the same checks and messages, minus the array sizes, which the view's count fixes. Large
// batches are scanned on several threads; a refusal names the first bad query all the same.
Status ValidateQueryView(const QueryView &queries, bool has_lights, const ValidationLimits &limits,
                         uint64_t first_query = 0, bool streamed = false);

// The part of ValidateQueryView that reads no query values: the count, which arrays are present
// (wo; the frame's three arrays all or none) and whether they fit the lights (wi exactly when
// there are none). Same messages. RunShared (server/shm_io.cpp) checks this before it starts
// kernels that run while the values are still being checked.
Status ValidateQueryViewShape(const QueryView &queries, bool has_lights,
                              const ValidationLimits &limits, bool streamed = false);

// Checks what the material's model needs from a batch that passed ValidateQueries (the model's
// validate_queries, server/model.h; e.g. BINOMIAL needs uv and footprint and refuses probes).
Status ValidateQueriesForModel(const glint::v1::QueryBatch &queries,
                               const glint::v1::EvaluateRequest &settings,
                               uint64_t first_query = 0);

}  // namespace glint

namespace glint {

// A stream chunk after the first that carries no material reuses the first chunk's settings, so
// it must carry none of them: lights, precision, seed, area_method or area_samples there would
// be silently ignored, and are refused instead ("request.lights: 2 lights in a chunk without a
// material; ..."). A chunk with a material replaces all settings and is checked by
// ValidateSettings.
Status ValidateLaterChunkSettings(const glint::v1::EvaluateRequest &chunk_request);

}  // namespace glint
