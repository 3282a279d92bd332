// Dynamic batching, the evaluation half: several Evaluate requests that one kernel launch can
// serve run as one batch of concatenated queries, and each gets its own rows back.
//
// What must match for one launch to serve several requests (BatchKey): everything the kernels
// see besides the query arrays, i.e. the whole request except `queries` (material with its
// model, NDF, Fresnel and parameters, every light, precision, seed, area method and samples;
// a material naming a normal map names it by digest, so equal keys mean equal tables), plus
// which query arrays are present (uv, footprint, wo, wi, position, normal, tangent: the
// kernel variant depends on some, and concatenation needs all members to carry the same
// ones). Keys compare the deterministic serialisation byte for byte, so floats match bit for
// bit (-0 and +0 differ: conservative). Two requests with equal keys give equal EvalPlans.
//
// Results are bit-identical to evaluating each request on its own: every kernel evaluates a
// query from its own inputs (DESIGN.md "Determinism": no query index, batch or work-item
// enters a result), and a request's queries are a contiguous range of the batch.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/sliced_eval.h"
#include "server/status.h"

namespace glint {

// The batch key of `request` (see above).
std::string BatchKey(const glint::v1::EvaluateRequest &request);

// Whether `request` may wait to share a launch when batches hold up to `max_queries` queries:
// it has queries, at most half a batch of them (a larger request already spreads the launch
// overhead over many queries, and would leave little room for others), and carries them inline
// (every query array it has holds its `count` entries; validation reports anything else).
bool Batchable(const glint::v1::EvaluateRequest &request, uint32_t max_queries);

// One request of a batch.
struct BatchPart {
  const glint::v1::QueryBatch *queries = nullptr;  // validated
  float *out_rgb = nullptr;                        // 3 x queries->count() floats
  // This request's own reason to stop (its client cancelled, its deadline passed); empty: none.
  std::function<Status()> stop;
  Status status;  // out: OK with out_rgb filled, or why this part has no result
};

struct BatchStats {
  int evaluated_parts = 0;  // parts that were still wanted when the launch started
  uint32_t queries = 0;     // queries in the launch
  int slices = 0;
};

// The per-query cost (server/request_cost.h) a batch's slices are sized by: that of the dearest
// query of any part under `settings` (the parts' shared settings), each part counted by
// EstimateQueriesCost, the cost every member was admitted by. The first part's alone would let
// a NORMAL_MAP batch whose big footprints sit in a later part run as one long slice.
double BatchPerQueryCost(const glint::v1::EvaluateRequest &settings,
                         const std::vector<BatchPart> &parts);

// Evaluates `parts` (all with `plan`'s settings, BatchKey-equal) as one batch on `worker`
// (engine null: the host path). A part whose stop() fails before the launch is left out with
// that status. The launch runs in slices (server/sliced_eval.h) and stops early only when
// `slicing.stop` (the server's reason, e.g. shutdown) fails or every part has stopped; a part
// that stops while the others go on gets its stop status and no result. Returns the launch's
// status (not OK: the device failed, slicing.stop stopped it, or every part stopped); each
// part's own outcome is in its status. slicing.on_stop hears of every query not computed: a
// part left out before the launch (all its queries), and the rest of a launch that stopped (a
// part that stops while the others go on was computed, so it is not reported).
Status EvaluateBatched(DeviceEngine *engine, int worker, const EvalPlan &plan,
                       std::vector<BatchPart> *parts, const SliceOptions &slicing,
                       BatchStats *stats = nullptr);

}  // namespace glint
