// libFuzzer target over request decoding and validation: the bytes are parsed as the body of an
// Evaluate call (glint.v1.EvaluateRequest) and as a stream chunk (glint.v1.EvaluateChunk), then
// run through everything glintd does before device work: ValidateSettings, the admission cost
// estimate and limits, ValidateQueries, the model's query checks, the later-chunk rule and the
// evaluation plan. A request that passes all of it and is small (a few queries of low cost) is
// also evaluated on the host path: whatever validation accepts must not crash the kernels'
// host code. Run by ctest for a fixed time with a seed corpus made from examples/ (fuzz_seeds).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/request_cost.h"
#include "server/validation.h"

namespace {

void Check(const glint::v1::EvaluateRequest &r, bool later_chunk) {
  if (later_chunk) (void)glint::ValidateLaterChunkSettings(r);
  glint::ValidationLimits limits;
  limits.max_batch = 4096;
  glint::Status s = glint::ValidateSettings(r, limits);
  if (!s.ok()) return;
  const uint32_t n = r.queries().count();
  const glint::RequestCost cost = glint::EstimateRequestCost(r, n);
  s = glint::CheckRequestCost(cost, n, glint::CostLimits());
  if (!s.ok()) return;
  s = glint::ValidateQueries(r.queries(), r.lights_size() > 0, limits, later_chunk ? 7 : 0,
                             later_chunk);
  if (s.ok()) s = glint::ValidateQueriesForModel(r.queries(), r, 0);
  if (!s.ok()) return;
  const glint::EvalPlan plan = glint::MakeEvalPlan(r, r.queries());
  if (n <= 8 && cost.total <= 2e4) {
    std::vector<float> out(size_t(n) * 3);
    glint::HostEvaluate(plan, r.queries(), out.data());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  glint::v1::EvaluateRequest request;
  if (request.ParseFromArray(data, int(size))) Check(request, false);
  glint::v1::EvaluateChunk chunk;
  if (chunk.ParseFromArray(data, int(size))) Check(chunk.request(), chunk.chunk_index() > 0);
  return 0;
}
