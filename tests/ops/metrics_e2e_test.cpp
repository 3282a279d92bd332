// glintd --metrics-listen: scrape /metrics (cpp-httplib client) before and after a known
// workload and check that each counter moved by exactly what was sent: RPCs by method and
// status, queries by model, one compute and one queue-wait observation per evaluated batch,
// histogram buckets cumulative with +Inf equal to the count, the queue gauges, and the
// program-cache counters against the numbers glintd logs at warm-up.
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "client/lib/glint_client.h"
#include "client/lib/load_runner.h"
#include "glintd_process.h"

namespace {

using glint::test::Glintd;
using glint::test::TempDir;

// Prometheus text format 0.0.4, read independently of the server's writer: every sample line
// is `name{labels} value` or `name value`, and its family (the name without _bucket, _sum,
// _count) must have had a # TYPE line before it. Returns series -> value.
std::map<std::string, double> ParseExposition(const std::string &text) {
  std::map<std::string, double> samples;
  std::set<std::string> typed;
  const std::regex type_line(R"(# TYPE ([a-zA-Z_:][a-zA-Z0-9_:]*) (counter|gauge|histogram))");
  const std::regex sample_line(
      R"(([a-zA-Z_:][a-zA-Z0-9_:]*)(\{[a-zA-Z_]+="[^"]*"(,[a-zA-Z_]+="[^"]*")*\})? (\S+))");
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (line.rfind("# HELP ", 0) == 0) continue;
    if (std::regex_match(line, m, type_line)) {
      typed.insert(m[1]);
      continue;
    }
    EXPECT_TRUE(std::regex_match(line, m, sample_line)) << "not a sample line: " << line;
    if (m.empty()) continue;
    std::string family = m[1];
    for (const char *suffix : {"_bucket", "_sum", "_count"}) {
      const std::string s = suffix;
      if (family.size() > s.size() && family.compare(family.size() - s.size(), s.size(), s) == 0 &&
          typed.count(family.substr(0, family.size() - s.size()))) {
        family = family.substr(0, family.size() - s.size());
      }
    }
    EXPECT_TRUE(typed.count(family)) << "sample before its # TYPE line: " << line;
    const std::string value = m[4];
    samples[std::string(m[1]) + std::string(m[2])] =
        value == "+Inf" ? HUGE_VAL : std::strtod(value.c_str(), nullptr);
  }
  return samples;
}

double Get(const std::map<std::string, double> &s, const std::string &series) {
  auto it = s.find(series);
  return it == s.end() ? 0.0 : it->second;
}

std::string Handled(const std::string &method, const std::string &code) {
  return "glint_grpc_server_handled_total{grpc_service=\"glint.v1.GlintService\",grpc_method=\"" +
         method + "\",grpc_code=\"" + code + "\"}";
}

// Histogram buckets are cumulative (non-decreasing in le) and the +Inf bucket equals _count.
void ExpectHistogram(const std::map<std::string, double> &s, const std::string &name,
                     const std::string &labels) {
  const std::string prefix = name + "_bucket{" + (labels.empty() ? "" : labels + ",") + "le=\"";
  // std::map orders le as text; walk the server's bounds in numeric order instead.
  std::vector<std::pair<double, double>> by_le;
  for (const auto &[series, value] : s) {
    if (series.rfind(prefix, 0) != 0) continue;
    const std::string le = series.substr(prefix.size(), series.size() - prefix.size() - 2);
    by_le.emplace_back(le == "+Inf" ? HUGE_VAL : std::strtod(le.c_str(), nullptr), value);
  }
  std::sort(by_le.begin(), by_le.end());
  ASSERT_GT(by_le.size(), 1u) << name;
  double last = 0.0;
  for (const auto &[le, count] : by_le) {
    EXPECT_GE(count, last) << name << " le=" << le;
    last = count;
  }
  const std::string braces = labels.empty() ? "" : "{" + labels + "}";
  EXPECT_EQ(by_le.back().first, HUGE_VAL);
  EXPECT_EQ(by_le.back().second, Get(s, name + "_count" + braces)) << name;
}

glint::v1::EvaluateRequest SmoothProbes(uint32_t n) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.2f);
  for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(0.5f);
  *r.mutable_queries() = glint::client::MakeLoadQueries(n, true);
  return r;
}

