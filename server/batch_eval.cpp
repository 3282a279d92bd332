#include "server/batch_eval.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <algorithm>
#include <array>
#include <cstring>

#include "server/request_cost.h"

namespace glint {
namespace {

using FloatArray = google::protobuf::RepeatedField<float>;

// The query arrays in a fixed order with their floats per query.
template <class Batch>
auto Arrays(Batch &q) {
  return std::array{std::pair{&q.uv(), 2},       std::pair{&q.footprint(), 4},
                    std::pair{&q.wo(), 3},       std::pair{&q.wi(), 3},
                    std::pair{&q.position(), 3}, std::pair{&q.normal(), 3},
                    std::pair{&q.tangent(), 3}};
}

std::array<FloatArray *, 7> MutableArrays(glint::v1::QueryBatch *q) {
  return {q->mutable_uv(),       q->mutable_footprint(), q->mutable_wo(),     q->mutable_wi(),
          q->mutable_position(), q->mutable_normal(),    q->mutable_tangent()};
}

void Append(const glint::v1::QueryBatch &part, glint::v1::QueryBatch *all) {
  const auto in = Arrays(part);
  const auto out = MutableArrays(all);
  for (size_t a = 0; a < in.size(); ++a) out[a]->Add(in[a].first->begin(), in[a].first->end());
  all->set_count(all->count() + part.count());
}

}  // namespace

std::string BatchKey(const glint::v1::EvaluateRequest &request) {
  // A copy without the queries (only batchable, hence small, requests get a key): every other
  // field, including any added to the message later, is part of the key.
  glint::v1::EvaluateRequest settings = request;
  settings.clear_queries();
  std::string key;
  {
    google::protobuf::io::StringOutputStream stream(&key);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    settings.SerializeToCodedStream(&coded);
  }
  for (const auto &[array, per_query] : Arrays(request.queries()))
    key += array->empty() ? '0' : '1';
  return key;
}

bool Batchable(const glint::v1::EvaluateRequest &request, uint32_t max_queries) {
  const glint::v1::QueryBatch &q = request.queries();
  if (q.count() == 0 || uint64_t(q.count()) * 2 > max_queries) return false;
  if (q.wo().size() != int64_t(q.count()) * 3) return false;  // not inline
  for (const auto &[array, per_query] : Arrays(q))
    if (!array->empty() && array->size() != int64_t(q.count()) * per_query) return false;
  return true;
}

double BatchPerQueryCost(const glint::v1::EvaluateRequest &settings,
                         const std::vector<BatchPart> &parts) {
  double cost = 1;
  for (const BatchPart &p : parts)
    cost = std::max(cost, EstimateQueriesCost(settings, *p.queries).per_query);
  return cost;
}

Status EvaluateBatched(DeviceEngine *engine, int worker, const EvalPlan &plan,
                       std::vector<BatchPart> *parts, const SliceOptions &slicing,
                       BatchStats *stats) {
  std::vector<BatchPart *> live;
  glint::v1::QueryBatch all;
  uint64_t total = 0;
  for (BatchPart &p : *parts) {
    p.status = p.stop ? p.stop() : Status::Ok();
    if (!p.status.ok()) {  // expired or cancelled while queued: never started
      if (slicing.on_stop) slicing.on_stop(p.status, p.queries->count());
      continue;
    }
    live.push_back(&p);
    total += p.queries->count();
  }
  if (stats) *stats = BatchStats{int(live.size()), uint32_t(total), 0};
  if (live.empty()) return Status::Ok();
  {
    const auto in = Arrays(*live[0]->queries);
    const auto out = MutableArrays(&all);
    for (size_t a = 0; a < in.size(); ++a)
      if (!in[a].first->empty()) out[a]->Reserve(int(total) * in[a].second);
  }
  for (BatchPart *p : live) Append(*p->queries, &all);
  std::vector<float> rgb(size_t(total) * 3);
  SliceOptions options = slicing;
  // Stop early only for the server's reason, or when no part wants its result any more.
  options.stop = [&]() -> Status {
    if (slicing.stop) {
      Status s = slicing.stop();
      if (!s.ok()) return s;
    }
    Status last;
    for (BatchPart *p : live) {
      if (!p->stop) return Status::Ok();
      last = p->stop();
      if (last.ok()) return Status::Ok();
    }
    return last;
  };
  SliceStats slice_stats;
  Status s = EvaluateSliced(engine, worker, plan, all, rgb.data(), options, &slice_stats);
  if (stats) stats->slices = slice_stats.slices;
  size_t offset = 0;
  for (BatchPart *p : live) {
    const size_t floats = size_t(p->queries->count()) * 3;
    Status own = p->stop ? p->stop() : Status::Ok();
    if (!own.ok())
      p->status = own;  // stopped during the launch: its client no longer waits for it
    else if (!s.ok())
      p->status = s;  // the launch failed or the server stopped it
    else
      std::memcpy(p->out_rgb, rgb.data() + offset, floats * sizeof(float));
    offset += floats;
  }
  return s;
}

}  // namespace glint
