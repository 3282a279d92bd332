#include "server/health_service.h"

namespace glint {

using grpc::health::v1::HealthCheckRequest;
using grpc::health::v1::HealthCheckResponse;

// One Watch call. Sends the newest status; a change that arrives while a write is in flight is
// sent when it completes (intermediate values may be skipped, as the spec allows).
class HealthService::Watcher : public grpc::ServerWriteReactor<HealthCheckResponse> {
 public:
  Watcher(HealthService *service, std::string name) : service_(service), name_(std::move(name)) {}

  void Update(ServingStatus status) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (finished_ || (sent_any_ && status == last_sent_ && !writing_)) return;
    pending_ = status;
    has_pending_ = true;
    if (!writing_) WriteLocked();
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard<std::mutex> lock(mutex_);
    writing_ = false;
    if (!ok) return FinishLocked(grpc::Status(grpc::StatusCode::CANCELLED, "watch ended"));
    if (has_pending_ && pending_ != last_sent_) WriteLocked();
  }

  void OnCancel() override {
    std::lock_guard<std::mutex> lock(mutex_);
    FinishLocked(grpc::Status(grpc::StatusCode::CANCELLED, "watch cancelled"));
  }

  void OnDone() override {
    {
      std::lock_guard<std::mutex> lock(service_->mutex_);
      service_->watchers_.erase(this);
    }
    delete this;
  }

  const std::string &name() const { return name_; }

 private:
  void WriteLocked() {
    response_.set_status(pending_);
    last_sent_ = pending_;
    sent_any_ = true;
    has_pending_ = false;
    writing_ = true;
    StartWrite(&response_);
  }
  void FinishLocked(const grpc::Status &s) {
    if (finished_) return;
    finished_ = true;
    Finish(s);
  }

  HealthService *service_;
  std::string name_;
  std::mutex mutex_;
  HealthCheckResponse response_;
  ServingStatus pending_ = HealthCheckResponse::UNKNOWN, last_sent_ = HealthCheckResponse::UNKNOWN;
  bool has_pending_ = false, writing_ = false, sent_any_ = false, finished_ = false;
};

HealthService::HealthService(const std::vector<std::string> &services)
    : names_(services.begin(), services.end()) {
  names_.insert("");
}

HealthService::ServingStatus HealthService::StatusOf(const std::string &service) const {
  if (!names_.count(service)) return HealthCheckResponse::SERVICE_UNKNOWN;
  return serving_ ? HealthCheckResponse::SERVING : HealthCheckResponse::NOT_SERVING;
}

void HealthService::SetServing(bool serving) {
  std::lock_guard<std::mutex> lock(mutex_);
  serving_ = serving;
  for (Watcher *w : watchers_) w->Update(StatusOf(w->name()));
}

bool HealthService::serving() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return serving_;
}

grpc::ServerUnaryReactor *HealthService::Check(grpc::CallbackServerContext *ctx,
                                               const HealthCheckRequest *request,
                                               HealthCheckResponse *response) {
  grpc::ServerUnaryReactor *reactor = ctx->DefaultReactor();
  ServingStatus status;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status = StatusOf(request->service());
  }
  if (status == HealthCheckResponse::SERVICE_UNKNOWN) {
    reactor->Finish(
        grpc::Status(grpc::StatusCode::NOT_FOUND, "unknown service '" + request->service() + "'"));
  } else {
    response->set_status(status);
    reactor->Finish(grpc::Status::OK);
  }
  return reactor;
}

grpc::ServerWriteReactor<HealthCheckResponse> *HealthService::Watch(
    grpc::CallbackServerContext *, const HealthCheckRequest *request) {
  auto *watcher = new Watcher(this, request->service());
  std::lock_guard<std::mutex> lock(mutex_);
  watchers_.insert(watcher);
  watcher->Update(StatusOf(request->service()));
  return watcher;
}

}  // namespace glint
