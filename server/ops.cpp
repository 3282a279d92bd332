#include "server/ops.h"

#include <cstdio>
#include <cstdlib>
#include <utility>

#include "server/device_engine.h"
#include "server/metrics_interceptor.h"
#include "server/scheduler.h"

namespace glint {

const char kOpsUsage[] =
    "  --metrics-listen ADDR  serve Prometheus metrics at http://ADDR/metrics (HOST:PORT)\n";

bool ParseOpsFlag(int argc, char **argv, int *i, OpsFlags *flags) {
  const std::string a = argv[*i];
  std::string *target = nullptr;
  if (a == "--metrics-listen") target = &flags->metrics_listen;
  if (target == nullptr) return false;
  if (*i + 1 >= argc) {
    std::fprintf(stderr, "glintd: %s needs a value\n", a.c_str());
    std::exit(2);
  }
  *target = argv[++*i];
  return true;
}

Ops::Ops(OpsFlags flags) : flags_(std::move(flags)) {
  if (!flags_.metrics_listen.empty()) metrics_ = std::make_unique<Metrics>();
}

Ops::~Ops() = default;

void Ops::Configure(grpc::ServerBuilder *builder, const Scheduler *scheduler,
                    DeviceEngine *engine) {
  if (!metrics_) return;
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
  creators.push_back(std::make_unique<MetricsInterceptorFactory>(metrics_.get()));
  builder->experimental().SetInterceptorCreators(std::move(creators));
  metrics_->SetQueueDepthSource([scheduler] { return double(scheduler->pending()); },
                                double(scheduler->max_pending()));
  if (engine) {
    metrics_->SetProgramCacheSource([engine] {
      const ClRuntime &r = engine->runtime();
      ProgramCacheCounts c;
      c.memory_hits = uint64_t(r.programs_memory_hits());
      c.disk_hits = uint64_t(r.programs_loaded_from_disk());
      c.compiled = uint64_t(r.programs_compiled());
      return c;
    });
  }
}

bool Ops::Start(std::string *error) {
  if (!metrics_) return true;
  metrics_http_ = std::make_unique<MetricsHttpServer>();
  int port = 0;
  if (!metrics_http_->Start(flags_.metrics_listen, metrics_.get(), &port, error)) return false;
  const std::string host = flags_.metrics_listen.substr(0, flags_.metrics_listen.rfind(':'));
  std::fprintf(stderr, "glintd: metrics on http://%s:%d/metrics\n", host.c_str(), port);
  return true;
}

}  // namespace glint
