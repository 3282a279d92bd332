// Scale-out as an ops engineer deploys it (issue 12): three glintd replicas behind nginx from
// Debian's package, running the configuration we ship (docker/nginx/glint-lb.conf) with only its
// upstream addresses, listen port and scratch paths replaced. A sharded workload goes through the
// balancer from four client threads; one replica is killed (SIGKILL) once a third of the shards
// are back. Every shard must still come back, bit-identical to one server evaluating the whole
// batch in one call (the determinism contract makes that the exact reference), the balancer's
// log must show that all three replicas served calls, and calls must complete after the kill.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <atomic>
#include <fstream>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "client/lib/glint_client.h"
#include "glintd_process.h"

namespace {

using glint::client::ClientOptions;
using glint::client::GlintClient;
using glint::test::FreeLoopbackPort;
using glint::test::Glintd;
using glint::test::ReadFile;
using glint::test::Spawn;
using glint::test::TempDir;

constexpr uint32_t kShards = 48;
constexpr uint32_t kShardQueries = 4096;

// Smooth GGX under a square light with Monte Carlo area sampling: tens of milliseconds per shard
// on the host path, so the kill lands while replicas are busy.
glint::v1::EvaluateRequest Settings() {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.25f);
  m->set_alpha_y(0.4f);
  for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(0.6f);
  auto *polygon = r.add_lights()->mutable_polygon();
  for (const float v : {-1.f, -1.f, 2.f, 1.f, -1.f, 2.f, 1.f, 1.f, 2.f, -1.f, 1.f, 2.f}) {
    polygon->add_vertices(v);
  }
  for (const float l : {4.f, 3.f, 2.f}) polygon->add_radiance(l);
  r.set_area_method(glint::v1::MONTE_CARLO);
  r.set_area_samples(32);
  r.set_seed(7);
  return r;
}

// Query i of the whole batch: view directions over the upper hemisphere, uv spread out.
void AddQuery(glint::v1::QueryBatch *q, uint32_t i) {
  const float a = 0.37f * static_cast<float>(i % 997);
  const float z = 0.05f + 0.9f * static_cast<float>((i * 7919u) % 1000u) / 1000.f;
  const float s = std::sqrt(1.f - z * z);
  q->add_wo(s * std::cos(a));
  q->add_wo(s * std::sin(a));
  q->add_wo(z);
  q->add_uv(static_cast<float>(i % 128) / 128.f);
  q->add_uv(static_cast<float>(i / 128) / 128.f);
}

glint::v1::EvaluateRequest Shard(uint32_t shard) {
  glint::v1::EvaluateRequest r = Settings();
  for (uint32_t i = shard * kShardQueries; i < (shard + 1) * kShardQueries; ++i) {
    AddQuery(r.mutable_queries(), i);
  }
  r.mutable_queries()->set_count(kShardQueries);
  return r;
}

// The shipped balancer configuration with this test's upstreams, port and scratch paths.
std::string BalancerConfig(const std::vector<std::string> &upstreams, int port,
                           const std::string &scratch) {
  std::string conf = ReadFile(std::string(GLINT_SOURCE_DIR) + "/docker/nginx/glint-lb.conf");
  const std::regex server_line(R"(server glintd:50051([^;]*);)");
  std::smatch m;
  if (!std::regex_search(conf, m, server_line)) return "";
  std::string servers;
  for (const auto &u : upstreams) servers += "server " + u + m[1].str() + ";\n        ";
  conf = std::regex_replace(conf, server_line, servers, std::regex_constants::format_first_only);
  conf = std::regex_replace(conf, std::regex(R"(listen 50051 )"),
                            "listen 127.0.0.1:" + std::to_string(port) + " ");
  // nginx's compiled-in scratch directories (/var/lib/nginx) need root; the test may not be.
  std::string paths;
  for (const char *kind : {"client_body", "proxy", "fastcgi", "uwsgi", "scgi"}) {
    paths += std::string("    ") + kind + "_temp_path " + scratch + "/" + kind + ";\n";
  }
  return std::regex_replace(conf, std::regex(R"(http \{\n)"), "http {\n" + paths,
                            std::regex_constants::format_first_only);
}

// How many access-log lines name each upstream address.
std::vector<int> CallsPerUpstream(const std::string &log,
                                  const std::vector<std::string> &upstreams) {
  std::vector<int> calls(upstreams.size(), 0);
  std::istringstream lines(log);
  std::string line;
  while (std::getline(lines, line)) {
    for (size_t u = 0; u < upstreams.size(); ++u) {
      if (line.find(upstreams[u]) != std::string::npos) ++calls[u];
    }
  }
  return calls;
}

