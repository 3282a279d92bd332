// Evaluation in query slices, so that cancellation, deadlines and shutdown take effect while a
// long request runs: the engine evaluates slices of consecutive queries, each sized to take
// about `target_ms`, and asks `stop` before every slice (the first included, so work whose
// deadline passed while it waited in the queue never starts). The first slice is sized from the
// admission cost estimate (server/request_cost.h) and the device's calibrated rate; later ones
// from the rate the earlier slices actually ran at, so a loaded machine or a cost estimate that
// is off by a constant still gives slices of about target_ms. A request estimated at no more
// than 4 slices runs as one (no copy).
//
// Results are bit-identical to one unsliced call: every kernel evaluates each query on its own
// from its own inputs (DESIGN.md "Determinism": no query index, batch or work-item enters the
// result), and a slice is a contiguous copy of its queries writing its part of the output.
#pragma once

#include <cstdint>
#include <functional>

#include "glint/v1/glint.pb.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/status.h"

namespace glint {

struct SliceOptions {
  double per_query_cost = 1;  // RequestCost::per_query
  // Cost units the device evaluates per ms (all compute units, one request at a time): ~50 ns
  // per unit in bench/bench_request_cost.cpp on the loaded 2-core PoCL CPU device. Only sizes
  // the first slice; later ones use the measured rate.
  double units_per_ms = 20e3;
  double target_ms = 50;
  // At most this many queries per slice (0: no cap). Tests force many small slices with it.
  uint32_t max_slice_queries = 0;
  // Returns OK to go on, or the status the call ends with (CANCELLED, DEADLINE_EXCEEDED,
  // UNAVAILABLE). Empty: never stop.
  std::function<Status()> stop;
  // Called once when stop() ends the loop, with its status and the queries not run (those from
  // the slice it would have started to the end): the abandoned-work count (server/
  // abandoned_work.h). Empty: not reported.
  std::function<void(const Status &stop, uint32_t not_run)> on_stop;
};

struct SliceStats {
  int slices = 0;
  uint32_t first_slice_queries = 0;
};

// Writes 3 * queries.count() floats to out_rgb, on `engine` (worker's queue) or, when engine
// is null, on the host path. On a stop, returns stop()'s status; out_rgb is then partial.
Status EvaluateSliced(DeviceEngine *engine, int worker, const EvalPlan &plan,
                      const glint::v1::QueryBatch &queries, float *out_rgb,
                      const SliceOptions &options, SliceStats *stats = nullptr);

// The slice loop itself, for any per-query work (EvaluateSliced, and the Sample RPC's sample
// pass, server/sample.cpp): calls run(begin, size) on consecutive ranges covering [0, n),
// sized and stopped as above. A request estimated at no more than 4 slices is one range.
Status RunInSlices(uint32_t n, bool on_device, const SliceOptions &options,
                   const std::function<Status(uint32_t begin, uint32_t size)> &run,
                   SliceStats *stats = nullptr);

// Queries [begin, end) of `q` as a batch of their own (every present array sliced).
void CopyQuerySlice(const glint::v1::QueryBatch &q, uint32_t begin, uint32_t end,
                    glint::v1::QueryBatch *out);

}  // namespace glint
