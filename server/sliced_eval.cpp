#include "server/sliced_eval.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "server/host_path.h"

namespace glint {
namespace {

using Clock = std::chrono::steady_clock;

void CopyRange(const google::protobuf::RepeatedField<float> &in, int per_query, uint32_t begin,
               uint32_t end, google::protobuf::RepeatedField<float> *out) {
  if (in.empty()) return;
  out->Resize(int(end - begin) * per_query, 0.0f);
  std::copy(in.begin() + int64_t(begin) * per_query, in.begin() + int64_t(end) * per_query,
            out->begin());
}

}  // namespace

void CopyQuerySlice(const glint::v1::QueryBatch &q, uint32_t begin, uint32_t end,
                    glint::v1::QueryBatch *out) {
  out->Clear();
  out->set_count(end - begin);
  CopyRange(q.uv(), 2, begin, end, out->mutable_uv());
  CopyRange(q.footprint(), 4, begin, end, out->mutable_footprint());
  CopyRange(q.wo(), 3, begin, end, out->mutable_wo());
  CopyRange(q.wi(), 3, begin, end, out->mutable_wi());
  CopyRange(q.position(), 3, begin, end, out->mutable_position());
  CopyRange(q.normal(), 3, begin, end, out->mutable_normal());
  CopyRange(q.tangent(), 3, begin, end, out->mutable_tangent());
}

Status RunInSlices(uint32_t n, bool on_device, const SliceOptions &options,
                   const std::function<Status(uint32_t begin, uint32_t size)> &run,
                   SliceStats *stats) {
  // Queries per ms: first from the estimate, then measured.
  double rate = options.units_per_ms / std::max(options.per_query_cost, 1e-9);
  if (!on_device) rate /= 8;  // the host path is one scalar thread (bench_smooth: ~8x slower)
  uint32_t begin = 0;
  double done_ms = 0;
  int slices = 0;
  while (begin < n) {
    if (options.stop) {
      Status s = options.stop();
      if (!s.ok()) {
        if (options.on_stop) options.on_stop(s, n - begin);
        return s;
      }
    }
    double want = std::floor(rate * options.target_ms);
    // A request estimated at no more than a few slices runs whole: splitting it would copy its
    // queries (CopyQuerySlice) for a gain in responsiveness of at most those few slices. This
    // keeps cheap large batches (1M probes, ~6 ms on the device) one launch with no copy.
    if (begin == 0 && !options.max_slice_queries && double(n) <= 4.0 * want) want = double(n);
    double cap = double(n - begin);
    if (options.max_slice_queries) cap = std::min(cap, double(options.max_slice_queries));
    const uint32_t size = uint32_t(std::clamp(want, 1.0, cap));
    const auto t0 = Clock::now();
    Status s = run(begin, size);
    if (!s.ok()) return s;
    if (stats && slices == 0) stats->first_slice_queries = size;
    ++slices;
    begin += size;
    if (stats) stats->slices = slices;
    done_ms += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    // Measured rate over everything so far (at least 1 ms of it, so one fast slice's timer
    // noise does not blow the next slice up).
    rate = double(begin) / std::max(done_ms, 1.0);
  }
  return Status::Ok();
}

Status EvaluateSliced(DeviceEngine *engine, int worker, const EvalPlan &plan,
                      const glint::v1::QueryBatch &queries, float *out_rgb,
                      const SliceOptions &options, SliceStats *stats) {
  auto run = [&](const glint::v1::QueryBatch &q, float *out) -> Status {
    if (engine) return engine->Evaluate(worker, plan, q, out);
    HostEvaluate(plan, q, out);
    return Status::Ok();
  };
  const uint32_t n = queries.count();
  glint::v1::QueryBatch slice;
  return RunInSlices(
      n, engine != nullptr, options,
      [&](uint32_t begin, uint32_t size) {
        if (begin == 0 && size == n) return run(queries, out_rgb);  // one slice: no copy
        CopyQuerySlice(queries, begin, begin + size, &slice);
        return run(slice, out_rgb + size_t(begin) * 3);
      },
      stats);
}

}  // namespace glint
