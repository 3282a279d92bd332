// glintd's operations features, kept out of main.cpp: their flags, the /metrics endpoint and
// the gRPC server hooks they need. main.cpp parses the flags with ParseOpsFlag, builds one Ops,
// and calls Configure on the ServerBuilder and Start once the server runs.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "server/metrics.h"
#include "server/metrics_http.h"

namespace glint {

class DeviceEngine;
class Scheduler;

struct OpsFlags {
  std::string metrics_listen;  // HOST:PORT of the Prometheus endpoint; "" = none
};

// The usage lines of the flags below, appended to glintd --help.
extern const char kOpsUsage[];

// If argv[*i] is one of the ops flags, consumes it (and its value, advancing *i) into `flags`
// and returns true. A flag without its value exits with status 2, as glintd's other flags do.
bool ParseOpsFlag(int argc, char **argv, int *i, OpsFlags *flags);

class Ops {
 public:
  explicit Ops(OpsFlags flags);
  ~Ops();

  // Null when --metrics-listen is not given: the service then skips its metric hooks.
  Metrics *metrics() { return metrics_.get(); }

  // Before BuildAndStart: interceptors (metrics); reads the scheduler's depth and the engine's
  // program cache (engine may be null: --device host) when scraped.
  void Configure(grpc::ServerBuilder *builder, const Scheduler *scheduler, DeviceEngine *engine);

  // After the server is up: starts the metrics endpoint. False with `error` on failure.
  bool Start(std::string *error);

 private:
  OpsFlags flags_;
  std::unique_ptr<Metrics> metrics_;
  std::unique_ptr<MetricsHttpServer> metrics_http_;
};

}  // namespace glint
