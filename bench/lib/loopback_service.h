// glintd's service in this process on a free loopback port, evaluating on a given device engine,
// with the client library connected to it: the `end_to_end` path of bench_models (protobuf
// encoding and gRPC transfer both ways, unary or streamed as the client library picks), without
// starting a second process that would compile its own kernels.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>
#include <vector>

#include "client/lib/glint_client.h"
#include "client/lib/shm_transport.h"
#include "server/device_engine.h"
#include "server/scheduler.h"
#include "server/service.h"
#include "server/shm_regions.h"

namespace glint::bench {

class LoopbackService {
 public:
  // Serves on `engine` (one worker: the caller must not use the engine while a call runs).
  // `shm_direct_output`: glintd --shm-direct-output for the shared-memory path.
  explicit LoopbackService(DeviceEngine *engine, glint::client::ClientOptions client_options = {},
                           bool shm_direct_output = false);
  ~LoopbackService();
  bool ok() const { return server_ != nullptr; }
  const std::string &address() const { return address_; }

  // One Evaluate through the client library; info says whether it streamed.
  grpc::Status Evaluate(const glint::v1::EvaluateRequest &request, std::vector<float> *radiance,
                        glint::client::EvaluateInfo *info = nullptr);
  // The same through same-host shared memory (the `shared_memory` path): one region registered
  // on first use and reused (client/lib/shm_transport.h ShmSession); the timed call packs the
  // queries into it, sends the small request, and copies the radiance out.
  grpc::Status EvaluateShared(const glint::v1::EvaluateRequest &request,
                              std::vector<float> *radiance,
                              glint::client::EvaluateInfo *info = nullptr);
  // Zero-copy shared memory (ShmSession::PrepareInPlace): PrepareSharedInPlace writes the
  // request's queries into the session's region (untimed, as an application producing them
  // there would), EvaluateSharedInPlace sends the call; the radiance is left in the region
  // (SharedRadiance, 3 floats per query).
  grpc::Status PrepareSharedInPlace(const glint::v1::EvaluateRequest &request);
  grpc::Status EvaluateSharedInPlace(const glint::v1::EvaluateRequest &request,
                                     glint::client::EvaluateInfo *info = nullptr);
  const float *SharedRadiance() const { return blocks_.radiance; }

 private:
  glint::client::ShmSession::InPlaceBlocks blocks_;
  ShmRegistry shm_;
  Scheduler scheduler_;
  GlintServiceImpl service_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
  std::unique_ptr<glint::client::GlintClient> client_;
  std::unique_ptr<glint::client::ShmSession> session_;
};

}  // namespace glint::bench
