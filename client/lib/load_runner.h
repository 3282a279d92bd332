// Closed-loop load generation against one glintd, like Triton's perf_analyzer in concurrency
// mode: `concurrency` threads each keep exactly one request in flight (send, wait for the
// answer, send the next) for a fixed time, and every answer's latency is recorded.
//
// Bounded: a level issues no request after `duration` and at most `requests_max` in all, and
// every call carries the client's evaluate deadline, so a level ends at the latest at
// duration + timeout. It only ever talks to the client's own target.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "client/lib/glint_client.h"
#include "glint/v1/glint.pb.h"

namespace glint::client {

struct LoadConfig {
  // Sent as is by every request (unary), or as the first chunk of each stream (--stream; later
  // chunks carry its queries only).
  glint::v1::EvaluateRequest request;
  // false: one unary Evaluate per request through GlintClient::Evaluate. true: one
  // EvaluateStream per thread, one chunk per request; the latency is from writing a chunk to
  // reading its result. A stream the server ends (e.g. RESOURCE_EXHAUSTED) is reopened.
  bool stream = false;
  std::chrono::duration<double> duration{5.0};
  uint64_t requests_max = 1000000;  // per level, over all threads
  // Per call (unary) or per stream; 0 = none. Keeps a level bounded when a server hangs.
  std::chrono::milliseconds timeout{60000};
};

struct LoadLevelResult {
  int concurrency = 0;
  double seconds = 0.0;  // from the first send to the last answer of the level
  uint64_t ok = 0;
  uint64_t refused = 0;  // RESOURCE_EXHAUSTED: the server's queue was full
  uint64_t errors = 0;   // every other failure (UNAVAILABLE, DEADLINE_EXCEEDED, INTERNAL, ...)
  double requests_per_s = 0.0;  // ok / seconds
  double queries_per_s = 0.0;   // ok x batch / seconds
  // Latency of the successful requests, nearest-rank percentiles (client/lib/percentile.h), ms;
  // NaN when no request succeeded.
  double p50_ms = 0.0, p90_ms = 0.0, p95_ms = 0.0, p99_ms = 0.0, mean_ms = 0.0;
  std::string first_error;  // the first non-OK status seen, formatted, for the report
};

// Runs one level. `client` should have retries off (ClientOptions::retry.max_attempts = 1):
// refusals are part of what a load test measures.
LoadLevelResult RunLoadLevel(GlintClient &client, const LoadConfig &config, int concurrency);

// `n` BRDF probes (with_wi) or lit queries (wo only), deterministic and valid for every model:
// directions spread over the upper hemisphere by a golden-angle spiral, uv over [0, 1)^2,
// footprint zero.
glint::v1::QueryBatch MakeLoadQueries(uint32_t n, bool with_wi);

// The CSV the load tool writes, one row per level:
// concurrency,requests_per_s,queries_per_s,p50_ms,p90_ms,p99_ms,ok,refused,errors
std::string LoadCsvHeader();
std::string LoadCsvRow(const LoadLevelResult &r);

}  // namespace glint::client
