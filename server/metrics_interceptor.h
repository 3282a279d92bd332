// Counts every RPC the server answers, by method and status code, into Metrics: a gRPC server
// interceptor sees the status as it is sent, for our service, health and reflection alike,
// without a hook in each handler's many exits.
#pragma once

#include <grpcpp/support/server_interceptor.h>

#include "server/metrics.h"

namespace glint {

class MetricsInterceptorFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit MetricsInterceptorFactory(Metrics *metrics) : metrics_(metrics) {}
  grpc::experimental::Interceptor *CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo *info) override;

 private:
  Metrics *metrics_;
};

}  // namespace glint
