#include "server/kserve_service.h"

#include <algorithm>
#include <chrono>
#include <sstream>

#include "server/auth.h"
#include "server/counted_reactor.h"
#include "server/eval_plan.h"
#include "server/kserve_tensors.h"
#include "server/model_table.h"
#include "server/request_cost.h"

namespace glint {
namespace {

using Clock = std::chrono::steady_clock;

// The one version of every model: presets are not versioned.
constexpr const char *kModelVersion = "1";
constexpr const char *kPlatform = "glint";

uint64_t NsBetween(Clock::time_point a, Clock::time_point b) {
  return uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(b - a).count());
}

grpc::ServerUnaryReactor *Done(grpc::CallbackServerContext *ctx, const grpc::Status &status) {
  grpc::ServerUnaryReactor *reactor = ctx->DefaultReactor();
  reactor->Finish(status);
  return reactor;
}

bool HasLights(const KServeModel &model) {
  return model.settings.lights_size() > 0;
}

}  // namespace

KServeServiceImpl::KServeServiceImpl(GlintServiceImpl *glint, std::vector<KServeModel> models)
    : glint_(glint), models_(std::move(models)), stats_(models_.size()) {}

namespace {
// The kernel variant a preset's ModelInfer requests use (queries without a world frame).
KernelSpec PresetSpec(const KServeModel &model) {
  glint::v1::QueryBatch one;  // the spec depends on which arrays are present, not values
  one.set_count(1);
  for (float v : {0.0f, 0.0f, 1.0f}) one.add_wo(v);
  if (!HasLights(model))
    for (float v : {0.0f, 0.0f, 1.0f}) one.add_wi(v);
  return MakeEvalPlan(model.settings, one).spec;
}
}  // namespace

std::vector<KernelSpec> KServeServiceImpl::WarmSpecs() const {
  std::vector<KernelSpec> specs;
  for (const KServeModel &model : models_) {
    const KernelSpec spec = PresetSpec(model);
    if (std::find(specs.begin(), specs.end(), spec) == specs.end()) specs.push_back(spec);
  }
  return specs;
}

std::string KServeServiceImpl::PresetsUsing(const KernelSpec &spec) const {
  std::string names;
  int count = 0;
  for (const KServeModel &model : models_) {
    if (!(PresetSpec(model) == spec)) continue;
    names += count++ == 0 ? "" : ", ";
    names += "'" + model.name + "' (" + model.source + ")";
  }
  if (count == 0) return "";
  return (count == 1 ? "--model preset " : "--model presets ") + names;
}

const KServeModel *KServeServiceImpl::Find(const std::string &name, const std::string &version,
                                           grpc::Status *status) const {
  for (const KServeModel &model : models_) {
    if (model.name != name) continue;
    if (!version.empty() && version != kModelVersion) {
      *status = grpc::Status(grpc::StatusCode::NOT_FOUND,
                             "model '" + name + "' has no version '" + version +
                                 "'; glintd serves version 1 only (or give none)");
      return nullptr;
    }
    return &model;
  }
  std::string known;
  for (const KServeModel &model : models_) known += (known.empty() ? "" : ", ") + model.name;
  *status = grpc::Status(
      grpc::StatusCode::NOT_FOUND,
      "model '" + name + "': unknown; registered models: " +
          (known.empty() ? "none (start glintd with --model NAME=MATERIAL.json)" : known));
  return nullptr;
}

void KServeServiceImpl::Record(size_t model_index, bool ok, const Timings &t) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  Stats &s = stats_[model_index];
  s.last_inference_ms = uint64_t(std::chrono::duration_cast<std::chrono::milliseconds>(
                                     std::chrono::system_clock::now().time_since_epoch())
                                     .count());
  if (!ok) {
    ++s.fail_count;
    s.fail_ns += t.total_ns;
    return;
  }
  ++s.success_count;
  s.success_ns += t.total_ns;
  s.queue_ns += t.queue_ns;
  s.input_ns += t.input_ns;
  s.infer_ns += t.infer_ns;
  s.output_ns += t.output_ns;
}