TEST(MetricsEndToEnd, CountersMatchWhatWasSent) {
  TempDir dir("glint_metrics");
  std::string error;
  auto server = Glintd::Start(GLINTD_PATH, dir, "glintd",
                              {"--metrics-listen", "127.0.0.1:0", "--max-pending", "5"}, &error);
  ASSERT_NE(server, nullptr) << error;
  const int metrics_port = server->MetricsPort();  // --metrics-listen 127.0.0.1:0
  ASSERT_GT(metrics_port, 0) << server->Stderr();

  httplib::Client http("127.0.0.1", metrics_port);
  auto scrape = [&] {
    auto res = http.Get("/metrics");
    EXPECT_TRUE(res) << "no answer from /metrics";
    if (!res) return std::map<std::string, double>{};
    EXPECT_EQ(res->status, 200);
    EXPECT_EQ(res->get_header_value("Content-Type").rfind("text/plain; version=0.0.4", 0), 0u);
    return ParseExposition(res->body);
  };
  const auto before = scrape();

  glint::client::ClientOptions options;
  options.max_chunk_queries = 40;  // 100 queries stream as chunks of 40, 40, 20
  glint::client::GlintClient client(server->address(), options);
  std::vector<float> rgb;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(client.Evaluate(SmoothProbes(30), &rgb).ok());  // unary: 30 <= 40
  }
  glint::client::EvaluateInfo info;
  ASSERT_TRUE(client.Evaluate(SmoothProbes(100), &rgb, {}, &info).ok());
  ASSERT_TRUE(info.streamed);
  ASSERT_EQ(info.chunks, 3u);
  glint::v1::EvaluateRequest bad = SmoothProbes(10);
  bad.mutable_material()->set_alpha_x(5.0f);  // refused by validation, before the queue
  EXPECT_EQ(client.Evaluate(bad, &rgb).error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  const auto after = scrape();
  auto delta = [&](const std::string &series) { return Get(after, series) - Get(before, series); };
  EXPECT_EQ(delta(Handled("Evaluate", "OK")), 3);
  EXPECT_EQ(delta(Handled("Evaluate", "INVALID_ARGUMENT")), 1);
  EXPECT_EQ(delta(Handled("EvaluateStream", "OK")), 1);
  EXPECT_EQ(delta(Handled("GetCapabilities", "OK")), 1);  // the client caches capabilities
  EXPECT_EQ(delta("glint_queries_evaluated_total{model=\"SMOOTH\"}"), 3 * 30 + 100);
  // One compute and one queue-wait observation per batch: 3 unary requests + 3 chunks.
  EXPECT_EQ(delta("glint_compute_seconds_count{model=\"SMOOTH\"}"), 6);
  EXPECT_EQ(delta("glint_queue_wait_seconds_count"), 6);
  EXPECT_GT(delta("glint_compute_seconds_sum{model=\"SMOOTH\"}"), 0.0);
  ExpectHistogram(after, "glint_compute_seconds", "model=\"SMOOTH\"");
  ExpectHistogram(after, "glint_queue_wait_seconds", "");
  EXPECT_EQ(Get(after, "glint_queue_depth"), 0);  // every request has been answered
  EXPECT_EQ(Get(after, "glint_queue_capacity"), 5);
  // Exported from the start under each reason; nothing above was abandoned (the stopped calls
  // that count are in robustness_test's Cancellation and Shutdown tests).
  for (const char *reason : {"cancelled", "deadline", "shutdown"}) {
    const std::string series =
        std::string("glint_abandoned_queries_total{reason=\"") + reason + "\"}";
    EXPECT_EQ(before.count(series), 1u) << series;
    EXPECT_EQ(delta(series), 0) << series;
  }

  // Program cache: glintd logs "(C compiled, D from cache ...)" after its warm-up, before any
  // request; the workload above only uses warm kernel variants, so nothing new was compiled.
  std::smatch m;
  const std::string log = server->Stderr();
  ASSERT_TRUE(std::regex_search(log, m, std::regex(R"(\((\d+) compiled, (\d+) from cache)")))
      << log;
  EXPECT_EQ(Get(after, "glint_program_cache_lookups_total{result=\"compiled\"}"), std::stod(m[1]));
  EXPECT_EQ(Get(after, "glint_program_cache_lookups_total{result=\"disk_hit\"}"), std::stod(m[2]));
  EXPECT_GE(Get(after, "glint_program_cache_lookups_total{result=\"compiled\"}") +
                Get(after, "glint_program_cache_lookups_total{result=\"disk_hit\"}"),
            1);
}

