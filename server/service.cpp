#include "server/service.h"

#include <google/protobuf/io/coded_stream.h>
#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/proto_buffer_writer.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <mutex>
#include <optional>
#include <sstream>
#include <vector>

#include "proto/wire/chunk_result.h"
#include "proto/wire/slice_pool.h"
#include "server/chunk_pool.h"
#include "server/eval_plan.h"
#include "server/log_sanitize.h"
#include "server/metadata_admission.h"
#include "server/model_table.h"
#include "server/normal_map_store.h"
#include "server/raw_messages.h"
#include "server/shm_io.h"
#include "server/sliced_eval.h"

namespace glint {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

const char *ModelName(const glint::v1::EvaluateRequest &r) {
  return glint::v1::Model_IsValid(r.material().model())
             ? glint::v1::Model_Name(r.material().model()).c_str()
             : "?";
}

// Clears every field of `m` but the one named `keep`, and its unknown fields (through reflection,
// so fields added to the contract later are cleared too).
void ClearAllBut(google::protobuf::Message *m, const char *keep) {
  const google::protobuf::Reflection *reflection = m->GetReflection();
  std::vector<const google::protobuf::FieldDescriptor *> fields;
  reflection->ListFields(*m, &fields);
  for (const google::protobuf::FieldDescriptor *f : fields)
    if (f->name() != keep) reflection->ClearField(m, f);
  reflection->MutableUnknownFields(m)->Clear();
}

// Parses a stream chunk into a message used before, keeping the capacity of its query arrays
// (issue 12): Clear() (which ParseFrom calls) deletes the nested request with its arrays, and
// parsing into fresh arrays regrows them by doubling and faults in their pages for every chunk.
// Everything else is cleared first, so the merge below sees an empty message, as a parse would.
Status ParseChunkReusing(const grpc::ByteBuffer *body, glint::v1::EvaluateChunk *chunk,
                         const std::string &what) {
  ClearAllBut(chunk, "request");
  glint::v1::EvaluateRequest *request = chunk->mutable_request();
  ClearAllBut(request, "queries");
  request->mutable_queries()->Clear();  // repeated fields keep their capacity
  auto *raw = const_cast<grpc::ByteBuffer *>(body);
  const size_t bytes = raw->Length();
  bool ok = false;
  {
    grpc::ProtoBufferReader reader(raw);
    google::protobuf::io::CodedInputStream input(&reader);
    ok = chunk->MergeFromCodedStream(&input) && input.ConsumedEntireMessage();
  }
  raw->Clear();
  if (ok) return Status::Ok();
  return Status::InvalidArgument(what + ": the " + std::to_string(bytes) +
                                 "-byte body does not parse as a " + chunk->GetTypeName() +
                                 " (truncated, or not this message); check that client and "
                                 "server use the same proto/glint/v1/glint.proto");
}

// Memory of the streams' reply radiance, shared by every stream (issue 12: the device writes
// into pages that stay mapped instead of a fresh array per chunk). Idle, it holds at most
// kReplyBuffersKept replies (12 bytes per query of the largest chunks).
constexpr size_t kReplyBuffersKept = 4;
glint::wire::SlicePool &ReplyPool() {
  static const std::shared_ptr<glint::wire::SlicePool> pool =
      glint::wire::SlicePool::Create(kReplyBuffersKept);
  return *pool;
}

}  // namespace

grpc::Status ToGrpcStatus(const Status &s) {
  switch (s.code()) {
    case Status::Code::kOk:
      return grpc::Status::OK;
    case Status::Code::kInvalidArgument:
      return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, s.message());
    case Status::Code::kResourceExhausted:
      return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, s.message());
    case Status::Code::kFailedPrecondition:
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, s.message());
    case Status::Code::kInternal:
      return grpc::Status(grpc::StatusCode::INTERNAL, s.message());
    case Status::Code::kNotFound:
      return grpc::Status(grpc::StatusCode::NOT_FOUND, s.message());
    case Status::Code::kCancelled:
      return grpc::Status(grpc::StatusCode::CANCELLED, s.message());
    case Status::Code::kDeadlineExceeded:
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, s.message());
    case Status::Code::kUnavailable:
      return grpc::Status(grpc::StatusCode::UNAVAILABLE, s.message());
  }
  return grpc::Status(grpc::StatusCode::UNKNOWN, s.message());
}