TEST(NginxFailover, KilledReplicaLosesNoShard) {
#ifndef NGINX_PATH
  GTEST_SKIP() << "nginx not found at configure time (scripts/install-deps.sh installs it)";
#else
  TempDir dir("glint_nginx");
  std::vector<std::unique_ptr<Glintd> > replicas;
  std::vector<std::string> upstreams;
  for (int r = 0; r < 3; ++r) {
    std::string error;
    // Host path: no kernel compilation, and every replica computes bit-identically.
    replicas.push_back(Glintd::Start(GLINTD_PATH, dir, "replica" + std::to_string(r),
                                     {"--device", "host", "--workers", "1"}, &error));
    ASSERT_NE(replicas.back(), nullptr) << error;
    upstreams.push_back(replicas.back()->address());
  }

  // nginx is forked before this process makes its first gRPC call: a fork after gRPC has
  // started its threads left this process unable to connect anywhere (gRPC 1.51).

  const std::string scratch = dir.File("nginx");
  ASSERT_EQ(mkdir(scratch.c_str(), 0777), 0);
  chmod(scratch.c_str(), 0777);  // nginx's workers drop to `nobody` when the test runs as root
  const int port = FreeLoopbackPort();
  const std::string conf = BalancerConfig(upstreams, port, scratch);
  ASSERT_FALSE(conf.empty()) << "docker/nginx/glint-lb.conf has no `server glintd:50051` line";
  const std::string conf_path = dir.File("nginx.conf");
  std::ofstream(conf_path) << conf;
  const std::string access_log = dir.File("access.log");
  const pid_t nginx =
      Spawn({NGINX_PATH, "-p", scratch, "-c", conf_path, "-e", dir.File("error.log"), "-g",
             "daemon off; pid " + scratch + "/nginx.pid;"},
            access_log, dir.File("nginx.stderr"));
  ASSERT_GT(nginx, 0);
  struct KillOnExit {
    pid_t pid;
    ~KillOnExit() {
      kill(pid, SIGTERM);
      waitpid(pid, nullptr, 0);
    }
  } stop_nginx{nginx};

  // The reference: one server, the whole batch in one call (streamed by the client library).
  std::vector<float> reference;
  {
    glint::v1::EvaluateRequest all = Settings();
    for (uint32_t i = 0; i < kShards * kShardQueries; ++i) AddQuery(all.mutable_queries(), i);
    all.mutable_queries()->set_count(kShards * kShardQueries);
    GlintClient direct(upstreams[0]);
    const grpc::Status s = direct.Evaluate(all, &reference);
    ASSERT_TRUE(s.ok()) << glint::client::FormatStatus(s);
    ASSERT_EQ(reference.size(), size_t{kShards} * kShardQueries * 3);
  }

  ClientOptions options;
  options.retry.max_attempts = 8;
  GlintClient balanced("127.0.0.1:" + std::to_string(port), options);
  std::string why;
  // A bound on a poll that ends when nginx answers (milliseconds when idle): 120 s so that a
  // loaded machine starting nginx and its workers is not reported as a failure.
  ASSERT_TRUE(balanced.WaitUntilServing(std::chrono::seconds(120), &why))
      << why << "\nnginx error log:\n"
      << ReadFile(dir.File("error.log")) << ReadFile(dir.File("nginx.stderr"));

  std::atomic<uint32_t> next{0}, done{0}, done_after_kill{0}, retried{0};
  std::atomic<bool> killed{false};
  std::mutex failures_mutex;
  std::vector<std::string> failures;
  std::vector<std::vector<float> > results(kShards);
  auto worker = [&] {
    for (uint32_t shard = next++; shard < kShards; shard = next++) {
      glint::client::EvaluateInfo info;
      const grpc::Status s = balanced.Evaluate(Shard(shard), &results[shard], {}, &info);
      if (!s.ok()) {
        std::lock_guard<std::mutex> lock(failures_mutex);
        failures.push_back("shard " + std::to_string(shard) + ": " +
                           glint::client::FormatStatus(s));
        continue;
      }
      if (info.attempts > 1) ++retried;
      if (killed) ++done_after_kill;
      if (++done == kShards / 3) {
        replicas[1]->Signal(SIGKILL);
        killed = true;
      }
    }
  };
  std::vector<std::thread> clients;
  for (int t = 0; t < 4; ++t) clients.emplace_back(worker);
  for (auto &t : clients) t.join();

  EXPECT_TRUE(failures.empty()) << failures.size() << " shards failed, first: " << failures[0];
  ASSERT_TRUE(killed);
  EXPECT_FALSE(replicas[1]->Alive()) << "the killed replica still runs";
  EXPECT_GT(done_after_kill.load(), 0u) << "no shard completed after the kill";
  for (uint32_t shard = 0; shard < kShards; ++shard) {
    ASSERT_EQ(results[shard].size(), size_t{kShardQueries} * 3) << "shard " << shard;
    const float *expected = reference.data() + size_t{shard} * kShardQueries * 3;
    for (size_t k = 0; k < results[shard].size(); ++k) {
      ASSERT_EQ(results[shard][k], expected[k])
          << "shard " << shard << " value " << k << " differs from the single-server run";
    }
  }
  const std::vector<int> calls = CallsPerUpstream(ReadFile(access_log), upstreams);
  for (size_t u = 0; u < calls.size(); ++u) {
    EXPECT_GT(calls[u], 0) << "replica " << u << " (" << upstreams[u] << ") served no call";
  }
  std::printf("calls per replica %d / %d / %d; %u shards needed a client retry\n", calls[0],
              calls[1], calls[2], retried.load());
#endif
}

}  // namespace
