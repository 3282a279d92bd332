#include "server/service.h"

#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/proto_buffer_writer.h>

#include <chrono>
#include <cstdio>
#include <sstream>

#include "server/eval_plan.h"
#include "server/metadata_admission.h"
#include "server/model_table.h"
#include "server/normal_map_store.h"
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

// Parses a raw request body. gRPC has already checked the frame (length prefix, size limit);
// what fails here is the protobuf inside it: truncated, a wrong wire type, a length past the end.
// The body buffer is released once parsed: only the parsed message stays in memory.
Status ParseBody(const grpc::ByteBuffer *body, google::protobuf::Message *out,
                 const std::string &what) {
  auto *raw = const_cast<grpc::ByteBuffer *>(body);
  const size_t bytes = raw->Length();
  bool ok = false;
  {
    grpc::ProtoBufferReader reader(raw);
    ok = out->ParseFromZeroCopyStream(&reader);
  }
  raw->Clear();
  if (ok) return Status::Ok();
  return Status::InvalidArgument(what + ": the " + std::to_string(bytes) +
                                 "-byte body does not parse as a " + out->GetTypeName() +
                                 " (truncated, or not this message); check that client and "
                                 "server use the same proto/glint/v1/glint.proto");
}

// Serialises a response into the raw reply buffer.
grpc::Status SerializeReply(const google::protobuf::Message &message, grpc::ByteBuffer *out) {
  out->Clear();  // a stream reuses its reply buffer; the writer wants an empty one
  bool own = false;
  grpc::Status s = grpc::GenericSerialize<grpc::ProtoBufferWriter, google::protobuf::Message>(
      message, out, &own);
  return s;
}

// A unary call's reactor that owns its typed request and response (the methods are raw, see
// service.h); Finish serialises the response into the reply buffer.
template <class Request, class Response>
class OwningUnaryReactor : public grpc::ServerUnaryReactor {
 public:
  explicit OwningUnaryReactor(grpc::ByteBuffer *reply) : reply_(reply) {}
  Request request;
  Response response;
  void Finish(grpc::Status s) {
    if (s.ok()) s = SerializeReply(response, reply_);
    response.Clear();  // the serialised copy is what stays until the reply has left
    request.Clear();
    grpc::ServerUnaryReactor::Finish(s);
  }
  void OnDone() override { delete this; }

 private:
  grpc::ByteBuffer *reply_;
};

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

GlintServiceImpl::GlintServiceImpl(DeviceEngine *engine, Scheduler *scheduler,
                                   ServiceOptions options)
    : engine_(engine), scheduler_(scheduler), options_(std::move(options)) {}

std::string GlintServiceImpl::DeviceName() const {
  return engine_ ? engine_->info().name : std::string("host (scalar C++)");
}

void GlintServiceImpl::LogLine(const std::string &line) {
  if (!options_.log_requests) return;
  std::lock_guard<std::mutex> lock(log_mutex_);
  std::fprintf(stderr, "glintd: %s\n", line.c_str());
}

Status GlintServiceImpl::Admit(const glint::v1::EvaluateRequest &settings,
                               uint64_t query_count) const {
  if (shutting_down_)
    return Status::Unavailable(
        "server shutting down: no new work accepted; send to another "
        "replica");
  return CheckRequestCost(EstimateRequestCost(settings, query_count), query_count, options_.cost);
}

Status GlintServiceImpl::StopReason(grpc::CallbackServerContext *ctx) const {
  if (cancel_in_flight_)
    return Status::Unavailable(
        "server shutting down: work in flight cancelled after "
        "--shutdown-grace; retry on another replica");
  if (!ctx) return Status::Ok();
  if (ctx->IsCancelled()) return Status::Cancelled("the client cancelled the call");
  if (ctx->deadline() <= std::chrono::system_clock::now())
    return Status::DeadlineExceeded("the call's deadline passed before its work finished");
  return Status::Ok();
}