grpc::Status ChunkStatus(uint64_t chunk_index, const Status &s) {
  if (s.ok()) return grpc::Status::OK;
  const grpc::Status g = ToGrpcStatus(s);
  return grpc::Status(g.error_code(), "chunk " + std::to_string(chunk_index) + ": " + s.message());
}

Status OverloadStatus(const Scheduler &scheduler) {
  return Status::ResourceExhausted("server busy: " + std::to_string(scheduler.max_pending()) +
                                   " requests already pending (--max-pending); retry later or "
                                   "send to another replica");
}

void AddRetryPushback(grpc::ServerContextBase *ctx, double wait_ms) {
  ctx->AddTrailingMetadata("glint-retry-pushback-ms",
                           std::to_string(static_cast<int64_t>(std::ceil(std::max(0.0, wait_ms)))));
}

GlintServiceImpl::GlintServiceImpl(DeviceEngine *engine, Scheduler *scheduler,
                                   ServiceOptions options)
    : engine_(engine), scheduler_(scheduler), options_(std::move(options)) {}

std::string GlintServiceImpl::DeviceName() const {
  return engine_ ? engine_->info().name : std::string("host (scalar C++)");
}

void GlintServiceImpl::LogLine(const std::string &line) {
  if (!options_.log_requests) return;
  std::lock_guard<std::mutex> lock(log_mutex_);
  // Client-chosen strings in it may not forge lines or grow the log (server/log_sanitize.h).
  std::fprintf(stderr, "glintd: %s\n", LogSafe(line).c_str());
}

Status GlintServiceImpl::Admit(const glint::v1::EvaluateRequest &settings,
                               const glint::v1::QueryBatch &queries, uint64_t first_query) const {
  if (Status s = ShutdownStatus(); !s.ok()) return s;
  return CheckRequestCost(EstimateQueriesCost(settings, queries, first_query), queries.count(),
                          options_.cost);
}

Status GlintServiceImpl::ShutdownStatus() const {
  if (shutting_down_)
    return Status::Unavailable(
        "server shutting down: no new work accepted; send to another "
        "replica");
  return Status::Ok();
}

Status GlintServiceImpl::AdmitCount(const glint::v1::EvaluateRequest &settings,
                                    uint64_t query_count) const {
  if (Status s = ShutdownStatus(); !s.ok()) return s;
  const Model *model = FindModel(settings.material().model());
  if (model && model->query_costs) return Status::Ok();  // RunShared admits it with its queries
  return CheckRequestCost(EstimateRequestCost(settings, query_count), query_count, options_.cost);
}

Status GlintServiceImpl::StopReason(grpc::CallbackServerContext *ctx) const {
  if (cancel_in_flight_)
    return Status::Unavailable(
        "server shutting down: work in flight cancelled after "
        "--shutdown-grace; retry on another replica");
  if (!ctx) return Status::Ok();
  // The deadline first: gRPC also marks a call whose deadline passed as cancelled, and the
  // abandoned-work count (server/abandoned_work.h) should say which it was.
  if (ctx->deadline() <= std::chrono::system_clock::now())
    return Status::DeadlineExceeded("the call's deadline passed before its work finished");
  if (ctx->IsCancelled()) return Status::Cancelled("the client cancelled the call");
  return Status::Ok();
}

void GlintServiceImpl::StopSlicesFor(grpc::CallbackServerContext *ctx, SliceOptions *slicing) {
  slicing->stop = [this, ctx] { return StopReason(ctx); };
  slicing->on_stop = [this](const Status &stop, uint32_t not_run) {
    abandoned_.Count(stop, not_run);
  };
}

