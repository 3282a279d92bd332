// grpc.health.v1.Health, our own instead of gRPC's default service: the default one is created
// inside Server::Start with "" already SERVING, so a check that arrives between the port being
// bound and the first SetServingStatus(false) sees SERVING before any kernel is warm. Here every
// registered name starts NOT_SERVING and only SetServing(true) (after warm-up) changes that.
// Check answers a registered name's status (NOT_FOUND for others, as the spec says); Watch sends
// the current status, then every change, until the client cancels or the server shuts down.
#pragma once

#include <grpcpp/grpcpp.h>

#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "grpc/health/v1/health.grpc.pb.h"

namespace glint {

class HealthService final : public grpc::health::v1::Health::CallbackService {
 public:
  // `services`: the names answered besides "" (the whole server), e.g. "glint.v1.GlintService".
  explicit HealthService(const std::vector<std::string> &services);

  // Every registered name (and "") becomes SERVING or NOT_SERVING.
  void SetServing(bool serving);
  bool serving() const;

  grpc::ServerUnaryReactor *Check(grpc::CallbackServerContext *ctx,
                                  const grpc::health::v1::HealthCheckRequest *request,
                                  grpc::health::v1::HealthCheckResponse *response) override;
  grpc::ServerWriteReactor<grpc::health::v1::HealthCheckResponse> *Watch(
      grpc::CallbackServerContext *ctx,
      const grpc::health::v1::HealthCheckRequest *request) override;

 private:
  class Watcher;
  using ServingStatus = grpc::health::v1::HealthCheckResponse::ServingStatus;
  ServingStatus StatusOf(const std::string &service) const;  // under mutex_

  mutable std::mutex mutex_;
  std::set<std::string> names_;
  bool serving_ = false;
  std::set<Watcher *> watchers_;
};

}  // namespace glint