Status GlintServiceImpl::RunBatch(int worker, const glint::v1::EvaluateRequest &settings,
                                  const glint::v1::QueryBatch &queries, uint64_t first_query,
                                  bool streamed, glint::v1::EvaluateResponse *response,
                                  std::string *kernel, grpc::CallbackServerContext *ctx) {
  Status s =
      ValidateQueries(queries, settings.lights_size() > 0, options_.limits, first_query, streamed);
  if (s.ok()) s = ValidateQueriesForModel(queries, settings, first_query);
  if (!s.ok()) return s;
  EvalPlan plan = MakeEvalPlan(settings, queries);
  s = ResolveRequestTable(settings.material(), &plan);
  if (!s.ok()) return s;
  if (kernel) *kernel = plan.spec.Describe();
  const auto start = Clock::now();
  response->set_count(queries.count());
  response->mutable_radiance()->Resize(int(queries.count()) * 3, 0.0f);
  float *out = response->mutable_radiance()->mutable_data();
  SliceOptions slicing;
  slicing.per_query_cost = EstimateRequestCost(settings, 1).per_query;
  slicing.target_ms = options_.slice_ms;
  slicing.stop = [this, ctx] { return StopReason(ctx); };
  s = EvaluateSliced(engine_, worker, plan, queries, out, slicing);
  response->mutable_stats()->set_compute_ms(MsSince(start));
  response->mutable_stats()->set_device(DeviceName());
  if (options_.metrics && s.ok())
    options_.metrics->CountEvaluated(ModelName(settings), queries.count(),
                                     response->stats().compute_ms() / 1e3);
  return s;
}

grpc::ServerUnaryReactor *GlintServiceImpl::Evaluate(grpc::CallbackServerContext *ctx,
                                                     const grpc::ByteBuffer *body,
                                                     grpc::ByteBuffer *reply) {
  using Reactor = OwningUnaryReactor<glint::v1::EvaluateRequest, glint::v1::EvaluateResponse>;
  auto *reactor = new Reactor(reply);
  const glint::v1::EvaluateRequest *request = &reactor->request;
  glint::v1::EvaluateResponse *response = &reactor->response;
  const auto received = Clock::now();
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok()) {
    reactor->Finish(denied);
    return reactor;
  }
  // Full already: refused before the body is parsed (no second copy of it in memory).
  Status s = scheduler_->pending() >= scheduler_->max_pending() ? OverloadStatus(*scheduler_)
                                                                : Status::Ok();
  // The client's claim (query count, model) before the body is parsed.
  if (s.ok()) s = AdmitFromMetadata(*ctx, options_.limits, /*per_message=*/true);
  if (s.ok()) s = ParseBody(body, &reactor->request, "request");
  if (s.ok()) s = ValidateSettings(*request, options_.limits);
  if (s.ok()) s = Admit(*request, request->queries().count());
  if (!s.ok()) {
    LogLine("Evaluate n=" + std::to_string(request->queries().count()) +
            " refused: " + s.message());
    reactor->Finish(ToGrpcStatus(s));
    return reactor;
  }
  // Batchable: the scheduler may run it in one launch with others (RunEvaluateBatch) instead.
  auto member = MakeEvaluateMember(ctx, request, response, received, [reactor](const Status &st) {
    reactor->Finish(ToGrpcStatus(st));
  });
  bool queued = scheduler_->TrySubmit(
      [this, ctx, reactor, request, response, received](int worker) {
        const double queue_ms = MsSince(received);
        if (options_.metrics) options_.metrics->ObserveQueueWait(queue_ms / 1e3);
        std::string kernel = "-";
        Status st =
            RunBatch(worker, *request, request->queries(), 0, false, response, &kernel, ctx);
        response->mutable_stats()->set_queue_ms(queue_ms);
        std::ostringstream line;
        line << "Evaluate n=" << request->queries().count() << " model=" << ModelName(*request)
             << " kernel=" << kernel << " queue_ms=" << queue_ms
             << " compute_ms=" << response->stats().compute_ms()
             << (st.ok() ? " ok" : " refused: " + st.message());
        LogLine(line.str());
        if (!st.ok()) response->Clear();
        return [reactor, st] { reactor->Finish(ToGrpcStatus(st)); };
      },
      std::move(member));
  if (!queued) {
    Status busy = OverloadStatus(*scheduler_);
    LogLine("Evaluate n=" + std::to_string(request->queries().count()) + " " + busy.message());
    reactor->Finish(ToGrpcStatus(busy));
  }
  return reactor;
}