Status GlintServiceImpl::RunBatch(int worker, const glint::v1::EvaluateRequest &settings,
                                  const glint::v1::QueryBatch &queries, uint64_t first_query,
                                  bool streamed, glint::v1::EvaluateResponse *response,
                                  std::string *kernel, grpc::CallbackServerContext *ctx) {
  response->set_count(queries.count());
  response->mutable_radiance()->Resize(int(queries.count()) * 3, 0.0f);
  return RunBatchInto(worker, settings, queries, first_query, streamed,
                      response->mutable_radiance()->mutable_data(), response->mutable_stats(),
                      kernel, ctx);
}

Status GlintServiceImpl::RunBatchInto(int worker, const glint::v1::EvaluateRequest &settings,
                                      const glint::v1::QueryBatch &queries, uint64_t first_query,
                                      bool streamed, float *out, glint::v1::EvaluateStats *stats,
                                      std::string *kernel, grpc::CallbackServerContext *ctx) {
  Status s =
      ValidateQueries(queries, settings.lights_size() > 0, options_.limits, first_query, streamed);
  if (s.ok()) s = ValidateQueriesForModel(queries, settings, first_query);
  if (!s.ok()) return s;
  EvalPlan plan = MakeEvalPlan(settings, queries);
  s = ResolveRequestTable(settings.material(), &plan);
  if (!s.ok()) return s;
  if (kernel) *kernel = plan.spec.Describe();
  // A variant not yet built on this worker is built first and timed apart (compile_ms), so
  // compute_ms, the metrics and the slice sizes (measured from the first slice's rate) see the
  // evaluation alone.
  double compile_ms = 0;
  if (engine_) s = engine_->Prepare(worker, plan, QueryView::Of(queries), &compile_ms);
  stats->set_compile_ms(compile_ms);
  if (options_.metrics && compile_ms > 0)
    options_.metrics->ObserveCompile(ModelName(settings), compile_ms / 1e3);
  if (!s.ok()) return s;
  const auto start = Clock::now();
  SliceOptions slicing;
  slicing.per_query_cost = EstimateQueriesCost(settings, queries, first_query).per_query;
  slicing.target_ms = options_.slice_ms;
  StopSlicesFor(ctx, &slicing);
  s = EvaluateSliced(engine_, worker, plan, queries, out, slicing);
  stats->set_compute_ms(MsSince(start));
  stats->set_device(DeviceName());
  if (options_.metrics && s.ok())
    options_.metrics->CountEvaluated(ModelName(settings), queries.count(),
                                     stats->compute_ms() / 1e3);
  return s;
}

