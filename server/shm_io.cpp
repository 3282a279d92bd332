#include "server/shm_io.h"

#include <chrono>
#include <memory>

#include "server/eval_plan.h"
#include "server/request_cost.h"
#include "server/service.h"
#include "server/shm_guard.h"
#include "server/sliced_eval.h"
#include "server/validation.h"

namespace glint {
namespace {

// The input blocks in layout order (glint.proto SharedMemoryIo): QueryBatch field, floats per
// query, present.
struct Block {
  google::protobuf::RepeatedField<float> *(*field)(glint::v1::QueryBatch *);
  uint32_t per;
  bool present;
};

std::vector<Block> Blocks(const glint::v1::SharedMemoryIo &io) {
  using Q = glint::v1::QueryBatch;
  return {{[](Q *q) { return q->mutable_uv(); }, 2, io.uv()},
          {[](Q *q) { return q->mutable_footprint(); }, 4, io.footprint()},
          {[](Q *q) { return q->mutable_wo(); }, 3, true},
          {[](Q *q) { return q->mutable_wi(); }, 3, io.wi()},
          {[](Q *q) { return q->mutable_position(); }, 3, io.frame()},
          {[](Q *q) { return q->mutable_normal(); }, 3, io.frame()},
          {[](Q *q) { return q->mutable_tangent(); }, 3, io.frame()}};
}

// Scratch memory a worker keeps between shared-memory calls: 1M probes with a frame.
constexpr size_t kKeepBytes = size_t(80) << 20;

Status Truncated(const std::string &field, const ShmRegion &region, const char *what) {
  return Status::InvalidArgument(field + ": region \"" + region.info().name() +
                                 "\" lost pages during the call (its object " +
                                 region.info().key() + " was truncated); " + what);
}

}  // namespace

std::string ShmOwner(const TokenAuth *auth, const grpc::ServerContextBase &context) {
  if (!auth) return {};
  const auto &md = context.client_metadata();
  auto it = md.find("authorization");
  return it == md.end() ? std::string() : std::string(it->second.data(), it->second.size());
}

uint32_t SharedMemoryFloatsPerQuery(const glint::v1::SharedMemoryIo &io) {
  uint32_t floats = 0;
  for (const Block &b : Blocks(io))
    if (b.present) floats += b.per;
  return floats;
}

Status CheckSharedMemoryRequest(const glint::v1::EvaluateRequest &r) {
  const glint::v1::SharedMemoryIo &io = r.shared_memory();
  const glint::v1::QueryBatch &q = r.queries();
  if (q.count() || q.uv_size() || q.footprint_size() || q.wo_size() || q.wi_size() ||
      q.position_size() || q.normal_size() || q.tangent_size())
    return Status::InvalidArgument(
        "queries: must be empty when shared_memory is set (the queries are in "
        "shared_memory.input_region)");
  if (io.count() == 0)
    return Status::InvalidArgument("shared_memory.count: 0; expected at least one query");
  Status s = ValidateRegionName(io.input_region(), "shared_memory.input_region");
  if (s.ok()) s = ValidateRegionName(io.output_region(), "shared_memory.output_region");
  if (!s.ok()) return s;
  const uint64_t want = uint64_t(io.count()) * SharedMemoryFloatsPerQuery(io) * sizeof(float);
  if (io.input_byte_size() != want)
    return Status::InvalidArgument(
        "shared_memory.input_byte_size: " + std::to_string(io.input_byte_size()) + "; expected " +
        std::to_string(want) + " (4 bytes x " + std::to_string(io.count()) + " queries x " +
        std::to_string(SharedMemoryFloatsPerQuery(io)) +
        " floats of the blocks present, glint.proto SharedMemoryIo)");
  return Status::Ok();
}

Status ResolveSharedMemoryCall(const ShmRegistry &registry, const std::string &owner,
                               const glint::v1::SharedMemoryIo &io, SharedMemoryCall *call) {
  Status s = registry.Find(owner, io.input_region(), "shared_memory.input_region", &call->in);
  if (s.ok())
    s = registry.Find(owner, io.output_region(), "shared_memory.output_region", &call->out);
  if (s.ok())
    s = call->in->CheckRange(io.input_offset(), io.input_byte_size(), "shared_memory.input_offset");
  const uint64_t out_bytes = uint64_t(io.count()) * 3 * sizeof(float);
  if (s.ok())
    s = call->out->CheckRange(io.output_offset(), out_bytes, "shared_memory.output_offset");
  if (s.ok() && io.output_offset() % alignof(float) != 0)
    s = Status::InvalidArgument(
        "shared_memory.output_offset: " + std::to_string(io.output_offset()) +
        " is not a multiple of 4 (float alignment)");
  if (!s.ok()) return s;
  call->input = call->in->data() + io.input_offset();
  call->output = reinterpret_cast<float *>(call->out->data() + io.output_offset());
  call->count = io.count();
  return Status::Ok();
}

Status LoadSharedQueries(const SharedMemoryCall &call, const glint::v1::SharedMemoryIo &io,
                         glint::v1::QueryBatch *queries) {
  queries->Clear();
  queries->set_count(call.count);
  const uint8_t *src = call.input;
  for (const Block &b : Blocks(io)) {
    if (!b.present) continue;
    const int floats = int(uint64_t(call.count) * b.per);
    google::protobuf::RepeatedField<float> *field = b.field(queries);
    field->Reserve(floats);
    float *dst = field->AddNAlreadyReserved(floats);  // uninitialised: the copy fills it
    if (!GuardedCopy(dst, src, size_t(floats) * sizeof(float))) {
      queries->Clear();
      return Truncated("shared_memory.input_region", *call.in, "nothing was evaluated");
    }
    src += size_t(floats) * sizeof(float);
  }
  return Status::Ok();
}

Status StoreSharedRadiance(const SharedMemoryCall &call, const float *rgb) {
  if (!GuardedCopy(call.output, rgb, size_t(call.count) * 3 * sizeof(float)))
    return Truncated("shared_memory.output_region", *call.out,
                     "the radiance could not be written back");
  return Status::Ok();
}

// Evaluate's shared-memory path: RunBatch (server/service.cpp) with the queries copied out of the
// input region and the radiance written into the output region.
Status GlintServiceImpl::RunShared(int worker, const glint::v1::EvaluateRequest &settings,
                                   const std::string &owner, glint::v1::EvaluateResponse *response,
                                   std::string *kernel, grpc::CallbackServerContext *ctx) {
  if (!options_.shm)
    return Status::FailedPrecondition("shared_memory: this server has no shared-memory support");
  const glint::v1::SharedMemoryIo &io = settings.shared_memory();
  // Per worker thread and reused: the arrays keep their capacity across calls (Clear), so a
  // steady stream of large calls does not page-fault fresh memory in every call (measured: a
  // fifth of the time of a 1M-probe call). Released after a call larger than kKeepBytes.
  thread_local glint::v1::QueryBatch queries;
  thread_local std::vector<float> scratch;
  struct Release {
    ~Release() {
      if (size_t(queries.ByteSizeLong()) + scratch.capacity() * sizeof(float) > kKeepBytes) {
        glint::v1::QueryBatch().Swap(&queries);
        std::vector<float>().swap(scratch);
      }
    }
  } release;
  SharedMemoryCall call;
  // At the time of the call, not of admission: the fstat inside sees truncation up to now.
  Status s = ResolveSharedMemoryCall(*options_.shm, owner, io, &call);
  if (s.ok()) s = LoadSharedQueries(call, io, &queries);
  if (s.ok()) s = ValidateQueries(queries, settings.lights_size() > 0, options_.limits, 0, false);
  if (s.ok()) s = ValidateQueriesForModel(queries, settings, 0);
  if (!s.ok()) return s;
  EvalPlan plan = MakeEvalPlan(settings, queries);
  s = ResolveRequestTable(settings.material(), &plan);
  if (!s.ok()) return s;
  if (kernel) *kernel = plan.spec.Describe();
  const auto start = std::chrono::steady_clock::now();
  const bool direct = options_.shm->limits().direct_output;
  float *out = call.output;
  if (!direct) {
    scratch.resize(size_t(call.count) * 3);
    out = scratch.data();
  } else if (Status again =
                 call.out->CheckRange(io.output_offset(), uint64_t(call.count) * 3 * sizeof(float),
                                      "shared_memory.output_offset");
             !again.ok()) {
    return again;  // the last check before the device writes the mapping unguarded
  }
  SliceOptions slicing;
  slicing.per_query_cost = EstimateRequestCost(settings, 1).per_query;
  slicing.target_ms = options_.slice_ms;
  slicing.stop = [this, ctx] { return StopReason(ctx); };
  s = EvaluateSliced(engine_, worker, plan, queries, out, slicing);
  if (s.ok() && !direct) s = StoreSharedRadiance(call, out);
  response->set_count(call.count);
  response->mutable_stats()->set_compute_ms(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  response->mutable_stats()->set_device(DeviceName());
  if (options_.metrics && s.ok())
    options_.metrics->CountEvaluated(glint::v1::Model_Name(settings.material().model()), call.count,
                                     response->stats().compute_ms() / 1e3);
  return s;
}

}  // namespace glint
