#include "server/unparsed_body_interceptor.h"

#include <string>

#include "server/served_methods.h"

namespace glint {
namespace {

using grpc::experimental::InterceptionHookPoints;

class UnparsedBodyInterceptor final : public grpc::experimental::Interceptor {
 public:
  UnparsedBodyInterceptor(const TokenAuth *auth, grpc::experimental::ServerRpcInfo *info)
      : auth_(auth), info_(info), method_(info->method() ? info->method() : "") {}

  void Intercept(grpc::experimental::InterceptorBatchMethods *methods) override {
    // Unary and server-streaming calls: gRPC deserialises the one request before the handler
    // and hands the interceptors null when that failed (or when no whole message arrived).
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE))
      unparsed_ = methods->GetRecvMessage() == nullptr;
    if (unparsed_ && methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      const grpc::Status sent = methods->GetSendStatus();
      if (sent.error_code() == grpc::StatusCode::UNIMPLEMENTED && sent.error_message().empty()) {
        grpc::Status denied;
        if (auth_ && !NeedsNoToken()) denied = CheckBearer(auth_, *info_->server_context());
        methods->ModifySendStatus(
            denied.ok() ? grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, Message()) : denied);
      }
    }
    methods->Proceed();
  }

 private:
  std::string Message() const {
    const google::protobuf::MethodDescriptor *m = FindServedMethod(method_);
    if (!m) return "request: the body does not parse as this method's request message";
    return "request: the body is not a whole " + m->input_type()->full_name() +
           " (truncated, or not this message); check that client and server use the same " +
           m->file()->name();
  }

  // The typed calls that answer without a token (server/health_service.h; KServe's health
  // calls, server/kserve_service.h).
  bool NeedsNoToken() const {
    return method_.rfind("/grpc.health.v1.Health/", 0) == 0 ||
           method_ == "/inference.GRPCInferenceService/ServerLive" ||
           method_ == "/inference.GRPCInferenceService/ServerReady";
  }

  const TokenAuth *auth_;
  grpc::experimental::ServerRpcInfo *info_;
  std::string method_;
  bool unparsed_ = false;
};

}  // namespace

grpc::experimental::Interceptor *UnparsedBodyInterceptorFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo *info) {
  return new UnparsedBodyInterceptor(auth_, info);
}

}  // namespace glint
