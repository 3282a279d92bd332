// The /metrics endpoint: cpp-httplib (Debian's libcpp-httplib-dev) serving Metrics::Render on
// its own thread, apart from the gRPC port so a scraper never competes with evaluation traffic
// for gRPC's threads.
#pragma once

#include <memory>
#include <string>
#include <thread>

#include "server/metrics.h"

namespace httplib {
class Server;
}

namespace glint {

class MetricsHttpServer {
 public:
  MetricsHttpServer();
  ~MetricsHttpServer();  // stops the listener and joins its thread
  MetricsHttpServer(const MetricsHttpServer &) = delete;
  MetricsHttpServer &operator=(const MetricsHttpServer &) = delete;

  // `address` is HOST:PORT (port 0 picks a free one); false with `error` filled when it is
  // malformed or cannot be bound. On success `bound_port` is the port listened on.
  bool Start(const std::string &address, const Metrics *metrics, int *bound_port,
             std::string *error);

 private:
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
};

}  // namespace glint