// --warm none builds nothing before SERVING, not even a --model preset's kernel (it compiled the
// presets and logged "0 kernels warm"), and says so. Then a request of a variant its worker has
// not built reports the build apart from its compute: compile_ms > 0 exactly when the program
// cache counters show a build (or disk load) during that request, 0 for the next request of the
// same variant, on unary Evaluate and per chunk of an EvaluateStream; glint_compile_seconds
// observes the builds and glint_compute_seconds the compute_ms the replies carried (before,
// compute_ms and the histogram included the build).
TEST(MetricsEndToEnd, WarmNoneBuildsNothingAndColdVariantsReportCompileApart) {
  TempDir dir("glint_metrics_cold");
  const std::string examples = GLINT_EXAMPLES_DIR;
  std::string error;
  auto server = Glintd::Start(
      GLINTD_PATH, dir, "glintd",
      {"--warm", "none", "--workers", "1", "--model",
       "paint=" + examples + "/materials/paint_schlick.json," + examples + "/lights/studio.json",
       "--metrics-listen", "127.0.0.1:0"},
      &error);
  ASSERT_NE(server, nullptr) << error;
  const int metrics_port = server->MetricsPort();  // --metrics-listen 127.0.0.1:0
  ASSERT_GT(metrics_port, 0) << server->Stderr();
  httplib::Client http("127.0.0.1", metrics_port);
  auto scrape = [&] {
    auto res = http.Get("/metrics");
    EXPECT_TRUE(res) << "no answer from /metrics";
    return res ? ParseExposition(res->body) : std::map<std::string, double>{};
  };
  auto builds = [&](const std::map<std::string, double> &s) {
    return Get(s, "glint_program_cache_lookups_total{result=\"compiled\"}") +
           Get(s, "glint_program_cache_lookups_total{result=\"disk_hit\"}");
  };
  const auto start = scrape();
  EXPECT_EQ(builds(start), 0);
  EXPECT_EQ(Get(start, "glint_program_cache_lookups_total{result=\"memory_hit\"}"), 0);
  const std::string log = server->Stderr();
  EXPECT_NE(log.find("--warm none: no kernels built before SERVING (0 compiled, 0 from cache"),
            std::string::npos)
      << log;

  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  auto stub = glint::v1::GlintService::NewStub(channel);
  auto evaluate = [&](const glint::v1::EvaluateRequest &r) {
    glint::v1::EvaluateResponse response;
    grpc::ClientContext ctx;
    const grpc::Status st = stub->Evaluate(&ctx, r, &response);
    EXPECT_TRUE(st.ok()) << st.error_message();
    return response.stats();
  };
  glint::v1::EvaluateRequest beckmann = SmoothProbes(30);
  beckmann.mutable_material()->set_ndf(glint::v1::BECKMANN);
  double compile_sum = 0, compute_sum = 0;
  double before = builds(start);
  int cold = 0;
  for (const glint::v1::EvaluateRequest &r : {SmoothProbes(30), SmoothProbes(30), beckmann}) {
    const glint::v1::EvaluateStats stats = evaluate(r);
    const double now = builds(scrape());
    const bool built = now > before;
    before = now;
    cold += built;
    EXPECT_EQ(stats.compile_ms() > 0, built)
        << "compile_ms " << stats.compile_ms() << " with " << (built ? "a" : "no") << " build";
    EXPECT_GE(stats.compute_ms(), 0);
    compile_sum += stats.compile_ms() / 1e3;
    compute_sum += stats.compute_ms() / 1e3;
  }
  EXPECT_EQ(cold, 2);  // GGX's first request and Beckmann's; not GGX's second

  // The same on EvaluateStream, each chunk's result carrying its own stats: chunk 0 brings a
  // variant not built yet (a dielectric), chunk 1 only queries of it (no build, compile_ms 0),
  // chunk 2 new settings of another unbuilt variant (a conductor). One chunk at a time, so that
  // each result can be held against the program-cache counters.
  glint::v1::EvaluateRequest dielectric = SmoothProbes(30);
  dielectric.mutable_material()->mutable_dielectric()->set_ior(1.5f);
  glint::v1::EvaluateRequest queries_only;
  *queries_only.mutable_queries() = SmoothProbes(20).queries();
  glint::v1::EvaluateRequest conductor = SmoothProbes(10);
  for (int c = 0; c < 3; ++c) {
    conductor.mutable_material()->mutable_conductor()->add_eta(0.2f);
    conductor.mutable_material()->mutable_conductor()->add_k(3.0f);
  }
  {
    grpc::ClientContext ctx;
    auto stream = stub->EvaluateStream(&ctx);
    const glint::v1::EvaluateRequest *chunks[3] = {&dielectric, &queries_only, &conductor};
    const bool builds_expected[3] = {true, false, true};
    for (uint64_t k = 0; k < 3; ++k) {
      SCOPED_TRACE("stream chunk " + std::to_string(k));
      glint::v1::EvaluateChunk chunk;
      chunk.set_chunk_index(k);
      *chunk.mutable_request() = *chunks[k];
      ASSERT_TRUE(stream->Write(chunk));
      glint::v1::EvaluateChunkResult result;
      ASSERT_TRUE(stream->Read(&result));
      ASSERT_EQ(result.chunk_index(), k);
      const glint::v1::EvaluateStats &stats = result.result().stats();
      const double now = builds(scrape());
      const bool built = now > before;
      before = now;
      EXPECT_EQ(built, builds_expected[k]);
      EXPECT_EQ(stats.compile_ms() > 0, built)
          << "compile_ms " << stats.compile_ms() << " with " << (built ? "a" : "no") << " build";
      EXPECT_GE(stats.compute_ms(), 0);
      compile_sum += stats.compile_ms() / 1e3;
      compute_sum += stats.compute_ms() / 1e3;
    }
    ASSERT_TRUE(stream->WritesDone());
    const grpc::Status st = stream->Finish();
    ASSERT_TRUE(st.ok()) << st.error_message();
  }

  const auto after = scrape();
  EXPECT_EQ(Get(after, "glint_compile_seconds_count{model=\"SMOOTH\"}"), 4);
  EXPECT_DOUBLE_EQ(Get(after, "glint_compile_seconds_sum{model=\"SMOOTH\"}"), compile_sum);
  ExpectHistogram(after, "glint_compile_seconds", "model=\"SMOOTH\"");
  EXPECT_EQ(Get(after, "glint_compute_seconds_count{model=\"SMOOTH\"}"), 6);
  EXPECT_DOUBLE_EQ(Get(after, "glint_compute_seconds_sum{model=\"SMOOTH\"}"), compute_sum);
}

