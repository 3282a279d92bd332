// libFuzzer target over request decoding and validation: the bytes are parsed as the body of an
// Evaluate call (glint.v1.EvaluateRequest) and as a stream chunk (glint.v1.EvaluateChunk), then
// run through everything glintd does before device work: ValidateSettings, the admission cost
// estimate and limits, ValidateQueries, the model's query checks, the later-chunk rule and the
// evaluation plan. A request that passes all of it and is small (a few queries of low cost) is
// also evaluated on the host path: whatever validation accepts must not crash the kernels'
// host code. Run by ctest for a fixed time with a seed corpus made from examples/ (fuzz_seeds).
// The same bytes, read as a stream result by the client's hand-written decoder
// (proto/wire/chunk_result.h), must be accepted exactly when protobuf's parser accepts them, to
// the same values, without writing past the output (issue 12).
#include <grpcpp/support/byte_buffer.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "proto/wire/chunk_result.h"
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
  const glint::RequestCost cost = glint::EstimateQueriesCost(r, r.queries());
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

void CheckChunkResultDecoder(const uint8_t *data, size_t size) {
  glint::v1::EvaluateChunkResult expected;
  const bool parses = expected.ParseFromArray(data, int(size));
  constexpr uint64_t kRoom = 64;  // floats; a canary follows
  std::vector<float> out(kRoom + 1, -7.0f);
  grpc::Slice slice(data, size);
  grpc::ByteBuffer buffer(&slice, 1);
  glint::wire::DecodedChunkResult got;
  const std::string problem = glint::wire::DecodeChunkResult(&buffer, out.data(), kRoom, &got);
  if (out[kRoom] != -7.0f) std::abort();  // wrote past the output
  const bool fits = !parses || uint64_t(expected.result().radiance_size()) <= kRoom;
  if (fits && problem.empty() != parses) std::abort();  // accepts what protobuf refuses, or not
  if (!parses || !problem.empty()) return;
  if (got.chunk_index != expected.chunk_index() || got.first_query != expected.first_query() ||
      got.count != expected.result().count() ||
      got.radiance_floats != uint64_t(expected.result().radiance_size()) ||
      (got.radiance_floats && std::memcmp(out.data(), expected.result().radiance().data(),
                                          got.radiance_floats * sizeof(float)) != 0) ||
      got.stats.SerializeAsString() != expected.result().stats().SerializeAsString())
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  glint::v1::EvaluateRequest request;
  if (request.ParseFromArray(data, int(size))) Check(request, false);
  glint::v1::EvaluateChunk chunk;
  if (chunk.ParseFromArray(data, int(size))) Check(chunk.request(), chunk.chunk_index() > 0);
  CheckChunkResultDecoder(data, size);
  return 0;
}
