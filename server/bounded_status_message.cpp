#include "server/bounded_status_message.h"

namespace glint {

std::string BoundedStatusMessage(const std::string &message, size_t max_bytes) {
  if (message.size() <= max_bytes) return message;
  size_t cut = max_bytes;
  // Not inside a UTF-8 sequence: back off over continuation bytes (10xxxxxx).
  while (cut > 0 && (static_cast<unsigned char>(message[cut]) & 0xC0) == 0x80) --cut;
  return message.substr(0, cut) + "... (" + std::to_string(message.size()) + " bytes in all)";
}

namespace {

class BoundedStatusMessageInterceptor final : public grpc::experimental::Interceptor {
 public:
  void Intercept(grpc::experimental::InterceptorBatchMethods *methods) override {
    if (methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_STATUS)) {
      const grpc::Status sent = methods->GetSendStatus();
      if (sent.error_message().size() > kMaxStatusMessageBytes)
        methods->ModifySendStatus(grpc::Status(
            sent.error_code(), BoundedStatusMessage(sent.error_message()), sent.error_details()));
    }
    methods->Proceed();
  }
};

}  // namespace

grpc::experimental::Interceptor *BoundedStatusMessageInterceptorFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo *) {
  return new BoundedStatusMessageInterceptor;
}

}  // namespace glint
