#include "server/metrics_interceptor.h"

#include <string>

#include "server/served_methods.h"

namespace glint {
namespace {

class MetricsInterceptor final : public grpc::experimental::Interceptor {
 public:
  // Paths no served service defines are counted under one label pair, "unknown/unknown": every
  // distinct path a client invents would otherwise add a series to /metrics for the life of the
  // server (unbounded memory and scrape size; tokens do not stop it, the interceptor runs first).
  MetricsInterceptor(Metrics *metrics, const char *method)
      : metrics_(metrics),
        method_(method && FindServedMethod(method) ? method : "/unknown/unknown") {}

  void Intercept(grpc::experimental::InterceptorBatchMethods *methods) override {
    if (methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_STATUS)) {
      metrics_->CountRpc(method_, methods->GetSendStatus().error_code());
    }
    methods->Proceed();
  }

 private:
  Metrics *metrics_;
  std::string method_;
};

}  // namespace

grpc::experimental::Interceptor *MetricsInterceptorFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo *info) {
  return new MetricsInterceptor(metrics_, info->method());
}

}  // namespace glint