grpc::ServerUnaryReactor *GlintServiceImpl::Evaluate(grpc::CallbackServerContext *ctx,
                                                     const grpc::ByteBuffer *body,
                                                     grpc::ByteBuffer *reply) {
  using Reactor = OwningUnaryReactor<glint::v1::EvaluateRequest, glint::v1::EvaluateResponse>;
  auto *reactor = new Reactor(reply, &undelivered_, [this] { scheduler_->DropDeadJobs(); });
  const glint::v1::EvaluateRequest *request = &reactor->request;
  glint::v1::EvaluateResponse *response = &reactor->response;
  const auto received = Clock::now();
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok()) {
    reactor->Finish(denied);
    return reactor;
  }
  // Full already: refused before the body is parsed (no second copy of it in memory).
  Status s = Status::Ok();
  if (!scheduler_->HasRoom()) {  // dead queued calls give up their slots first
    s = OverloadStatus(*scheduler_);
    AddRetryPushback(ctx, options_.slice_ms);
  } else if (s = undelivered_.Admit(); !s.ok()) {
    AddRetryPushback(ctx, options_.slice_ms);
  }
  // The client's claim (query count, model) before the body is parsed.
  if (s.ok()) s = AdmitFromMetadata(*ctx, options_.limits, /*per_message=*/true);
  if (s.ok()) s = ParseBody(body, &reactor->request, "request");
  if (s.ok()) s = ValidateSettings(*request, options_.limits);
  // Shared memory (server/shm_io.h): the query count is in the request, the queries in a region.
  const bool shared = request->has_shared_memory();
  if (s.ok() && shared) s = CheckSharedMemoryRequest(*request);
  if (s.ok())
    s = shared ? AdmitCount(*request, request->shared_memory().count())
               : Admit(*request, request->queries());
  if (!s.ok()) {
    LogLine("Evaluate n=" + std::to_string(request->queries().count()) +
            " refused: " + s.message());
    reactor->Finish(ToGrpcStatus(s));
    return reactor;
  }
  // Batchable: the scheduler may run it in one launch with others (RunEvaluateBatch) instead.
  auto finish = [reactor](const Status &st) { reactor->Finish(ToGrpcStatus(st)); };
  auto member = MakeEvaluateMember(ctx, request, response, received, finish);
  bool queued = scheduler_->TrySubmit(
      [this, ctx, reactor, request, response, received](int worker) -> Scheduler::Respond {
        const double queue_ms = MsSince(received);
        if (options_.metrics) options_.metrics->ObserveQueueWait(queue_ms / 1e3);
        std::string kernel = "-";
        const uint32_t count = request->queries().count();
        if (!request->has_shared_memory() && count <= options_.limits.max_batch) {
          // As the stream's chunks: the device writes the radiance straight into a pooled reply
          // slice, which the reply wraps without a copy (proto/wire/chunk_result.h
          // EncodeEvaluateResponse); no response array to zero-fill, no serialisation copy. A
          // count over the limit is refused by the validation below without a buffer.
          uint8_t *radiance = nullptr;
          grpc_slice slice = ReplyPool().Take(size_t(count) * 3 * sizeof(float), &radiance);
          glint::v1::EvaluateStats stats;
          Status st = RunBatchInto(worker, *request, request->queries(), 0, false,
                                   reinterpret_cast<float *>(radiance), &stats, &kernel, ctx);
          stats.set_queue_ms(queue_ms);
          std::ostringstream line;
          line << "Evaluate n=" << count << " model=" << ModelName(*request) << " kernel=" << kernel
               << " queue_ms=" << queue_ms << " compile_ms=" << stats.compile_ms()
               << " compute_ms=" << stats.compute_ms()
               << (st.ok() ? " ok" : " refused: " + st.message());
          LogLine(line.str());
          if (!st.ok()) {
            grpc_slice_unref(slice);
            return [reactor, st] { reactor->Finish(ToGrpcStatus(st)); };
          }
          auto encoded = std::make_shared<grpc::ByteBuffer>(
              glint::wire::EncodeEvaluateResponse(count, slice, stats));
          return [reactor, encoded] { reactor->FinishWithReply(std::move(*encoded)); };
        }
        Status st =
            request->has_shared_memory()
                ? RunShared(worker, *request, ShmOwner(options_.auth, *ctx), response, &kernel, ctx)
                : RunBatch(worker, *request, request->queries(), 0, false, response, &kernel, ctx);
        response->mutable_stats()->set_queue_ms(queue_ms);
        std::ostringstream line;
        line << "Evaluate n="
             << (request->has_shared_memory() ? request->shared_memory().count()
                                              : request->queries().count())
             << " model=" << ModelName(*request) << " kernel=" << kernel << " queue_ms=" << queue_ms
             << " compile_ms=" << response->stats().compile_ms()
             << " compute_ms=" << response->stats().compute_ms()
             << (st.ok() ? " ok" : " refused: " + st.message());
        LogLine(line.str());
        if (!st.ok()) response->Clear();
        return [reactor, st] { reactor->Finish(ToGrpcStatus(st)); };
      },
      std::move(member),
      DeadCall(ctx, "Evaluate n=" + std::to_string(request->queries().count()),
               request->has_shared_memory() ? request->shared_memory().count()
                                            : request->queries().count(),
               finish));
  if (!queued) {
    Status busy = OverloadStatus(*scheduler_);
    LogLine("Evaluate n=" + std::to_string(request->queries().count()) + " " + busy.message());
    AddRetryPushback(ctx, options_.slice_ms);
    reactor->Finish(ToGrpcStatus(busy));
  }
  return reactor;
}