// One chunk in flight at a time: read, evaluate on a worker, write, read the
// next. Results therefore leave in chunk order, and the reactor is finished
// only when nothing is outstanding, so `delete this` in OnDone is safe.
class GlintServiceImpl::StreamReactor
    : public grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  StreamReactor(GlintServiceImpl *service, grpc::CallbackServerContext *ctx)
      : service_(service), ctx_(ctx), start_(Clock::now()) {
    // Refused before the first chunk's body is read where that is already known.
    if (service_->shutting_down_) {
      Fail(ToGrpcStatus(service_->Admit({}, 0)));
      return;
    }
    // A full server, or a refused claim in the call metadata: before the first chunk is read.
    if (service_->scheduler().pending() >= service_->scheduler().max_pending()) {
      Status busy = OverloadStatus(service_->scheduler());
      Fail(ToGrpcStatus(Status::ResourceExhausted(
          busy.message() + " (refused on opening the stream, before its first chunk was read)")));
      return;
    }
    if (Status s = AdmitFromMetadata(*ctx_, service_->options().limits, false); !s.ok()) {
      Fail(ToGrpcStatus(s));
      return;
    }
    StartRead(&raw_chunk_);
  }

  void OnReadDone(bool ok) override {
    if (!ok) {
      // No more chunks: the client half-closed (every chunk read has been answered, since one is
      // read only after the previous one's result was written) or the call was cancelled.
      if (ctx_->IsCancelled()) {
        return Fail(grpc::Status(grpc::StatusCode::CANCELLED,
                                 "chunk " + std::to_string(next_index_) + ": call cancelled"));
      }
      std::ostringstream line;
      line << "EvaluateStream chunks=" << next_index_ << " n=" << next_query_
           << " total_ms=" << MsSince(start_) << " ok";
      service_->LogLine(line.str());
      Finish(grpc::Status::OK);
      return;
    }
    if (Status s = ParseBody(&raw_chunk_, &chunk_, "chunk " + std::to_string(next_index_)); !s.ok())
      return Fail(ToGrpcStatus(s));
    if (chunk_.chunk_index() != next_index_) {
      return Fail(ToGrpcStatus(
          Status::InvalidArgument("chunk_index: got " + std::to_string(chunk_.chunk_index()) +
                                  "; expected " + std::to_string(next_index_))));
    }
    if (chunk_.request().has_material() || next_index_ == 0) {
      // The first chunk sets material, lights, precision and seed; a later
      // chunk that carries a material replaces them.
      settings_ = chunk_.request();
      settings_.clear_queries();
      Status s = ValidateSettings(settings_, service_->options().limits);
      if (!s.ok()) return Fail(ChunkStatus(next_index_, s));
    } else if (Status s = ValidateLaterChunkSettings(chunk_.request()); !s.ok()) {
      return Fail(ChunkStatus(next_index_, s));
    }
    if (Status s = service_->Admit(settings_, chunk_.request().queries().count()); !s.ok())
      return Fail(ChunkStatus(next_index_, s));
    submitted_ = Clock::now();
    bool queued = service_->scheduler().TrySubmit([this](int worker) -> Scheduler::Respond {
      if (Metrics *m = service_->options().metrics) m->ObserveQueueWait(MsSince(submitted_) / 1e3);
      result_.Clear();
      result_.set_chunk_index(next_index_);
      result_.set_first_query(next_query_);
      Status s = service_->RunBatch(worker, settings_, chunk_.request().queries(), next_query_,
                                    true, result_.mutable_result(), nullptr, ctx_);
      // The engine's own code (INTERNAL for a device failure, INVALID_ARGUMENT for a bad
      // query, ...), exactly as the unary path would return it.
      if (!s.ok()) return [this, st = ChunkStatus(next_index_, s)] { Fail(st); };
      next_query_ += chunk_.request().queries().count();
      ++next_index_;
      chunk_.Clear();
      grpc::Status ser = SerializeReply(result_, &raw_result_);
      result_.Clear();
      if (!ser.ok()) return [this, ser] { Fail(ser); };
      return [this] { StartWrite(&raw_result_); };
    });
    if (!queued) Fail(ToGrpcStatus(OverloadStatus(service_->scheduler())));
  }

  void OnWriteDone(bool ok) override {
    if (!ok) {
      Finish(grpc::Status(grpc::StatusCode::CANCELLED, "client went away"));
      return;
    }
    StartRead(&raw_chunk_);
  }

  void OnDone() override { delete this; }

 private:
  void Fail(const grpc::Status &s) {
    service_->LogLine("EvaluateStream refused at chunk " + std::to_string(next_index_) + ": " +
                      s.error_message());
    Finish(s);
  }

  GlintServiceImpl *service_;
  grpc::CallbackServerContext *ctx_;
  Clock::time_point start_;
  Clock::time_point submitted_;  // when the current chunk was queued (queue-wait metric)
  grpc::ByteBuffer raw_chunk_, raw_result_;
  glint::v1::EvaluateChunk chunk_;
  glint::v1::EvaluateRequest settings_;
  glint::v1::EvaluateChunkResult result_;
  uint64_t next_index_ = 0;
  uint64_t next_query_ = 0;
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
  c->set_max_request_cost(options_.cost.max_request_cost);
  c->set_max_query_cost(options_.cost.max_query_cost);
  c->set_slice_ms(options_.slice_ms);
  c->set_batch_delay_us(uint32_t(scheduler_->batching().delay.count()));
  c->set_batch_max_queries(scheduler_->batching().max_queries);
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

}  // namespace glint
