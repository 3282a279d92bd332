// The Sample RPC without gRPC: checks a glint.v1.SampleRequest and runs the material model's
// sample pass (server/model.h ModelSampler) on the device engine or the host path. The service
// handler (server/sample_service.cpp) and the tests call these.
#pragma once

#include <cstdint>

#include "glint/v1/glint.pb.h"
#include "server/device_engine.h"
#include "server/sliced_eval.h"
#include "server/status.h"
#include "server/validation.h"

namespace glint {

// At most this many samples per query (SampleRequest.samples_per_query).
constexpr uint32_t kMaxSamplesPerQuery = 65536;

// Bytes of a SampleResponse per sample: wi (3 floats), pdf (1), weight (3), packed.
constexpr uint64_t kSampleReplyBytesPerSample = 28;
// A bound on everything else in a SampleResponse: count, samples_per_query, the three packed
// fields' tags and lengths, and stats (two doubles, batch_requests and the device name: tens of
// bytes for PoCL's; sample_test checks a 512-byte one).
constexpr uint64_t kSampleReplyOverheadBytes = 1024;

// Checks everything a sample request carries: the material (as Evaluate does, plus: the model
// has a sampler), samples_per_query in [1, kMaxSamplesPerQuery], count * K <= max_batch, the
// reply within limits.max_message_bytes (count * K * kSampleReplyBytesPerSample +
// kSampleReplyOverheadBytes), the queries (as Evaluate's, no `wi`, the model's own needs). On
// success `settings` holds the request as an EvaluateRequest without queries (for MakeEvalPlan).
// The part of ValidateSampleRequest that needs no query data (material, sampler,
// samples_per_query, count * K): what the handler checks on gRPC's thread before admission.
Status ValidateSampleSettings(const glint::v1::SampleRequest &request,
                              const ValidationLimits &limits, glint::v1::EvaluateRequest *settings);

Status ValidateSampleRequest(const glint::v1::SampleRequest &request,
                             const ValidationLimits &limits, glint::v1::EvaluateRequest *settings);

// Validates and samples: fills response's wi, pdf and weight (not its stats; `compile_ms`, if
// not null, gets the build of a sample pass not yet built on `worker`'s queue, done and timed
// before the sampling: DeviceEngine::PrepareSample; 0 on the host path). `engine` null:
// the host path. `worker` is the engine queue to run on. Runs in query slices as Evaluate does
// (server/sliced_eval.h; `slicing`'s per_query_cost is replaced by the request's own:
// EstimateSampleCost, server/request_cost.h) and returns slicing.stop's status when
// that stops it between slices; null: one launch.
Status RunSample(DeviceEngine *engine, int worker, const glint::v1::SampleRequest &request,
                 const ValidationLimits &limits, glint::v1::SampleResponse *response,
                 const SliceOptions *slicing = nullptr, double *compile_ms = nullptr);

}  // namespace glint
