#include "server/unparsed_body_interceptor.h"

#include <string>

#include "server/served_methods.h"

namespace glint {
namespace {

using grpc::experimental::InterceptionHookPoints;

class UnparsedBodyInterceptor final : public grpc::experimental::Interceptor {
 public:
  explicit UnparsedBodyInterceptor(const char *method) : method_(method ? method : "") {}

  void Intercept(grpc::experimental::InterceptorBatchMethods *methods) override {
    // Unary and server-streaming calls: gRPC deserialises the one request before the handler
    // and hands the interceptors null when that failed (or when no whole message arrived).
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE))
      unparsed_ = methods->GetRecvMessage() == nullptr;
    if (unparsed_ && methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      const grpc::Status sent = methods->GetSendStatus();
      if (sent.error_code() == grpc::StatusCode::UNIMPLEMENTED && sent.error_message().empty())
        methods->ModifySendStatus(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, Message()));
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

  std::string method_;
  bool unparsed_ = false;
};

}  // namespace

grpc::experimental::Interceptor *UnparsedBodyInterceptorFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo *info) {
  return new UnparsedBodyInterceptor(info->method());
}

}  // namespace glint
