#include "server/sample.h"

#include <string>
#include <vector>

#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/model_table.h"
#include "server/request_cost.h"

namespace glint {

Status ValidateSampleSettings(const glint::v1::SampleRequest &r, const ValidationLimits &limits,
                              glint::v1::EvaluateRequest *settings) {
  settings->Clear();
  *settings->mutable_material() = r.material();
  settings->set_precision(r.precision());
  settings->set_seed(r.seed());
  Status s = ValidateSettings(*settings, limits);
  if (!s.ok()) return s;
  const Model *model = FindModel(r.material().model());
  if (!model) return Status::InvalidArgument("material.model: unknown");
  if (!model->sample.kernel_file) {
    return Status::InvalidArgument(
        std::string("material.model: ") + model->name + " cannot be sampled: " +
        (model->sample.unsupported_reason ? model->sample.unsupported_reason
                                          : "the model has no sample pass") +
        "; expected a model with an NDF (SMOOTH, KEMPPINEN, CHERMAIN, NORMAL_MAP)");
  }
  const uint32_t k = r.samples_per_query();
  if (k < 1 || k > kMaxSamplesPerQuery) {
    return Status::InvalidArgument("samples_per_query: " + std::to_string(k) + "; expected 1 to " +
                                   std::to_string(kMaxSamplesPerQuery));
  }
  const glint::v1::QueryBatch &q = r.queries();
  const uint64_t total = uint64_t(q.count()) * k;
  if (total > limits.max_batch) {
    return Status::InvalidArgument(
        "samples_per_query: " + std::to_string(q.count()) + " queries x " + std::to_string(k) +
        " samples = " + std::to_string(total) + " samples; expected at most " +
        std::to_string(limits.max_batch) + " per call (send fewer queries per call)");
  }
  // The reply is ~28 bytes per sample whatever the request's size: one over the message limit
  // was computed in full and then failed in gRPC's send as RESOURCE_EXHAUSTED "Sent message
  // larger than max (18350140 vs. 1048576)" (10 queries x 65536 samples at --max-message-mb 1;
  // outside-client probe, session 11). Refused before any work, saying how many samples fit.
  const uint64_t reply = total * kSampleReplyBytesPerSample + kSampleReplyOverheadBytes;
  if (limits.max_message_bytes > 0 && reply > limits.max_message_bytes) {
    const uint64_t fit =
        limits.max_message_bytes > kSampleReplyOverheadBytes
            ? (limits.max_message_bytes - kSampleReplyOverheadBytes) / kSampleReplyBytesPerSample
            : 0;
    return Status::InvalidArgument(
        "samples_per_query: " + std::to_string(q.count()) + " queries x " + std::to_string(k) +
        " samples = " + std::to_string(total) + " samples, whose reply (" +
        std::to_string(kSampleReplyBytesPerSample) +
        " bytes per sample: wi, pdf, weight) of up to " + std::to_string(reply) +
        " bytes exceeds the server's message limit of " + std::to_string(limits.max_message_bytes) +
        " bytes (glintd --max-message-mb, Capabilities.max_message_bytes); expected at most " +
        std::to_string(fit) + " samples per call (send fewer queries per call or fewer samples)");
  }
  return Status::Ok();
}

Status ValidateSampleRequest(const glint::v1::SampleRequest &r, const ValidationLimits &limits,
                             glint::v1::EvaluateRequest *settings) {
  Status s = ValidateSampleSettings(r, limits, settings);
  if (!s.ok()) return s;
  const glint::v1::QueryBatch &q = r.queries();
  if (!q.wi().empty()) {
    return Status::InvalidArgument(
        "queries.wi: set; a sample request's incident directions are its output, expected none");
  }
  // No wi: the batch is not a probe batch, which ValidateQueries accepts only with lights;
  // sampling needs none, so it is checked as a lit batch (the light checks only concern probes).
  s = ValidateQueries(q, /*has_lights=*/true, limits);
  if (s.ok()) s = ValidateQueriesForModel(q, *settings);
  return s;
}

Status RunSample(DeviceEngine *engine, int worker, const glint::v1::SampleRequest &request,
                 const ValidationLimits &limits, glint::v1::SampleResponse *response,
                 const SliceOptions *slicing, double *compile_ms) {
  glint::v1::EvaluateRequest settings;
  Status s = ValidateSampleRequest(request, limits, &settings);
  if (!s.ok()) return s;
  const glint::v1::QueryBatch &q = request.queries();
  const uint32_t k = request.samples_per_query();
  const size_t samples = size_t(q.count()) * k;
  EvalPlan plan = MakeEvalPlan(settings, q);
  // uv keys every model's samples when the queries carry it, also where the BRDF does not read
  // it (README "Determinism"; models/smooth/smooth_sample.h). The glint models key on uv through
  // their own inputs already; only the smooth model's sampler reads the option, so only its
  // programs get it (for the others it would compile a second, unwarmed copy of each program).
  plan.spec.sample_uv = q.uv_size() > 0 && settings.material().model() == glint::v1::SMOOTH;
  // The normal map of a NORMAL_MAP material (NOT_FOUND naming the digest when it is gone).
  s = ResolveRequestTable(settings.material(), &plan);
  if (!s.ok()) return s;
  // A sample pass not yet built on this worker is built first and timed apart, so the caller's
  // compute_ms and the slice sizes see the sampling alone (EvaluateStats.compile_ms).
  double prepare_ms = 0;
  if (engine) s = engine->PrepareSample(worker, plan, q, &prepare_ms);
  if (compile_ms) *compile_ms = prepare_ms;
  if (!s.ok()) return s;
  std::vector<float> raw(samples * kSampleFloats);
  // Queries [begin, begin + size) write samples [begin K, (begin + size) K): the sample keys do
  // not depend on a query's index in the batch (kernels/sample.h), so slicing is bit-identical.
  auto run = [&](const glint::v1::QueryBatch &part, float *out) -> Status {
    if (engine) return engine->Sample(worker, plan, part, k, out);
    HostSample(plan, part, k, out);
    return Status::Ok();
  };
  if (!slicing) {
    s = run(q, raw.data());
  } else {
    SliceOptions options = *slicing;
    options.per_query_cost = EstimateSampleCost(settings, k, q).per_query;
    glint::v1::QueryBatch part;
    s = RunInSlices(q.count(), engine != nullptr, options, [&](uint32_t begin, uint32_t size) {
      if (begin == 0 && size == q.count()) return run(q, raw.data());
      CopyQuerySlice(q, begin, begin + size, &part);
      return run(part, raw.data() + size_t(begin) * k * kSampleFloats);
    });
  }
  if (!s.ok()) return s;
  response->set_count(q.count());
  response->set_samples_per_query(k);
  auto *wi = response->mutable_wi();
  auto *pdf = response->mutable_pdf();
  auto *weight = response->mutable_weight();
  wi->Resize(int(3 * samples), 0.0f);
  pdf->Resize(int(samples), 0.0f);
  weight->Resize(int(3 * samples), 0.0f);
  for (size_t j = 0; j < samples; ++j) {
    const float *o = raw.data() + kSampleFloats * j;
    for (int c = 0; c < 3; ++c) wi->Set(int(3 * j) + c, o[c]);
    pdf->Set(int(j), o[3]);
    for (int c = 0; c < 3; ++c) weight->Set(int(3 * j) + c, o[4 + c]);
  }
  return Status::Ok();
}

}  // namespace glint
