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
#include "server/device_engine.h"
#include "server/scheduler.h"
#include "server/service.h"

namespace glint::bench {

class LoopbackService {
 public:
  // Serves on `engine` (one worker: the caller must not use the engine while a call runs).
  explicit LoopbackService(DeviceEngine *engine, glint::client::ClientOptions client_options = {});
  ~LoopbackService();
  bool ok() const { return server_ != nullptr; }
  const std::string &address() const { return address_; }

  // One Evaluate through the client library; info says whether it streamed.
  grpc::Status Evaluate(const glint::v1::EvaluateRequest &request, std::vector<float> *radiance,
                        glint::client::EvaluateInfo *info = nullptr);

 private:
  Scheduler scheduler_;
  GlintServiceImpl service_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
  std::unique_ptr<glint::client::GlintClient> client_;
};

}  // namespace glint::bench
