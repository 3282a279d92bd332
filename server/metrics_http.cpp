#include "server/metrics_http.h"

#include <httplib.h>

#include <charconv>

namespace glint {
namespace {
constexpr size_t kMetricsHttpThreads = 32;
}  // namespace

MetricsHttpServer::MetricsHttpServer() = default;

MetricsHttpServer::~MetricsHttpServer() {
  if (server_) server_->stop();
  if (thread_.joinable()) thread_.join();
}

bool MetricsHttpServer::Start(const std::string &address, const Metrics *metrics, int *bound_port,
                              std::string *error) {
  const size_t colon = address.rfind(':');
  int port = -1;
  if (colon != std::string::npos) {
    const char *begin = address.data() + colon + 1;
    const char *end = address.data() + address.size();
    auto [ptr, ec] = std::from_chars(begin, end, port);
    if (ec != std::errc() || ptr != end || begin == end) port = -1;
  }
  if (colon == std::string::npos || port < 0 || port > 65535) {
    *error = "--metrics-listen " + address + ": expected HOST:PORT with a port in [0, 65535]";
    return false;
  }
  std::string host = address.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);  // [::1]:9090
  }
  server_ = std::make_unique<httplib::Server>();
  // cpp-httplib holds a pool thread per open connection until it is read or times out (5 s by
  // default, 8 threads here): a dozen clients sending half a request stalled every scrape for
  // ~10 s (an outside-client probe). A scrape is one small GET, so short read and keep-alive
  // timeouts and a larger pool keep a handful of idle or slow peers from starving it.
  server_->new_task_queue = [] { return new httplib::ThreadPool(kMetricsHttpThreads); };
  server_->set_read_timeout(std::chrono::seconds(1));
  server_->set_keep_alive_timeout(1);
  server_->Get("/metrics", [metrics](const httplib::Request &, httplib::Response &res) {
    res.set_content(metrics->Render(), "text/plain; version=0.0.4; charset=utf-8");
  });
  const int bound = port == 0                           ? server_->bind_to_any_port(host)
                    : server_->bind_to_port(host, port) ? port
                                                        : -1;
  if (bound <= 0) {
    *error = "--metrics-listen " + address + ": cannot listen there";
    server_.reset();
    return false;
  }
  *bound_port = bound;
  thread_ = std::thread([this] { server_->listen_after_bind(); });
  return true;
}

}  // namespace glint
