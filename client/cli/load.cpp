#include "client/cli/load.h"

#include <sys/stat.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "client/lib/glint_client.h"
#include "client/lib/load_runner.h"
#include "client/lib/query_io.h"

namespace glint::cli {
namespace {

constexpr const char *kLoadUsage =
    R"(usage: glint load --server ADDR [--concurrency 1,8,32] [--batch N] [--duration S]
                  [--material M.json] [--lights L.json] [--stream] [--requests-max N]
                  [--timeout-ms MS] [--csv OUT.csv]

Closed-loop load test of one glintd, like Triton's perf_analyzer in concurrency mode: for each
concurrency level C, C threads each keep one request of N queries in flight for S seconds.
Prints per level the request and query throughput and the latency percentiles of the answered
requests, and writes one CSV row per level:
  concurrency,requests_per_s,queries_per_s,p50_ms,p90_ms,p99_ms,ok,refused,errors
Percentiles are nearest-rank (the smallest latency with at least p% of the samples at or below
it); refused = RESOURCE_EXHAUSTED (queue full), errors = every other failure. Requests are never
retried. Only ADDR is contacted.

  --server ADDR        gRPC target, e.g. 127.0.0.1:50051, or replicas a:1,b:2 (round robin)
  --concurrency LIST   comma-separated levels, each 1..1024 (default 1)
  --batch N            queries per request, 1..16777216 (default 256)
  --duration S         seconds per level, (0, 3600] (default 5)
  --material M.json    glint.v1.Material (default: SMOOTH, GGX, alpha 0.3, Schlick f0 0.04)
  --lights L.json      glint.v1.LightList; with it queries are lit (wo only), without it they
                       are BRDF probes (wo, wi)
  --stream             one EvaluateStream per thread, one chunk per request (default: unary)
  --requests-max N     at most N requests per level (default 1000000)
  --timeout-ms MS      deadline of each call (unary) or stream, after the level's end for
                       streams (default 60000)
  --csv OUT.csv        write the CSV here (default: stdout only)
  --wait-ms MS         how long to wait for the server to report SERVING (default 10000)
  --tls-ca PEM, --tls-cert PEM, --tls-key PEM, --token-file FILE
                       TLS, mutual TLS and bearer token as for every glint command
                       (the token defaults to $GLINT_TOKEN)
)";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

const std::set<std::string> kWithValue = {
    "server",     "concurrency", "batch",   "duration", "material", "lights",  "requests-max",
    "timeout-ms", "csv",         "wait-ms", "tls-ca",   "tls-cert", "tls-key", "token-file"};
const std::set<std::string> kFlags = {"stream"};

std::map<std::string, std::string> ParseArgs(int argc, char **argv, bool *help) {
  std::map<std::string, std::string> values;
  for (int i = 0; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      *help = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0) throw UsageError("unexpected argument '" + arg + "'");
    std::string name = arg.substr(2);
    std::string value;
    bool inline_value = false;
    if (const size_t eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
      inline_value = true;
    }
    const bool takes_value = kWithValue.count(name) != 0;
    if (!takes_value && kFlags.count(name) == 0) throw UsageError("unknown option --" + name);
    if (values.count(name)) throw UsageError("option --" + name + " given twice");
    if (!takes_value && inline_value) throw UsageError("option --" + name + " takes no value");
    if (takes_value && !inline_value) {
      if (i + 1 >= argc) throw UsageError("option --" + name + " needs a value");
      value = argv[++i];
    }
    values[name] = value;
  }
  return values;
}

template <typename T>
T Parse(const std::string &option, const std::string &text, T lo, T hi) {
  T value{};
  const char *end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || !(value >= lo && value <= hi)) {
    throw UsageError("--" + option + ": '" + text + "' is not a number in [" + std::to_string(lo) +
                     ", " + std::to_string(hi) + "]");
  }
  return value;
}

