#include "server/shm_io.h"

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

#include "server/eval_plan.h"
#include "server/model_table.h"
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

// From this many queries on, an in-place call checks the values while its kernels run
// (RunShared); below, a thread costs more than the check (~1.2 ns per probe).
constexpr uint32_t kOverlapCheckQueries = 1u << 16;

// Scratch memory a worker keeps between shared-memory calls (copy path): 1M probes with a frame.
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
  call->windows_overlap = WindowsOverlap(*call->in, io.input_offset(), io.input_byte_size(),
                                         *call->out, io.output_offset(), out_bytes);
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

// The queries of `call` as views into the input region (the SharedMemoryIo layout: each present
// block contiguous, in Blocks order).
QueryView SharedQueryView(const SharedMemoryCall &call, const glint::v1::SharedMemoryIo &io) {
  QueryView v;
  v.count = call.count;
  const float *at = reinterpret_cast<const float *>(call.input);
  auto take = [&](bool present, uint32_t per) -> const float * {
    if (!present) return nullptr;
    const float *block = at;
    at += uint64_t(call.count) * per;
    return block;
  };
  v.uv = take(io.uv(), 2);
  v.footprint = take(io.footprint(), 4);
  v.wo = take(true, 3);
  v.wi = take(io.wi(), 3);
  v.position = take(io.frame(), 3);
  v.normal = take(io.frame(), 3);
  v.tangent = take(io.frame(), 3);
  return v;
}

bool EvaluatesInPlace(const SharedMemoryCall &call, const glint::v1::EvaluateRequest &settings,
                      bool on_device) {
  if (!on_device) return false;  // the host path reads QueryBatch arrays
  // The kernels would read queries that earlier work-items' radiance overwrote: copied first.
  if (call.windows_overlap) return false;
  if (reinterpret_cast<uintptr_t>(call.input) % alignof(float) != 0) return false;
  // Kernels whose every step is arithmetic on the query's own floats: no table index, loop count
  // or branch into memory derived from query data, so bytes the client changes after validation
  // can only change its own results (tests/service/shm_view_test.cpp runs them on NaN, Inf,
  // huge, denormal and random bit patterns). Polygon lights index the LTC tables by the
  // query's angles and loop over clipped edges: copied.
  if (settings.material().model() != glint::v1::SMOOTH) return false;
  // The in-place path runs ValidateQueryView only: a model that checks more (validate_queries)
  // gets its batch copied and checked as over TCP.
  const Model *model = FindModel(settings.material().model());
  // Nor a model that counts each query's cost (query_costs): it is admitted once its queries
  // are copied (the handler saw only their count).
  if (!model || model->validate_queries || model->query_costs) return false;
  for (const glint::v1::Light &light : settings.lights())
    if (light.has_polygon()) return false;
  return true;
}

namespace {

Status Lost(const SharedMemoryCall &call) {
  for (const ShmRegion *r : {call.in.get(), call.out.get()})
    if (r->lost())
      return Status::InvalidArgument(
          "shared_memory: region \"" + r->info().name() + "\" lost its pages during the call " +
          "(its object " + r->info().key() +
          " was truncated); nothing was answered, and the region must be registered again");
  return Status::Ok();
}

}  // namespace

