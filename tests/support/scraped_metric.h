// Test support: one series of glintd's /metrics (glintd --metrics-listen) read by its full name
// with labels, e.g. glint_grpc_server_handled_total{grpc_service="...",grpc_method="...",
// grpc_code="..."}, so a test can wait for something the server did (a call it answered, a queue
// it holds) instead of sleeping for a guessed time.
#pragma once

#include <httplib.h>

#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

namespace glint::test {

// The series' value; 0 when /metrics lacks the series (a counter not yet incremented is not
// exported), -1 when /metrics is unreadable.
inline double ScrapedValue(httplib::Client &http, const std::string &series) {
  auto res = http.Get("/metrics");
  if (!res || res->status != 200) return -1;
  const std::string &body = res->body;
  const std::string key = series + " ";
  for (size_t at = body.find(key); at != std::string::npos; at = body.find(key, at + 1)) {
    if (at != 0 && body[at - 1] != '\n') continue;  // a longer name ending in `series`
    return std::strtod(body.c_str() + at + key.size(), nullptr);
  }
  return 0;
}

// glint.v1.GlintService calls of `method` that glintd answered with `code` (a grpc_code label:
// OK, RESOURCE_EXHAUSTED, ...).
inline std::string HandledSeries(const std::string &method, const std::string &code) {
  return "glint_grpc_server_handled_total{grpc_service=\"glint.v1.GlintService\",grpc_method=\"" +
         method + "\",grpc_code=\"" + code + "\"}";
}

// Queries glintd did not compute because their call was cancelled, its deadline passed or
// shutdown cancelled it: `reason` is "cancelled", "deadline" or "shutdown"
// (server/abandoned_work.h).
inline std::string AbandonedSeries(const std::string &reason) {
  return "glint_abandoned_queries_total{reason=\"" + reason + "\"}";
}

// Polls until the series reads at least `want` or `timeout` passes; returns the last value read.
inline double WaitForScrapedValue(httplib::Client &http, const std::string &series, double want,
                                  std::chrono::seconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  double value = ScrapedValue(http, series);
  while (value < want && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    value = ScrapedValue(http, series);
  }
  return value;
}

}  // namespace glint::test
