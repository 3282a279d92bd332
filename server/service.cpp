#include "server/service.h"

#include <chrono>
#include <cstdio>
#include <sstream>

#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/model_table.h"
#include "server/normal_map_store.h"

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

Status GlintServiceImpl::RunBatch(int worker, const glint::v1::EvaluateRequest &settings,
                                  const glint::v1::QueryBatch &queries, uint64_t first_query,
                                  bool streamed, glint::v1::EvaluateResponse *response,
                                  std::string *kernel) {
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
  if (engine_) {
    s = engine_->Evaluate(worker, plan, queries, out);
  } else {
    HostEvaluate(plan, queries, out);
  }
  response->mutable_stats()->set_compute_ms(MsSince(start));
  response->mutable_stats()->set_device(DeviceName());
  if (options_.metrics && s.ok())
    options_.metrics->CountEvaluated(ModelName(settings), queries.count(),
                                     response->stats().compute_ms() / 1e3);
  return s;
}

grpc::ServerUnaryReactor *GlintServiceImpl::Evaluate(grpc::CallbackServerContext *ctx,
                                                     const glint::v1::EvaluateRequest *request,
                                                     glint::v1::EvaluateResponse *response) {
  grpc::ServerUnaryReactor *reactor = ctx->DefaultReactor();
  const auto received = Clock::now();
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok()) {
    reactor->Finish(denied);
    return reactor;
  }
  Status s = ValidateSettings(*request, options_.limits);
  if (!s.ok()) {
    LogLine("Evaluate n=" + std::to_string(request->queries().count()) +
            " refused: " + s.message());
    reactor->Finish(ToGrpcStatus(s));
    return reactor;
  }
  bool queued = scheduler_->TrySubmit([this, reactor, request, response, received](int worker) {
    const double queue_ms = MsSince(received);
    if (options_.metrics) options_.metrics->ObserveQueueWait(queue_ms / 1e3);
    std::string kernel = "-";
    Status st = RunBatch(worker, *request, request->queries(), 0, false, response, &kernel);
    response->mutable_stats()->set_queue_ms(queue_ms);
    std::ostringstream line;
    line << "Evaluate n=" << request->queries().count() << " model=" << ModelName(*request)
         << " kernel=" << kernel << " queue_ms=" << queue_ms
         << " compute_ms=" << response->stats().compute_ms()
         << (st.ok() ? " ok" : " refused: " + st.message());
    LogLine(line.str());
    if (!st.ok()) response->Clear();
    return [reactor, st] { reactor->Finish(ToGrpcStatus(st)); };
  });
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
    : public grpc::ServerBidiReactor<glint::v1::EvaluateChunk, glint::v1::EvaluateChunkResult> {
 public:
  explicit StreamReactor(GlintServiceImpl *service) : service_(service), start_(Clock::now()) {
    StartRead(&chunk_);
  }

  void OnReadDone(bool ok) override {
    if (!ok) {  // the client half-closed (or cancelled): every chunk is answered
      std::ostringstream line;
      line << "EvaluateStream chunks=" << next_index_ << " n=" << next_query_
           << " total_ms=" << MsSince(start_) << " ok";
      service_->LogLine(line.str());
      Finish(grpc::Status::OK);
      return;
    }
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
    }
    submitted_ = Clock::now();
    bool queued = service_->scheduler().TrySubmit([this](int worker) -> Scheduler::Respond {
      if (Metrics *m = service_->options().metrics) m->ObserveQueueWait(MsSince(submitted_) / 1e3);
      result_.Clear();
      result_.set_chunk_index(next_index_);
      result_.set_first_query(next_query_);
      Status s = service_->RunBatch(worker, settings_, chunk_.request().queries(), next_query_,
                                    true, result_.mutable_result());
      // The engine's own code (INTERNAL for a device failure, INVALID_ARGUMENT for a bad
      // query, ...), exactly as the unary path would return it.
      if (!s.ok()) return [this, st = ChunkStatus(next_index_, s)] { Fail(st); };
      next_query_ += chunk_.request().queries().count();
      ++next_index_;
      return [this] { StartWrite(&result_); };
    });
    if (!queued) Fail(ToGrpcStatus(OverloadStatus(service_->scheduler())));
  }

  void OnWriteDone(bool ok) override {
    if (!ok) {
      Finish(grpc::Status(grpc::StatusCode::CANCELLED, "client went away"));
      return;
    }
    StartRead(&chunk_);
  }

  void OnDone() override { delete this; }

 private:
  void Fail(const grpc::Status &s) {
    service_->LogLine("EvaluateStream refused at chunk " + std::to_string(next_index_) + ": " +
                      s.error_message());
    Finish(s);
  }

  GlintServiceImpl *service_;
  Clock::time_point start_;
  Clock::time_point submitted_;  // when the current chunk was queued (queue-wait metric)
  glint::v1::EvaluateChunk chunk_;
  glint::v1::EvaluateRequest settings_;
  glint::v1::EvaluateChunkResult result_;
  uint64_t next_index_ = 0;
  uint64_t next_query_ = 0;
};

grpc::ServerBidiReactor<glint::v1::EvaluateChunk, glint::v1::EvaluateChunkResult>
    *GlintServiceImpl::EvaluateStream(grpc::CallbackServerContext *ctx) {
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok()) {
    return new RefusedBidiReactor<glint::v1::EvaluateChunk, glint::v1::EvaluateChunkResult>(denied);
  }
  return new StreamReactor(this);
}

grpc::ServerUnaryReactor *GlintServiceImpl::GetCapabilities(
    grpc::CallbackServerContext *ctx, const glint::v1::GetCapabilitiesRequest *,
    glint::v1::Capabilities *c) {
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok()) {
    auto *reactor = ctx->DefaultReactor();
    reactor->Finish(denied);
    return reactor;
  }
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
  auto *reactor = ctx->DefaultReactor();
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

}  // namespace glint