grpc::ServerUnaryReactor *KServeServiceImpl::ServerLive(grpc::CallbackServerContext *ctx,
                                                        const inference::ServerLiveRequest *,
                                                        inference::ServerLiveResponse *response) {
  response->set_live(true);
  return Done(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor *KServeServiceImpl::ServerReady(grpc::CallbackServerContext *ctx,
                                                         const inference::ServerReadyRequest *,
                                                         inference::ServerReadyResponse *response) {
  response->set_ready(ready_);
  return Done(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor *KServeServiceImpl::ModelReady(grpc::CallbackServerContext *ctx,
                                                        const inference::ModelReadyRequest *request,
                                                        inference::ModelReadyResponse *response) {
  if (grpc::Status denied = CheckBearer(glint_->options().auth, *ctx); !denied.ok())
    return Done(ctx, denied);
  grpc::Status unused;
  response->set_ready(ready_ && Find(request->name(), request->version(), &unused) != nullptr);
  return Done(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor *KServeServiceImpl::ServerMetadata(
    grpc::CallbackServerContext *ctx, const inference::ServerMetadataRequest *,
    inference::ServerMetadataResponse *response) {
  if (grpc::Status denied = CheckBearer(glint_->options().auth, *ctx); !denied.ok())
    return Done(ctx, denied);
  response->set_name("glintd");
  response->set_version(GLINT_VERSION);
  response->add_extensions("model_configuration");
  response->add_extensions("statistics");
  return Done(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor *KServeServiceImpl::ModelMetadata(
    grpc::CallbackServerContext *ctx, const inference::ModelMetadataRequest *request,
    inference::ModelMetadataResponse *response) {
  if (grpc::Status denied = CheckBearer(glint_->options().auth, *ctx); !denied.ok())
    return Done(ctx, denied);
  grpc::Status status;
  const KServeModel *model = Find(request->name(), request->version(), &status);
  if (!model) return Done(ctx, status);
  response->set_name(model->name);
  response->add_versions(kModelVersion);
  response->set_platform(kPlatform);
  for (const KServeInput &in : KServeInputs(HasLights(*model))) {
    auto *t = response->add_inputs();
    t->set_name(in.name);
    t->set_datatype("FP32");
    t->add_shape(-1);
    t->add_shape(in.width);
  }
  auto *out = response->add_outputs();
  out->set_name("radiance");
  out->set_datatype("FP32");
  out->add_shape(-1);
  out->add_shape(3);
  return Done(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor *KServeServiceImpl::ModelConfig(
    grpc::CallbackServerContext *ctx, const inference::ModelConfigRequest *request,
    inference::ModelConfigResponse *response) {
  if (grpc::Status denied = CheckBearer(glint_->options().auth, *ctx); !denied.ok())
    return Done(ctx, denied);
  grpc::Status status;
  const KServeModel *model = Find(request->name(), request->version(), &status);
  if (!model) return Done(ctx, status);
  inference::ModelConfig *config = response->mutable_config();
  config->set_name(model->name);
  config->set_platform(kPlatform);
  // 0: no batch dimension of Triton's kind; the row count of the [-1, k] tensors is the batch.
  config->set_max_batch_size(0);
  for (const KServeInput &in : KServeInputs(HasLights(*model))) {
    inference::ModelInput *t = config->add_input();
    t->set_name(in.name);
    t->set_data_type(inference::TYPE_FP32);
    t->add_dims(-1);
    t->add_dims(in.width);
    // perf_analyzer generates data only for the required inputs and those its data names.
    t->set_optional(!in.required);
  }
  inference::ModelOutput *out = config->add_output();
  out->set_name("radiance");
  out->set_data_type(inference::TYPE_FP32);
  out->add_dims(-1);
  out->add_dims(3);
  return Done(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor *KServeServiceImpl::ModelStatistics(
    grpc::CallbackServerContext *ctx, const inference::ModelStatisticsRequest *request,
    inference::ModelStatisticsResponse *response) {
  if (grpc::Status denied = CheckBearer(glint_->options().auth, *ctx); !denied.ok())
    return Done(ctx, denied);
  if (!request->name().empty()) {
    grpc::Status status;
    if (!Find(request->name(), request->version(), &status)) return Done(ctx, status);
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  for (size_t i = 0; i < models_.size(); ++i) {
    if (!request->name().empty() && models_[i].name != request->name()) continue;
    const Stats &s = stats_[i];
    inference::ModelStatistics *m = response->add_model_stats();
    m->set_name(models_[i].name);
    m->set_version(kModelVersion);
    m->set_last_inference(s.last_inference_ms);
    m->set_inference_count(s.success_count);
    m->set_execution_count(s.success_count);
    inference::InferStatistics *is = m->mutable_inference_stats();
    auto set = [](inference::StatisticDuration *d, uint64_t count, uint64_t ns) {
      d->set_count(count);
      d->set_ns(ns);
    };
    set(is->mutable_success(), s.success_count, s.success_ns);
    set(is->mutable_fail(), s.fail_count, s.fail_ns);
    set(is->mutable_queue(), s.success_count, s.queue_ns);
    set(is->mutable_compute_input(), s.success_count, s.input_ns);
    set(is->mutable_compute_infer(), s.success_count, s.infer_ns);
    set(is->mutable_compute_output(), s.success_count, s.output_ns);
  }
  return Done(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor *KServeServiceImpl::ModelInfer(grpc::CallbackServerContext *ctx,
                                                        const inference::ModelInferRequest *request,
                                                        inference::ModelInferResponse *response) {
  if (grpc::Status denied = CheckBearer(glint_->options().auth, *ctx); !denied.ok())
    return Done(ctx, denied);
  const auto received = Clock::now();
  grpc::Status status;
  const KServeModel *model = Find(request->model_name(), request->model_version(), &status);
  if (!model) {
    glint_->LogLine("ModelInfer refused: " + status.error_message());
    return Done(ctx, status);
  }
  const size_t model_index = size_t(model - models_.data());
  auto refuse = [&](const Status &s) {
    Timings t;
    t.total_ns = NsBetween(received, Clock::now());
    Record(model_index, false, t);
    glint_->LogLine("ModelInfer model=" + model->name + " refused: " + s.message());
    return Done(ctx, ToGrpcStatus(s));
  };
  // Replies not yet taken by their clients are bounded as Evaluate's (--max-undelivered-mb).
  if (Status full = glint_->undelivered().Admit(); !full.ok()) {
    AddRetryPushback(ctx, glint_->options().slice_ms);
    return refuse(full);
  }
  // The settings (preset + parameter overrides) are checked here, on gRPC's thread, as
  // Evaluate does; the tensors are decoded and validated on the worker.
  auto settings = std::make_shared<glint::v1::EvaluateRequest>(model->settings);
  Status s = ApplyInferParameters(*request, settings.get());
  if (s.ok()) s = ValidateSettings(*settings, glint_->options().limits);
  if (s.ok()) s = CheckRequestedOutputs(*request);
  if (s.ok()) s = CheckTensorParameters(*request);
  // wo's rows, refused here (INVALID_ARGUMENT naming 'wo') when its shape does not describe its
  // data: admission charges the shape, and a bad request must not be queued or told to retry.
  uint64_t rows = 0;
  if (s.ok()) s = InferQueryCount(*request, &rows);
  // Evaluate's admission (GlintServiceImpl::AdmitCount; a NORMAL_MAP preset is admitted once its
  // queries are decoded): UNAVAILABLE while shutting down, then
  // --max-query-cost and --max-request-cost for wo's row count, before the job is queued. (It
  // was missing: a REFERENCE 1024 request over a polygon preset, refused by Evaluate, held a
  // worker for its whole run.)
  if (s.ok()) s = glint_->AdmitCount(*settings, rows);
  if (!s.ok()) return refuse(s);

  // The reply counts in --max-undelivered-mb until it has left; a cancelled call leaves the
  // queue at once (server/counted_reactor.h).
  auto *reactor = new CountedUnaryReactor(request, response, &glint_->undelivered(),
                                          [this] { glint_->scheduler().DropDeadJobs(); });
  const bool queued = glint_->scheduler().TrySubmit(
      [this, ctx, reactor, request, response, settings, model, model_index,
       received](int worker) -> Scheduler::Respond {
        Timings t;
        const auto started = Clock::now();
        t.queue_ns = NsBetween(received, started);
        glint::v1::QueryBatch queries;
        Status st = DecodeInferInputs(*request, HasLights(*model), &queries);
        const uint32_t max_batch = glint_->options().limits.max_batch;
        if (st.ok() && queries.count() > max_batch) {
          st = Status::InvalidArgument("input 'wo': " + std::to_string(queries.count()) +
                                       " rows exceed the limit of " + std::to_string(max_batch) +
                                       " queries per ModelInfer call (glintd --max-batch); split "
                                       "the request");
        }
        // A model whose cost depends on each query (NORMAL_MAP's footprints) is admitted again
        // now that the tensors are decoded, by Evaluate's per-query cost (server/request_cost.h
        // EstimateQueriesCost); the count-based check before queueing covered the others. Only
        // the cost: a call queued before shutdown began still runs during --shutdown-grace, as
        // every queued glint.v1 call does.
        const Model *costed = FindModel(settings->material().model());
        if (st.ok() && costed && costed->query_costs)
          st = CheckRequestCost(EstimateQueriesCost(*settings, queries), queries.count(),
                                glint_->options().cost);
        const auto decoded = Clock::now();
        t.input_ns = NsBetween(started, decoded);
        glint::v1::EvaluateResponse evaluated;
        std::string kernel = "-";
        if (st.ok()) {
          // With the call's context, so its slices stop once the client cancels or the deadline
          // passes (without it, an abandoned call held its worker to the end).
          st = glint_->RunBatch(worker, *settings, queries, 0, false, &evaluated, &kernel, ctx);
          if (st.code() == Status::Code::kInvalidArgument)
            st = Status::InvalidArgument(InferMessage(st.message()));
        }
        const auto computed = Clock::now();
        // Without the build of a cold kernel variant (EvaluateStats.compile_ms), so perf_analyzer's
        // "server compute" is the evaluation alone; the build stays in the request's total.
        const uint64_t compile_ns = uint64_t(evaluated.stats().compile_ms() * 1e6);
        t.infer_ns = NsBetween(decoded, computed);
        t.infer_ns = t.infer_ns > compile_ns ? t.infer_ns - compile_ns : 0;
        if (st.ok()) {
          response->set_model_name(model->name);
          response->set_model_version(kModelVersion);
          response->set_id(request->id());
          EncodeRadiance(evaluated.radiance().data(), evaluated.count(), response);
        } else {
          response->Clear();
        }
        const auto encoded = Clock::now();
        t.output_ns = NsBetween(computed, encoded);
        t.total_ns = NsBetween(received, encoded);
        Record(model_index, st.ok(), t);
        std::ostringstream line;
        line << "ModelInfer model=" << model->name << " n=" << queries.count()
             << " kernel=" << kernel << " queue_ms=" << double(t.queue_ns) * 1e-6
             << " compile_ms=" << evaluated.stats().compile_ms()
             << " compute_ms=" << double(t.infer_ns) * 1e-6
             << (st.ok() ? " ok" : " refused: " + st.message());
        glint_->LogLine(line.str());
        return [reactor, st] { reactor->Finish(ToGrpcStatus(st)); };
      },
      nullptr,
      glint_->DeadCall(ctx, "ModelInfer model=" + model->name, rows,
                       [this, reactor, model_index, received](const Status &st) {
                         Timings t;
                         t.total_ns = NsBetween(received, Clock::now());
                         Record(model_index, false, t);
                         reactor->Finish(ToGrpcStatus(st));
                       }));
  if (!queued) {
    Status busy = OverloadStatus(glint_->scheduler());
    Timings t;
    t.total_ns = NsBetween(received, Clock::now());
    Record(model_index, false, t);
    glint_->LogLine("ModelInfer model=" + model->name + " " + busy.message());
    AddRetryPushback(ctx, glint_->options().slice_ms);
    reactor->Finish(ToGrpcStatus(busy));
  }
  return reactor;
}

}  // namespace glint
