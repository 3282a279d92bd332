#include "server/metrics_interceptor.h"

#include <string>

namespace glint {
namespace {

class MetricsInterceptor final : public grpc::experimental::Interceptor {
 public:
  MetricsInterceptor(Metrics *metrics, const char *method)
      : metrics_(metrics), method_(method ? method : "") {}

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