// Evaluate's shared-memory path: RunBatch (server/service.cpp) on the queries in the input
// region, the radiance written by the kernels into the output region. The queries are read in
// place (views: no copy) when EvaluatesInPlace, else copied out first. What a client that races
// its own region gets:
//  - truncating the object mid-call: the SIGBUS handler (server/shm_guard.h) maps zero pages
//    over the region and the call is refused (INVALID_ARGUMENT, "lost its pages"), as is every
//    later call on that region; the server and other clients are untouched;
//  - writing the input blocks mid-call: in place, validation and the kernels may see different
//    bytes, so its results are undefined (not necessarily finite) for its own queries only;
//    copied, the kernels see exactly the validated bytes;
//  - an output window over its input window: copied (EvaluatesInPlace), the queries are out of
//    the region before the first radiance is written, so the results are those of the same
//    queries over TCP (tests/service/shm_test.cpp).
Status GlintServiceImpl::RunShared(int worker, const glint::v1::EvaluateRequest &settings,
                                   const std::string &owner, glint::v1::EvaluateResponse *response,
                                   std::string *kernel, grpc::CallbackServerContext *ctx) {
  if (!options_.shm)
    return Status::FailedPrecondition("shared_memory: this server has no shared-memory support");
  const glint::v1::SharedMemoryIo &io = settings.shared_memory();
  // Per worker thread and reused (the copy path): the arrays keep their capacity across calls
  // (Clear), so a steady stream of large calls does not page-fault fresh memory in every call
  // (measured: a fifth of the time of a 1M-probe call). Released after a call larger than
  // kKeepBytes.
  thread_local glint::v1::QueryBatch queries;
  struct Release {
    ~Release() {
      if (size_t(queries.ByteSizeLong()) > kKeepBytes) glint::v1::QueryBatch().Swap(&queries);
    }
  } release;
  SharedMemoryCall call;
  // At the time of the call, not of admission: the fstat inside sees truncation up to now.
  Status s = ResolveSharedMemoryCall(*options_.shm, owner, io, &call);
  if (!s.ok()) return s;
  const bool in_place = EvaluatesInPlace(call, settings, engine_ != nullptr);
  QueryView view;
  if (in_place) {
    view = SharedQueryView(call, io);
  } else {
    s = LoadSharedQueries(call, io, &queries);
    view = QueryView::Of(queries);
  }
  // In place and large, the values are checked on another thread while the kernels already run
  // (overlap_check below); only the checks that read no values come first.
  const bool has_lights = settings.lights_size() > 0;
  const bool overlap_check = in_place && call.count >= kOverlapCheckQueries;
  if (s.ok())
    s = overlap_check ? ValidateQueryViewShape(view, has_lights, options_.limits)
                      : ValidateQueryView(view, has_lights, options_.limits, 0, false);
  // A region truncated under the validation reads as zeros: say why, not "length 0".
  if (Status lost = Lost(call); !lost.ok()) return lost;
  if (s.ok() && !in_place) s = ValidateQueriesForModel(queries, settings, 0);
  if (!s.ok()) return s;
  // A model whose cost depends on each query (Model::query_costs: NORMAL_MAP's footprints) is
  // admitted now that its queries are here (the handler saw only their count and left it to
  // us, AdmitCount), by the same per-query cost as over TCP. Such a model is never in place.
  double per_query_cost = EstimateRequestCost(settings, 1).per_query;
  if (const Model *model = FindModel(settings.material().model());
      !in_place && model && model->query_costs) {
    const RequestCost cost = EstimateQueriesCost(settings, queries);
    if (Status c = CheckRequestCost(cost, queries.count(), options_.cost); !c.ok()) return c;
    per_query_cost = cost.per_query;
  }
  glint::v1::QueryBatch shape;  // MakeEvalPlan reads only which arrays are present
  if (view.wi) shape.add_wi(0.0f);
  if (view.normal) shape.add_normal(0.0f);
  EvalPlan plan = MakeEvalPlan(settings, in_place ? shape : queries);
  s = ResolveRequestTable(settings.material(), &plan);
  if (!s.ok()) return s;
  if (kernel) *kernel = plan.spec.Describe();
  // A cold variant is built first and timed apart (EvaluateStats.compile_ms), as in RunBatchInto.
  // In place, before the overlapped value check: the in-place kernels are safe on any bytes.
  double compile_ms = 0;
  if (engine_) s = engine_->Prepare(worker, plan, view, &compile_ms);
  response->mutable_stats()->set_compile_ms(compile_ms);
  if (options_.metrics && compile_ms > 0)
    options_.metrics->ObserveCompile(glint::v1::Model_Name(settings.material().model()),
                                     compile_ms / 1e3);
  if (!s.ok()) return s;
  const auto start = std::chrono::steady_clock::now();
  SliceOptions slicing;
  slicing.per_query_cost = per_query_cost;
  slicing.target_ms = options_.slice_ms;
  StopSlicesFor(ctx, &slicing);
  if (in_place) {
    // overlap_check: the value check (ValidateQueryView) runs on its own thread while the kernels
    // run here, instead of one after the other (1M probes: ~1.2 ms of a ~6.5 ms call, issue 12).
    // Safe because the in-place kernels are safe on any bytes (EvaluatesInPlace; shm_view_test
    // runs them on NaN, Inf and random bits), so starting them before the verdict can only
    // write this call's own output region. A refused call answers the same refusal as before
    // (the check is the same function on the same bytes); its output region then holds
    // whatever the kernels wrote, as after a cancelled or lost call. Slices not yet started
    // when the refusal is found are skipped.
    Status values;
    std::atomic<bool> refused{false};
    std::thread check;
    if (overlap_check) {
      check = std::thread([&] {
        values = ValidateQueryView(view, has_lights, options_.limits, 0, false);
        if (!values.ok()) refused.store(true, std::memory_order_release);
      });
      // The flag is read once per slice, here, and the stop's reason travels in the status:
      // on_stop (StopSlicesFor's, unchanged) counts what stop() returned, and AbandonedWork
      // counts only CANCELLED, DEADLINE_EXCEEDED and UNAVAILABLE, so a refusal (INVALID_ARGUMENT:
      // the call is answered so, not abandoned) is not counted. on_stop used to read the flag
      // again: a refusal found between stop() returning DEADLINE_EXCEEDED and on_stop dropped
      // that abandonment from glint_abandoned_queries_total, depending on the threads' timing.
      slicing.stop = [this, ctx, &refused] {
        return refused.load(std::memory_order_acquire)
                   ? Status::InvalidArgument("refused by the value check")
                   : StopReason(ctx);
      };
    }
    s = RunInSlices(
        call.count, true, slicing,
        [&](uint32_t begin, uint32_t size) {
          return engine_->Evaluate(worker, plan, view.Slice(begin, size),
                                   call.output + size_t(begin) * 3);
        },
        nullptr);
    if (check.joinable()) check.join();
    // The order of the sequential path: lost pages, then the values' refusal, then the run.
    if (Status lost = Lost(call); !lost.ok()) return lost;
    if (!values.ok()) return values;
  } else {
    s = EvaluateSliced(engine_, worker, plan, queries, call.output, slicing);
  }
  if (Status lost = Lost(call); !lost.ok()) return lost;
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
