#include "bench/lib/loopback_service.h"

namespace glint::bench {

namespace {

ServiceOptions Options(const DeviceEngine *engine) {
  ServiceOptions o;
  o.log_requests = false;
  o.limits.fp64_available = engine->info().fp64;
  return o;
}

}  // namespace

LoopbackService::LoopbackService(DeviceEngine *engine, glint::client::ClientOptions client_options)
    : scheduler_(1, 4), service_(engine, &scheduler_, Options(engine)) {
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  const int max_bytes = int(service_.options().max_message_bytes);
  builder.SetMaxReceiveMessageSize(max_bytes);
  builder.SetMaxSendMessageSize(max_bytes);
  builder.RegisterService(&service_);
  server_ = builder.BuildAndStart();
  if (!server_ || port == 0) {
    server_.reset();
    return;
  }
  address_ = "127.0.0.1:" + std::to_string(port);
  client_ = std::make_unique<glint::client::GlintClient>(address_, client_options);
}

LoopbackService::~LoopbackService() {
  client_.reset();
  if (server_) server_->Shutdown();
}

grpc::Status LoopbackService::Evaluate(const glint::v1::EvaluateRequest &request,
                                       std::vector<float> *radiance,
                                       glint::client::EvaluateInfo *info) {
  return client_->Evaluate(request, radiance, {}, info);
}

}  // namespace glint::bench
