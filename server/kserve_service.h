// The Open Inference Protocol (KServe v2) gRPC service, inference.GRPCInferenceService
// (proto/inference/grpc_service.proto), served on glintd's port beside glint.v1 so that
// Triton's perf_analyzer and KServe / Triton clients work unchanged. A model is a named
// material preset (server/kserve_models.h); ModelInfer turns its tensors into a glint.v1
// query batch (server/kserve_tensors.h) and runs it through GlintServiceImpl::RunBatch on the
// same scheduler: the same validation, limits and kernels as glint.v1 Evaluate, with
// bit-identical results.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "inference/grpc_service.grpc.pb.h"
#include "server/eval_plan.h"
#include "server/kserve_models.h"
#include "server/service.h"

namespace glint {

class KServeServiceImpl final : public inference::GRPCInferenceService::CallbackService {
 public:
  // `glint` evaluates (its scheduler, limits, engine, request log and bearer tokens: every RPC
  // but ServerLive/ServerReady, the protocol's health calls, needs a token when glintd has
  // --auth-tokens); it must outlive this.
  KServeServiceImpl(GlintServiceImpl *glint, std::vector<KServeModel> models);

  // ServerReady / ModelReady answer true only after this (glintd: when it reports SERVING).
  void SetReady(bool ready) { ready_ = ready; }

  // The kernel variant of each preset (queries without a world frame), without duplicates:
  // glintd warms them with the models' own (server/warmup.h) unless --warm none, so that a
  // model's first ModelInfer does not pay for PoCL's compile.
  std::vector<KernelSpec> WarmSpecs() const;
  // The presets whose requests use `spec`, for the warm-up's failure message: "--model preset
  // 'NAME' (FILE[,LIGHTS]), ..." in registration order, "" when none does.
  std::string PresetsUsing(const KernelSpec &spec) const;

  const std::vector<KServeModel> &models() const { return models_; }

  grpc::ServerUnaryReactor *ServerLive(grpc::CallbackServerContext *ctx,
                                       const inference::ServerLiveRequest *request,
                                       inference::ServerLiveResponse *response) override;
  grpc::ServerUnaryReactor *ServerReady(grpc::CallbackServerContext *ctx,
                                        const inference::ServerReadyRequest *request,
                                        inference::ServerReadyResponse *response) override;
  grpc::ServerUnaryReactor *ModelReady(grpc::CallbackServerContext *ctx,
                                       const inference::ModelReadyRequest *request,
                                       inference::ModelReadyResponse *response) override;
  grpc::ServerUnaryReactor *ServerMetadata(grpc::CallbackServerContext *ctx,
                                           const inference::ServerMetadataRequest *request,
                                           inference::ServerMetadataResponse *response) override;
  grpc::ServerUnaryReactor *ModelMetadata(grpc::CallbackServerContext *ctx,
                                          const inference::ModelMetadataRequest *request,
                                          inference::ModelMetadataResponse *response) override;
  grpc::ServerUnaryReactor *ModelConfig(grpc::CallbackServerContext *ctx,
                                        const inference::ModelConfigRequest *request,
                                        inference::ModelConfigResponse *response) override;
  grpc::ServerUnaryReactor *ModelStatistics(grpc::CallbackServerContext *ctx,
                                            const inference::ModelStatisticsRequest *request,
                                            inference::ModelStatisticsResponse *response) override;
  grpc::ServerUnaryReactor *ModelInfer(grpc::CallbackServerContext *ctx,
                                       const inference::ModelInferRequest *request,
                                       inference::ModelInferResponse *response) override;

 private:
  // Cumulative per-model counters for ModelStatistics (Triton's "statistics" extension).
  struct Stats {
    uint64_t last_inference_ms = 0;
    uint64_t success_count = 0, success_ns = 0;
    uint64_t fail_count = 0, fail_ns = 0;
    uint64_t queue_ns = 0, input_ns = 0, infer_ns = 0, output_ns = 0;  // successes only
  };
  struct Timings {
    uint64_t total_ns = 0, queue_ns = 0, input_ns = 0, infer_ns = 0, output_ns = 0;
  };

  // The model `name` at `version` ("" or "1"), or null with *status saying why.
  const KServeModel *Find(const std::string &name, const std::string &version,
                          grpc::Status *status) const;
  void Record(size_t model_index, bool ok, const Timings &t);

  GlintServiceImpl *glint_;
  std::vector<KServeModel> models_;
  std::atomic<bool> ready_{false};
  std::mutex stats_mutex_;
  std::vector<Stats> stats_;  // by index in models_
};

}  // namespace glint
