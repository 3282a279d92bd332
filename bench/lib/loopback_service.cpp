#include "bench/lib/loopback_service.h"

#include <algorithm>

#include "server/malloc_policy.h"

namespace glint::bench {

namespace {

// glintd's malloc settings (server/malloc_policy.h), so that the end_to_end rows measure them;
// applied once, before the service's threads start.
bool MallocConfigured() {
  static const bool ok = ConfigureMallocForMessages();
  return ok;
}

ServiceOptions Options(const DeviceEngine *engine, ShmRegistry *shm) {
  (void)MallocConfigured();
  ServiceOptions o;
  o.shm = shm;
  o.log_requests = false;
  o.limits.fp64_available = engine->info().fp64;
  return o;
}

ShmLimits BenchShmLimits(bool direct_output) {
  ShmLimits l;
  l.direct_output = direct_output;
  return l;
}

}  // namespace

LoopbackService::LoopbackService(DeviceEngine *engine, glint::client::ClientOptions client_options,
                                 bool shm_direct_output)
    : shm_(BenchShmLimits(shm_direct_output)),
      scheduler_(1, 4),
      service_(engine, &scheduler_, Options(engine, &shm_)) {
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
  session_.reset();  // unregisters while the server still runs
  client_.reset();
  if (server_) server_->Shutdown();
}

grpc::Status LoopbackService::Evaluate(const glint::v1::EvaluateRequest &request,
                                       std::vector<float> *radiance,
                                       glint::client::EvaluateInfo *info) {
  return client_->Evaluate(request, radiance, {}, info);
}

grpc::Status LoopbackService::EvaluateShared(const glint::v1::EvaluateRequest &request,
                                             std::vector<float> *radiance,
                                             glint::client::EvaluateInfo *info) {
  if (!session_) session_ = std::make_unique<glint::client::ShmSession>(client_.get());
  return session_->Evaluate(request, radiance, {}, info);
}

grpc::Status LoopbackService::PrepareSharedInPlace(const glint::v1::EvaluateRequest &request) {
  if (!session_) session_ = std::make_unique<glint::client::ShmSession>(client_.get());
  const glint::v1::QueryBatch &q = request.queries();
  grpc::Status s = session_->PrepareInPlace(q, q.count(), &blocks_);
  if (!s.ok()) return s;
  auto put = [&](float *block, const google::protobuf::RepeatedField<float> &a) {
    if (block) std::copy(a.begin(), a.end(), block);
  };
  put(blocks_.uv, q.uv());
  put(blocks_.footprint, q.footprint());
  put(blocks_.wo, q.wo());
  put(blocks_.wi, q.wi());
  put(blocks_.position, q.position());
  put(blocks_.normal, q.normal());
  put(blocks_.tangent, q.tangent());
  return grpc::Status::OK;
}

grpc::Status LoopbackService::EvaluateSharedInPlace(const glint::v1::EvaluateRequest &request,
                                                    glint::client::EvaluateInfo *info) {
  return session_->EvaluateInPlace(request, info);
}

}  // namespace glint::bench
