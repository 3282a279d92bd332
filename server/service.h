// The gRPC service glint.v1.GlintService on the callback API: handlers
// validate nothing themselves and run nothing heavy; they hand a job to the
// Scheduler and finish the RPC from the worker that ran it.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <memory>
#include <string>

#include "glint/v1/glint.grpc.pb.h"
#include "server/auth.h"
#include "server/device_engine.h"
#include "server/metrics.h"
#include "server/scheduler.h"
#include "server/validation.h"

namespace glint {

struct ServiceOptions {
  ValidationLimits limits;
  uint64_t max_message_bytes = 64ull << 20;
  bool log_requests = true;
  Metrics *metrics = nullptr;       // --metrics-listen; null: no metric hooks
  const TokenAuth *auth = nullptr;  // --auth-tokens; null: every call is let through
};

// Evaluates on the OpenCL engine, or on the host path when engine is null.
class GlintServiceImpl final : public glint::v1::GlintService::CallbackService {
 public:
  GlintServiceImpl(DeviceEngine *engine, Scheduler *scheduler, ServiceOptions options);

  grpc::ServerUnaryReactor *Evaluate(grpc::CallbackServerContext *ctx,
                                     const glint::v1::EvaluateRequest *request,
                                     glint::v1::EvaluateResponse *response) override;
  grpc::ServerBidiReactor<glint::v1::EvaluateChunk, glint::v1::EvaluateChunkResult> *EvaluateStream(
      grpc::CallbackServerContext *ctx) override;
  grpc::ServerUnaryReactor *GetCapabilities(grpc::CallbackServerContext *ctx,
                                            const glint::v1::GetCapabilitiesRequest *request,
                                            glint::v1::Capabilities *response) override;
  // Importance sampling (server/sample_service.cpp, server/sample.h).
  grpc::ServerUnaryReactor *Sample(grpc::CallbackServerContext *ctx,
                                   const glint::v1::SampleRequest *request,
                                   glint::v1::SampleResponse *response) override;
  // Normal-map resources (server/normal_map_rpc.cpp, the store in server/normal_map_store.h).
  grpc::ServerReadReactor<glint::v1::NormalMapChunk> *UploadNormalMap(
      grpc::CallbackServerContext *ctx, glint::v1::NormalMapInfo *response) override;
  grpc::ServerUnaryReactor *ListNormalMaps(grpc::CallbackServerContext *ctx,
                                           const glint::v1::ListNormalMapsRequest *request,
                                           glint::v1::ListNormalMapsResponse *response) override;
  grpc::ServerUnaryReactor *DeleteNormalMap(grpc::CallbackServerContext *ctx,
                                            const glint::v1::DeleteNormalMapRequest *request,
                                            glint::v1::DeleteNormalMapResponse *response) override;

  // Validates `queries` against `settings` (already validated) and evaluates
  // them on `worker`'s queue, filling response->radiance. `kernel`, if given, receives
  // the kernel variant that ran (for the request log).
  Status RunBatch(int worker, const glint::v1::EvaluateRequest &settings,
                  const glint::v1::QueryBatch &queries, uint64_t first_query, bool streamed,
                  glint::v1::EvaluateResponse *response, std::string *kernel = nullptr);

  Scheduler &scheduler() { return *scheduler_; }
  const ServiceOptions &options() const { return options_; }
  void LogLine(const std::string &line);

 private:
  class StreamReactor;
  std::string DeviceName() const;

  DeviceEngine *engine_;
  Scheduler *scheduler_;
  ServiceOptions options_;
  std::mutex log_mutex_;
};

// The one mapping from the engine's Status to gRPC's: unary calls finish with it as is.
grpc::Status ToGrpcStatus(const Status &status);

// A failed stream chunk: the same code as ToGrpcStatus (so a device failure is INTERNAL, not the
// client's fault), the message prefixed with "chunk N: ".
grpc::Status ChunkStatus(uint64_t chunk_index, const Status &status);

// The message a client gets when the queue is full.
Status OverloadStatus(const Scheduler &scheduler);

}  // namespace glint
