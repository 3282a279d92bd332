// Service metrics in Prometheus' text exposition format (version 0.0.4), served by
// metrics_http.h at /metrics. Counters and histograms are updated from the request path (the
// gRPC interceptor in metrics_interceptor.h, the service's hooks); gauges and the program-cache
// counters are read from their owners when scraped, so they cannot drift from the truth.
//
// No C++ Prometheus client library is packaged in Debian bookworm, so the few lines of text
// rendering live here; tests/ops/metrics_e2e_test.cpp parses the output.
#pragma once

#include <grpcpp/grpcpp.h>

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

#include "server/abandoned_work.h"

namespace glint {

// Cumulative histogram with fixed upper bounds (seconds), as Prometheus defines it: bucket i
// counts observations <= bounds[i]; the +Inf bucket is the total count.
class Histogram {
 public:
  explicit Histogram(std::vector<double> bounds);
  void Observe(double value);
  // Appends name_bucket{le=...}, name_sum and name_count lines; `labels` is "" or `k="v"`.
  void Render(const std::string &name, const std::string &labels, std::string *out) const;

 private:
  std::vector<double> bounds_;
  std::vector<uint64_t> counts_;  // per bucket, not cumulative; the last is (bounds.back, +Inf)
  double sum_ = 0.0;
  uint64_t count_ = 0;
};

struct ProgramCacheCounts {
  uint64_t memory_hits = 0;  // found in the runtime's in-memory program cache
  uint64_t disk_hits = 0;    // loaded from a cached binary on disk
  uint64_t compiled = 0;     // compiled from source
};

class Metrics {
 public:
  Metrics();

  // One finished RPC: `method` is gRPC's full name "/package.Service/Method".
  void CountRpc(const std::string &method, grpc::StatusCode code);
  // One batch (unary request or stream chunk) evaluated successfully; compute_seconds without
  // the kernel build of a cold variant (ObserveCompile), as EvaluateStats.compute_ms.
  void CountEvaluated(const std::string &model, uint64_t queries, double compute_seconds);
  // A request or chunk that had to build its kernel variant on its worker's queue first
  // (EvaluateStats.compile_ms > 0): how long that took.
  void ObserveCompile(const std::string &model, double seconds);
  // Time a request or chunk waited in the scheduler's queue before a worker took it.
  void ObserveQueueWait(double seconds);

  // Read at scrape time. Unset sources are left out of the output.
  void SetQueueDepthSource(std::function<double()> depth, double capacity);
  void SetProgramCacheSource(std::function<ProgramCacheCounts()> source);
  // glint_abandoned_queries_total{reason}: the service's AbandonedWork (server/abandoned_work.h).
  void SetAbandonedSource(std::function<AbandonedCounts()> source);

  // The whole exposition, HELP and TYPE lines included.
  std::string Render() const;

 private:
  mutable std::mutex mutex_;
  // (service, method, code) -> count
  std::map<std::tuple<std::string, std::string, std::string>, uint64_t> rpcs_;
  std::map<std::string, uint64_t> queries_;   // model -> queries evaluated
  std::map<std::string, Histogram> compute_;  // model -> compute latency
  std::map<std::string, Histogram> compile_;  // model -> kernel builds by requests
  Histogram queue_wait_;
  std::function<double()> queue_depth_;
  double queue_capacity_ = 0.0;
  std::function<ProgramCacheCounts()> program_cache_;
  std::function<AbandonedCounts()> abandoned_;
};

// The latency buckets (seconds) of both histograms: 100 us to 60 s, roughly x2.5 apart, so a
// 256-query probe batch (~0.3 ms) and a 1M-query REFERENCE request (minutes) both resolve.
std::vector<double> LatencyBuckets();

}  // namespace glint
