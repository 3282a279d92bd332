#include "server/metrics.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <utility>

namespace glint {
namespace {

// Prometheus sample values: integers exactly, others with enough digits to round-trip.
std::string Value(double v) {
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  if (std::isnan(v)) return "NaN";
  char buf[64];
  // Shortest text that reads back as the same double (0.00025, not 0.00025000000000000001).
  const auto result = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, result.ptr);
}

std::string Value(uint64_t v) {
  return std::to_string(v);
}

// gRPC's own names for status codes (the grpc_code label of grpc-prometheus' metrics).
const char *GrpcCodeName(grpc::StatusCode code) {
  static const char *const kNames[] = {"OK",
                                       "CANCELLED",
                                       "UNKNOWN",
                                       "INVALID_ARGUMENT",
                                       "DEADLINE_EXCEEDED",
                                       "NOT_FOUND",
                                       "ALREADY_EXISTS",
                                       "PERMISSION_DENIED",
                                       "RESOURCE_EXHAUSTED",
                                       "FAILED_PRECONDITION",
                                       "ABORTED",
                                       "OUT_OF_RANGE",
                                       "UNIMPLEMENTED",
                                       "INTERNAL",
                                       "UNAVAILABLE",
                                       "DATA_LOSS",
                                       "UNAUTHENTICATED"};
  const auto i = static_cast<size_t>(code);
  return i < sizeof kNames / sizeof kNames[0] ? kNames[i] : "UNKNOWN";
}

// Label values are escaped as the text format requires (backslash, quote, newline).
std::string Escape(const std::string &s) {
  std::string out;
  for (const char c : s) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

void Header(const char *name, const char *type, const char *help, std::string *out) {
  *out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n";
}

}  // namespace

std::vector<double> LatencyBuckets() {
  return {1e-4, 2.5e-4, 5e-4, 1e-3, 2.5e-3, 5e-3, 0.01, 0.025, 0.05,
          0.1,  0.25,   0.5,  1.0,  2.5,    5.0,  10.0, 30.0,  60.0};
}

Histogram::Histogram(std::vector<double> bounds)
    : bounds_(std::move(bounds)), counts_(bounds_.size() + 1, 0) {}

void Histogram::Observe(double value) {
  size_t i = 0;
  while (i < bounds_.size() && !(value <= bounds_[i])) ++i;
  ++counts_[i];
  sum_ += value;
  ++count_;
}

void Histogram::Render(const std::string &name, const std::string &labels, std::string *out) const {
  const std::string sep = labels.empty() ? "" : ",";
  uint64_t cumulative = 0;
  for (size_t i = 0; i <= bounds_.size(); ++i) {
    cumulative += counts_[i];
    const std::string le = i < bounds_.size() ? Value(bounds_[i]) : "+Inf";
    *out += name + "_bucket{" + labels + sep + "le=\"" + le + "\"} " + Value(cumulative) + "\n";
  }
  const std::string braces = labels.empty() ? "" : "{" + labels + "}";
  *out += name + "_sum" + braces + " " + Value(sum_) + "\n";
  *out += name + "_count" + braces + " " + Value(count_) + "\n";
}

Metrics::Metrics() : queue_wait_(LatencyBuckets()) {}

void Metrics::CountRpc(const std::string &method, grpc::StatusCode code) {
  // "/glint.v1.GlintService/Evaluate" -> service "glint.v1.GlintService", method "Evaluate".
  std::string service, name = method;
  if (const size_t slash = method.rfind('/'); slash != std::string::npos) {
    service = method.substr(method[0] == '/' ? 1 : 0, slash - (method[0] == '/' ? 1 : 0));
    name = method.substr(slash + 1);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ++rpcs_[{service, name, GrpcCodeName(code)}];
}

void Metrics::CountEvaluated(const std::string &model, uint64_t queries, double compute_seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  queries_[model] += queries;
  compute_.try_emplace(model, LatencyBuckets()).first->second.Observe(compute_seconds);
}

void Metrics::ObserveCompile(const std::string &model, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  compile_.try_emplace(model, LatencyBuckets()).first->second.Observe(seconds);
}

void Metrics::ObserveQueueWait(double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  queue_wait_.Observe(seconds);
}

void Metrics::SetQueueDepthSource(std::function<double()> depth, double capacity) {
  std::lock_guard<std::mutex> lock(mutex_);
  queue_depth_ = std::move(depth);
  queue_capacity_ = capacity;
}

void Metrics::SetProgramCacheSource(std::function<ProgramCacheCounts()> source) {
  std::lock_guard<std::mutex> lock(mutex_);
  program_cache_ = std::move(source);
}

void Metrics::SetAbandonedSource(std::function<AbandonedCounts()> source) {
  std::lock_guard<std::mutex> lock(mutex_);
  abandoned_ = std::move(source);
}

std::string Metrics::Render() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string out;
  Header("glint_grpc_server_handled_total", "counter",
         "RPCs completed by the server, by service, method and gRPC status code.", &out);
  for (const auto &[key, n] : rpcs_) {
    const auto &[service, method, code] = key;
    out += "glint_grpc_server_handled_total{grpc_service=\"" + Escape(service) +
           "\",grpc_method=\"" + Escape(method) + "\",grpc_code=\"" + code + "\"} " + Value(n) +
           "\n";
  }
  Header("glint_queries_evaluated_total", "counter",
         "Queries evaluated successfully, by material model.", &out);
  for (const auto &[model, n] : queries_) {
    out += "glint_queries_evaluated_total{model=\"" + Escape(model) + "\"} " + Value(n) + "\n";
  }
  Header("glint_compute_seconds", "histogram",
         "Evaluation time of one batch (a unary request or a stream chunk) on a worker, by "
         "material model; a cold variant's kernel build is in glint_compile_seconds instead.",
         &out);
  for (const auto &[model, h] : compute_)
    h.Render("glint_compute_seconds", "model=\"" + Escape(model) + "\"", &out);
  Header("glint_compile_seconds", "histogram",
         "Kernel builds by requests: the time a request or stream chunk spent building (or "
         "loading) a kernel variant its worker had not built yet, before its compute time, by "
         "material model.",
         &out);
  for (const auto &[model, h] : compile_)
    h.Render("glint_compile_seconds", "model=\"" + Escape(model) + "\"", &out);
  Header("glint_queue_wait_seconds", "histogram",
         "Time a request or stream chunk waited in the scheduler queue before a worker took it.",
         &out);
  queue_wait_.Render("glint_queue_wait_seconds", "", &out);
  if (queue_depth_) {
    Header("glint_queue_depth", "gauge",
           "Requests and stream chunks queued or running (what --max-pending bounds).", &out);
    out += "glint_queue_depth " + Value(queue_depth_()) + "\n";
    Header("glint_queue_capacity", "gauge",
           "--max-pending: the queue depth beyond which new "
           "work is refused with RESOURCE_EXHAUSTED.",
           &out);
    out += "glint_queue_capacity " + Value(queue_capacity_) + "\n";
  }
  if (program_cache_) {
    const ProgramCacheCounts c = program_cache_();
    Header("glint_program_cache_lookups_total", "counter",
           "OpenCL program lookups by result: memory_hit (built this run), disk_hit (cached "
           "binary loaded), compiled (built from source).",
           &out);
    out +=
        "glint_program_cache_lookups_total{result=\"memory_hit\"} " + Value(c.memory_hits) + "\n";
    out += "glint_program_cache_lookups_total{result=\"disk_hit\"} " + Value(c.disk_hits) + "\n";
    out += "glint_program_cache_lookups_total{result=\"compiled\"} " + Value(c.compiled) + "\n";
  }
  if (abandoned_) {
    const AbandonedCounts a = abandoned_();
    Header("glint_abandoned_queries_total", "counter",
           "Queries not computed because nobody waited for them any more, by reason: cancelled "
           "(the client cancelled the call or went away, or gave up at its own deadline first), "
           "deadline (the server saw the call's deadline pass), "
           "shutdown (cancelled after --shutdown-grace). Counted where the work stopped: between "
           "query slices, or when a queued call was dropped before it started.",
           &out);
    out += "glint_abandoned_queries_total{reason=\"cancelled\"} " + Value(a.cancelled) + "\n";
    out += "glint_abandoned_queries_total{reason=\"deadline\"} " + Value(a.deadline) + "\n";
    out += "glint_abandoned_queries_total{reason=\"shutdown\"} " + Value(a.shutdown) + "\n";
  }
  return out;
}

}  // namespace glint