std::vector<int> ParseLevels(const std::string &text) {
  std::vector<int> levels;
  size_t begin = 0;
  for (;;) {
    const size_t comma = text.find(',', begin);
    levels.push_back(Parse<int>("concurrency", text.substr(begin, comma - begin), 1, 1024));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  if (levels.size() > 64) throw UsageError("--concurrency: at most 64 levels");
  return levels;
}

glint::v1::Material DefaultMaterial() {
  glint::v1::Material m;
  m.set_model(glint::v1::SMOOTH);
  m.set_ndf(glint::v1::GGX);
  m.set_alpha_x(0.3f);
  m.set_alpha_y(0.3f);
  for (int c = 0; c < 3; ++c) m.mutable_schlick()->add_f0(0.04f);
  return m;
}

std::string Ms(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, std::isfinite(v) ? "%.3f ms" : "-", v);
  return buf;
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  if (!(in >> one >> five >> fifteen)) return "unknown";
  return one + " " + five + " " + fifteen;
}

int Run(const std::map<std::string, std::string> &args) {
  auto get = [&](const std::string &name, const std::string &fallback) {
    auto it = args.find(name);
    return it == args.end() ? fallback : it->second;
  };
  const std::string server = get("server", "");
  if (server.empty()) throw UsageError("missing --server");
  const std::vector<int> levels = ParseLevels(get("concurrency", "1"));
  const auto batch = Parse<uint32_t>("batch", get("batch", "256"), 1, 1u << 24);
  glint::client::LoadConfig config;
  config.duration =
      std::chrono::duration<double>(Parse<double>("duration", get("duration", "5"), 1e-3, 3600.0));
  config.requests_max =
      Parse<uint64_t>("requests-max", get("requests-max", "1000000"), 1, uint64_t{1} << 40);
  config.timeout = std::chrono::milliseconds(
      Parse<int64_t>("timeout-ms", get("timeout-ms", "60000"), 1, int64_t{24} * 3600 * 1000));
  config.stream = args.count("stream") != 0;

  glint::v1::EvaluateRequest &request = config.request;
  *request.mutable_material() = args.count("material")
                                    ? glint::client::ReadMaterialJson(args.at("material"))
                                    : DefaultMaterial();
  if (args.count("lights")) {
    for (auto &light : glint::client::ReadLightsJson(args.at("lights"))) {
      *request.add_lights() = std::move(light);
    }
  }
  request.set_precision(glint::v1::FP32);
  const bool probes = request.lights_size() == 0;
  *request.mutable_queries() = glint::client::MakeLoadQueries(batch, probes);

  glint::client::ClientOptions options;
  options.evaluate_timeout = config.timeout;
  options.retry.max_attempts = 1;  // refusals are what a load test measures
  options.security = glint::client::LoadChannelSecurity(get("tls-ca", ""), get("tls-cert", ""),
                                                        get("tls-key", ""), get("token-file", ""));
  // Checked before the run, not after it: an unwritable path is said at once instead of after
  // every level has run (found by the session 9 outside-client probe). Opened to append, not to
  // write, and a file this check created removed again: a run that fails before it has results
  // (no server, a refused --batch) leaves an existing CSV as it was and creates none; the CSV is
  // written (truncated) only once the levels have run.
  if (args.count("csv")) {
    const std::string &path = args.at("csv");
    struct stat st {};
    const bool existed = ::stat(path.c_str(), &st) == 0;
    std::ofstream probe(path, std::ios::binary | std::ios::app);
    if (!probe) {
      std::fprintf(stderr, "glint load: cannot write %s: %s\n", path.c_str(), std::strerror(errno));
      return 1;
    }
    probe.close();
    if (!existed) std::remove(path.c_str());
  }
  glint::client::GlintClient client(server, options);
  std::string why;
  const auto wait = std::chrono::milliseconds(
      Parse<int64_t>("wait-ms", get("wait-ms", "10000"), 0, int64_t{3600} * 1000));
  if (!client.WaitUntilServing(wait, &why)) {
    std::fprintf(stderr, "glint load: server %s: %s\n", server.c_str(), why.c_str());
    return 1;
  }
  glint::v1::Capabilities caps;
  if (grpc::Status s = client.GetCapabilities(&caps); !s.ok()) {
    std::fprintf(stderr, "glint load: GetCapabilities: %s\n",
                 glint::client::FormatStatus(s).c_str());
    return 1;
  }
  if (config.stream && caps.max_batch() != 0 && batch > caps.max_batch()) {
    throw UsageError("--batch " + std::to_string(batch) + " exceeds the server's max_batch " +
                     std::to_string(caps.max_batch()) + " for one stream chunk");
  }

  std::printf("*** glint load: %s, %s, batch %u %s, %s, %.3g s per level\n", server.c_str(),
              caps.device_name().c_str(), batch, probes ? "probes" : "lit queries",
              config.stream ? "stream (one chunk per request)" : "unary", config.duration.count());
  std::printf("    model %s, %d lights; load average before the run: %s\n",
              glint::v1::Model_Name(request.material().model()).c_str(), request.lights_size(),
              LoadAverage().c_str());
  std::vector<glint::client::LoadLevelResult> results;
  for (const int level : levels) {
    const glint::client::LoadLevelResult r = glint::client::RunLoadLevel(client, config, level);
    results.push_back(r);
    std::printf("\nRequest concurrency: %d\n  Client:\n", level);
    std::printf("    Request count: %llu ok, %llu refused, %llu errors in %.3f s\n",
                static_cast<unsigned long long>(r.ok), static_cast<unsigned long long>(r.refused),
                static_cast<unsigned long long>(r.errors), r.seconds);
    std::printf("    Throughput: %.1f requests/s, %.4g queries/s\n", r.requests_per_s,
                r.queries_per_s);
    std::printf("    Avg latency: %s\n    p50 latency: %s\n    p90 latency: %s\n",
                Ms(r.mean_ms).c_str(), Ms(r.p50_ms).c_str(), Ms(r.p90_ms).c_str());
    std::printf("    p95 latency: %s\n    p99 latency: %s\n", Ms(r.p95_ms).c_str(),
                Ms(r.p99_ms).c_str());
    if (!r.first_error.empty()) std::printf("    first failure: %s\n", r.first_error.c_str());
    std::fflush(stdout);
  }
  std::printf("\nQueries/second vs. client p99 latency\n");
  for (const auto &r : results) {
    std::printf("Concurrency: %d, throughput: %.4g queries/s (%.1f requests/s), p99 latency %s\n",
                r.concurrency, r.queries_per_s, r.requests_per_s, Ms(r.p99_ms).c_str());
  }

  std::string csv = glint::client::LoadCsvHeader() + "\n";
  for (const auto &r : results) csv += glint::client::LoadCsvRow(r) + "\n";
  if (args.count("csv")) {
    const std::string path = args.at("csv");
    std::ofstream out(path, std::ios::binary);
    out << csv;
    out.close();
    if (!out) {
      std::fprintf(stderr, "glint load: cannot write %s\n", path.c_str());
      return 1;
    }
    std::printf("\nCSV -> %s\n", path.c_str());
  } else {
    std::printf("\n%s", csv.c_str());
  }
  for (const auto &r : results) {
    if (r.errors > 0 || r.ok == 0) return 1;
  }
  return 0;
}

}  // namespace

int RunLoad(int argc, char **argv) {
  try {
    bool help = false;
    const auto args = ParseArgs(argc, argv, &help);
    if (help) {
      std::fputs(kLoadUsage, stdout);
      return 0;
    }
    return Run(args);
  } catch (const UsageError &e) {
    std::fprintf(stderr, "glint load: %s\n\n%s", e.what(), kLoadUsage);
    return 2;
  } catch (const std::exception &e) {
    std::fprintf(stderr, "glint: %s\n", e.what());
    return 1;
  }
}

}  // namespace glint::cli