// A pipelined stream (issue 12): while chunk k evaluates on a worker, chunk k+1 is read and
// parsed on gRPC's thread and the result of chunk k-1 is written. Chunks still evaluate one at a
// time and in order, so results leave in chunk order and a later chunk's settings apply from
// that chunk on. At most kDepth chunks are held (read, not yet answered), which bounds a
// stream's memory to kDepth chunks and their results.
// Every action on the call (StartRead, StartWrite, submitting a job, Finish) is decided under
// mu_ and carried out after it is released: a reaction may run on another thread at once.
// Finish comes only when no job and no write is outstanding, so `delete this` in OnDone is safe
// (a read may still be outstanding: it then completes with ok = false).
// On a failure the chunks before it are still evaluated and answered (as before pipelining,
// when a chunk was read only after the previous one's result had been written); the stream then
// ends with the failure's status.
class GlintServiceImpl::StreamReactor
    : public grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  static constexpr size_t kDepth = 3;

  StreamReactor(GlintServiceImpl *service, grpc::CallbackServerContext *ctx)
      : service_(service), ctx_(ctx), start_(Clock::now()) {
    // Refused before the first chunk's body is read where that is already known: shutting
    // down, a full server, or a refused claim in the call metadata.
    // Outside mu_: dead queued calls give up their slots first, and their answers may run here.
    const bool room = service_->scheduler().HasRoom();
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (service_->shutting_down_) {
        failure_ = ToGrpcStatus(service_->ShutdownStatus());
      } else if (!room) {
        Status busy = OverloadStatus(service_->scheduler());
        AddRetryPushback(ctx_, service_->options().slice_ms);
        failure_ = ToGrpcStatus(Status::ResourceExhausted(
            busy.message() + " (refused on opening the stream, before its first chunk was read)"));
      } else if (Status s = AdmitFromMetadata(*ctx_, service_->options().limits, false); !s.ok()) {
        failure_ = ToGrpcStatus(s);
      }
    }
    Pump();
  }

  void OnReadDone(bool ok) override {
    std::shared_ptr<Chunk> chunk;
    grpc::Status failed;
    if (ok) {
      // Only one read is ever outstanding: raw_chunk_ and the read-side counters are ours here.
      {
        std::lock_guard<std::mutex> lock(mu_);
        if (!spare_.empty()) {
          chunk = std::move(spare_.back());
          spare_.pop_back();
        }
      }
      if (!chunk) {
        chunk = std::make_shared<Chunk>();
        StreamChunkPool().Take(&chunk->message);  // arrays left by an earlier stream
      }
      failed = Accept(&chunk);
    }
    {
      std::lock_guard<std::mutex> lock(mu_);
      reading_ = false;
      if (!ok) {
        reads_done_ = true;
        // No more chunks: the client half-closed, or the call was cancelled.
        if (ctx_->IsCancelled() && !failure_)
          failure_ = grpc::Status(grpc::StatusCode::CANCELLED,
                                  "chunk " + std::to_string(read_index_) + ": call cancelled");
      } else if (!failed.ok()) {
        if (!failure_) failure_ = failed;
      } else if (!failure_) {
        waiting_.push_back(std::move(chunk));
      }
    }
    Pump();
  }

  void OnWriteDone(bool ok) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      writing_ = false;
      to_write_.pop_front();
      if (!ok) {
        write_failed_ = true;
        if (!failure_) failure_ = grpc::Status(grpc::StatusCode::CANCELLED, "client went away");
        to_write_.clear();
        waiting_.clear();
      }
    }
    Pump();
  }

  void OnDone() override {
    // No job is outstanding: the evaluated chunks' arrays go on to later streams.
    for (const std::shared_ptr<Chunk> &c : spare_) StreamChunkPool().Give(&c->message);
    delete this;
  }

 private:
  // A parsed chunk with the settings in force for it.
  struct Chunk {
    glint::v1::EvaluateChunk message;
    std::shared_ptr<const glint::v1::EvaluateRequest> settings;
    uint64_t index = 0, first_query = 0;
    Clock::time_point queued;
  };

  // Parses and checks the chunk just read (index, settings, admission) on gRPC's thread.
  grpc::Status Accept(std::shared_ptr<Chunk> *chunk) {
    Chunk &c = **chunk;
    if (Status s =
            ParseChunkReusing(&raw_chunk_, &c.message, "chunk " + std::to_string(read_index_));
        !s.ok())
      return ToGrpcStatus(s);
    if (c.message.chunk_index() != read_index_) {
      // Named by its place in the stream, like every other chunk refusal ("chunk N: ...").
      return ChunkStatus(
          read_index_,
          Status::InvalidArgument("chunk_index: got " + std::to_string(c.message.chunk_index()) +
                                  "; expected " + std::to_string(read_index_)));
    }
    if (c.message.request().has_material() || read_index_ == 0) {
      // The first chunk sets material, lights, precision and seed; a later
      // chunk that carries a material replaces them.
      // Copied without the queries (megabytes; the settings are a few hundred bytes).
      glint::v1::EvaluateRequest *request = c.message.mutable_request();
      std::unique_ptr<glint::v1::QueryBatch> queries(request->release_queries());
      auto settings = std::make_shared<glint::v1::EvaluateRequest>(*request);
      request->set_allocated_queries(queries.release());
      Status s = ValidateSettings(*settings, service_->options().limits);
      if (!s.ok()) return ChunkStatus(read_index_, s);
      settings_ = std::move(settings);
    } else if (Status s = ValidateLaterChunkSettings(c.message.request()); !s.ok()) {
      return ChunkStatus(read_index_, s);
    }
    if (c.message.request().has_shared_memory())
      return ChunkStatus(read_index_,
                         Status::InvalidArgument("request.shared_memory: only unary Evaluate reads "
                                                 "shared memory; a region needs no stream"));
    // Admitted by the cost of its own queries under the settings in force (a NORMAL_MAP chunk by
    // each query's footprint, named by its place in the stream), as a unary call would be.
    const glint::v1::QueryBatch &queries = c.message.request().queries();
    const uint32_t count = queries.count();
    if (Status s = service_->Admit(*settings_, queries, read_query_); !s.ok())
      return ChunkStatus(read_index_, s);
    c.settings = settings_;
    c.index = read_index_++;
    c.first_query = read_query_;
    read_query_ += count;
    return grpc::Status::OK;
  }

  // Decides under mu_ what to start next, then starts it.
  void Pump() {
    for (;;) {
      bool read = false, finish = false;
      const grpc::ByteBuffer *write = nullptr;
      std::shared_ptr<Chunk> submit;
      grpc::Status status;
      uint64_t answered = 0;
      {
        std::lock_guard<std::mutex> lock(mu_);
        if (finished_) return;
        answered = answered_;
        const size_t held = waiting_.size() + (computing_ ? 1 : 0) + to_write_.size();
        if (!reading_ && !reads_done_ && !failure_ && held < kDepth) read = reading_ = true;
        if (!computing_ && !waiting_.empty()) {
          submit = std::move(waiting_.front());
          waiting_.pop_front();
          computing_ = true;
        }
        if (!writing_ && !to_write_.empty()) {
          write = &to_write_.front();
          writing_ = true;
        }
        const bool idle = waiting_.empty() && !computing_ && to_write_.empty() && !writing_;
        if (idle && (failure_ || reads_done_)) {
          finish = finished_ = true;
          status = failure_ ? *failure_ : grpc::Status::OK;
        }
      }
      if (finish) {
        if (status.ok()) {
          std::ostringstream line;
          line << "EvaluateStream chunks=" << read_index_ << " n=" << read_query_
               << " total_ms=" << MsSince(start_) << " ok";
          service_->LogLine(line.str());
        } else {
          service_->LogLine("EvaluateStream refused at chunk " + std::to_string(answered) + ": " +
                            status.error_message());
        }
        Finish(status);
        return;
      }
      if (read) StartRead(&raw_chunk_);
      if (write) StartWrite(write);
      if (!submit) return;
      if (Submit(std::move(submit))) return;
      // Queue full: record the refusal and decide again.
      std::lock_guard<std::mutex> lock(mu_);
      computing_ = false;
      if (!failure_) {
        failure_ = ToGrpcStatus(OverloadStatus(service_->scheduler()));
        AddRetryPushback(ctx_, service_->options().slice_ms);
      }
      waiting_.clear();
    }
  }

  // Evaluates `chunk` on a worker; its result (or failure) is handed back under mu_.
  bool Submit(std::shared_ptr<Chunk> chunk) {
    chunk->queued = Clock::now();
    // A chunk still queued when the call dies gives up its slot and is answered as if it had
    // been stopped before its first slice.
    Scheduler::Dead dead = [this, chunk]() -> Scheduler::Respond {
      Status reason = service_->StopReason(ctx_);
      if (reason.ok()) return {};
      service_->abandoned().Count(reason, chunk->message.request().queries().count());
      return Answered(chunk, ChunkStatus(chunk->index, reason), grpc::ByteBuffer());
    };
    return service_->scheduler().TrySubmit(
        [this, chunk](int worker) -> Scheduler::Respond {
          if (Metrics *m = service_->options().metrics)
            m->ObserveQueueWait(MsSince(chunk->queued) / 1e3);
          // The device writes the radiance straight into a pooled reply slice, which the reply's
          // envelope wraps without a copy (proto/wire/chunk_result.h).
          const uint32_t count = chunk->message.request().queries().count();
          uint8_t *radiance = nullptr;
          grpc_slice slice = ReplyPool().Take(size_t(count) * 3 * sizeof(float), &radiance);
          glint::v1::EvaluateStats stats;
          // The engine's own code (INTERNAL for a device failure, INVALID_ARGUMENT for a bad
          // query, ...), exactly as the unary path would return it.
          Status s = service_->RunBatchInto(
              worker, *chunk->settings, chunk->message.request().queries(), chunk->first_query,
              true, reinterpret_cast<float *>(radiance), &stats, nullptr, ctx_);
          grpc::Status status = ChunkStatus(chunk->index, s);
          grpc::ByteBuffer reply;
          if (status.ok())
            reply = glint::wire::EncodeChunkResult(chunk->index, chunk->first_query, count, slice,
                                                   stats);
          else
            grpc_slice_unref(slice);
          return Answered(chunk, status, std::move(reply));
        },
        nullptr, std::move(dead));
  }

  // Hands a chunk's result (or failure) back under mu_ and decides what comes next.
  Scheduler::Respond Answered(std::shared_ptr<Chunk> chunk, grpc::Status status,
                              grpc::ByteBuffer reply) {
    return [this, chunk, status, reply = std::move(reply)]() mutable {
      {
        std::lock_guard<std::mutex> lock(mu_);
        computing_ = false;
        // Its arrays' memory serves a later chunk (ParseChunkReusing).
        if (spare_.size() < kDepth) spare_.push_back(std::move(chunk));
        if (status.ok() && !write_failed_) {
          // Also after a later chunk failed to read: this chunk came before it.
          to_write_.push_back(std::move(reply));
          ++answered_;
        } else if (!status.ok()) {
          if (!failure_) failure_ = status;
          waiting_.clear();  // the chunks after a failed one are not evaluated
        }
      }
      Pump();
    };
  }

  GlintServiceImpl *service_;
  grpc::CallbackServerContext *ctx_;
  Clock::time_point start_;
  grpc::ByteBuffer raw_chunk_;  // target of the one outstanding read
  // Read side (touched only by the one reaction that handles a read).
  std::shared_ptr<const glint::v1::EvaluateRequest> settings_;
  uint64_t read_index_ = 0;
  uint64_t read_query_ = 0;

  std::mutex mu_;
  bool reading_ = false, reads_done_ = false, computing_ = false, writing_ = false;
  bool finished_ = false, write_failed_ = false;
  std::optional<grpc::Status> failure_;
  std::deque<std::shared_ptr<Chunk>> waiting_;  // parsed, in order, not yet submitted
  std::vector<std::shared_ptr<Chunk>> spare_;   // evaluated chunks whose arrays are reused
  std::deque<grpc::ByteBuffer> to_write_;       // serialized results in order; front in flight
  uint64_t answered_ = 0;                       // results queued for writing
};

grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> *GlintServiceImpl::EvaluateStream(
    grpc::CallbackServerContext *ctx) {
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok())
    return new RefusedBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>(denied);
  return new StreamReactor(this, ctx);
}

grpc::ServerUnaryReactor *GlintServiceImpl::GetCapabilities(grpc::CallbackServerContext *ctx,
                                                            const grpc::ByteBuffer *body,
                                                            grpc::ByteBuffer *reply) {
  using Reactor = OwningUnaryReactor<glint::v1::GetCapabilitiesRequest, glint::v1::Capabilities>;
  auto *reactor = new Reactor(reply);
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok()) {
    reactor->Finish(denied);
    return reactor;
  }
  if (Status s = ParseBody(body, &reactor->request, "request"); !s.ok()) {
    reactor->Finish(ToGrpcStatus(s));
    return reactor;
  }
  glint::v1::Capabilities *c = &reactor->response;
  c->set_server_version(GLINT_VERSION);
  if (engine_) {
    const DeviceInfo &d = engine_->info();
    c->set_device_name(d.name);
    c->set_device_vendor(d.vendor);
    c->set_device_opencl_version(d.opencl_version);
    c->set_driver_version(d.driver_version);
    c->set_platform_name(d.platform_name);
    c->set_compute_units(d.compute_units);
    c->set_fp64(d.fp64);
  } else {
    c->set_device_name(DeviceName());
    c->set_platform_name("none (--device host)");
    c->set_compute_units(1);
    c->set_fp64(true);
  }
  for (const Model *model : Models()) c->add_models(model->name);
  for (const char *n : {"GGX", "BECKMANN"}) c->add_ndfs(n);
  for (const char *f : {"schlick", "conductor", "dielectric"}) c->add_fresnel_kinds(f);
  for (const char *l : {"directional", "point", "polygon"}) c->add_light_kinds(l);
  c->set_max_batch(options_.limits.max_batch);
  c->set_max_message_bytes(options_.max_message_bytes);
  c->set_max_lights(options_.limits.max_lights);
  c->set_max_pending_requests(uint32_t(scheduler_->max_pending()));
  c->set_unit_vector_tolerance(options_.limits.unit_tolerance);
  const NormalMapLimits nm = NormalMaps().limits();
  c->set_max_normal_map_upload_bytes(nm.max_upload_bytes);
  c->set_max_normal_map_texels(nm.max_texels);
  c->set_normal_map_budget_bytes(nm.budget_bytes);
  if (options_.shm) {
    c->set_max_shared_memory_regions(options_.shm->limits().max_regions);
    c->set_max_shared_memory_bytes(options_.shm->limits().max_bytes);
  }
  c->set_max_request_cost(options_.cost.max_request_cost);
  c->set_max_query_cost(options_.cost.max_query_cost);
  c->set_slice_ms(options_.slice_ms);
  c->set_batch_delay_us(uint32_t(scheduler_->batching().delay.count()));
  c->set_batch_max_queries(scheduler_->batching().max_queries);
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

}  // namespace glint
