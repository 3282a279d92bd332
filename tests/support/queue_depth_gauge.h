// Test support: glintd's glint_queue_depth gauge (requests queued or running, what --max-pending
// bounds) read from /metrics, so a test can tell when calls sit queued behind a long one without
// sleeping for a guessed time.
#pragma once

#include <httplib.h>

#include <chrono>
#include <regex>
#include <string>
#include <thread>

namespace glint::test {

// The gauge's value; -1 when /metrics is unreadable or lacks it.
inline double QueueDepth(httplib::Client &http) {
  auto res = http.Get("/metrics");
  if (!res || res->status != 200) return -1;
  std::smatch m;
  static const std::regex line(R"((^|\n)glint_queue_depth ([0-9.eE+-]+)\n)");
  if (!std::regex_search(res->body, m, line)) return -1;
  return std::stod(m[2]);
}

// Polls the gauge until it reads `want`, `stop()` holds or `timeout` passes; returns the last
// value read.
template <class Stop>
double WaitForQueueDepth(httplib::Client &http, double want, Stop &&stop,
                         std::chrono::seconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  double depth = QueueDepth(http);
  while (depth != want && !stop() && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    depth = QueueDepth(http);
  }
  return depth;
}

}  // namespace glint::test