// Slow or idle HTTP peers must not starve a scrape: twelve connections each send half a request
// and stall (cpp-httplib's default pool has 8 threads and a 5 s read timeout: the scrape waited
// ~9 s). A Prometheus scrape times out after 10 s by default; this one gets 4 s.
TEST(MetricsEndToEnd, StalledConnectionsDoNotStarveAScrape) {
  TempDir dir("glint_metrics_stall");
  std::string error;
  auto server = Glintd::Start(GLINTD_PATH, dir, "glintd",
                              {"--device", "host", "--metrics-listen", "127.0.0.1:0"}, &error);
  ASSERT_NE(server, nullptr) << error;
  const int metrics_port = server->MetricsPort();  // --metrics-listen 127.0.0.1:0
  ASSERT_GT(metrics_port, 0) << server->Stderr();
  std::vector<int> stalled;
  for (int k = 0; k < 12; ++k) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    ASSERT_GE(fd, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(metrics_port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr *>(&addr), sizeof addr), 0);
    const char partial[] = "GET /metrics HTTP/1.1\r\nHost: x";
    ASSERT_GT(send(fd, partial, sizeof partial - 1, 0), 0);
    stalled.push_back(fd);
  }
  httplib::Client http("127.0.0.1", metrics_port);
  http.set_read_timeout(std::chrono::seconds(4));
  http.set_connection_timeout(std::chrono::seconds(4));
  auto res = http.Get("/metrics");
  EXPECT_TRUE(res) << "no scrape within 4 s with 12 stalled connections open";
  if (res) {
    EXPECT_NE(res->body.find("glint_"), std::string::npos);
  }
  for (const int fd : stalled) close(fd);
}

TEST(MetricsEndToEnd, BadListenAddressIsRefusedAtStart) {
  TempDir dir("glint_metrics");
  std::string error;
  auto server =
      Glintd::Start(GLINTD_PATH, dir, "glintd",
                    {"--device", "host", "--metrics-listen", "127.0.0.1:notaport"}, &error);
  EXPECT_EQ(server, nullptr);
  EXPECT_NE(error.find("--metrics-listen 127.0.0.1:notaport: expected HOST:PORT"),
            std::string::npos)
      << error;
  // The start-up wait ended when glintd exited, and says how (tests/support/glintd_process.h).
  EXPECT_NE(error.find("glintd exited before SERVING (exit status 1)"), std::string::npos) << error;
}

}  // namespace
