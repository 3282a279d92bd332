// `--server a,b,c` (issue 12, scale-out): the server-list parser, then two glintd on loopback
// behind one round_robin channel. One large batch spread over them must come back complete
// and bit-identical to one server's result (the determinism contract: a query's result depends
// only on its own inputs), and both servers must have evaluated part of it: each one's
// glint_queries_evaluated_total (scraped from --metrics-listen with cpp-httplib) moves by a
// positive amount, and the two moves add up to exactly the batch.
#include "client/lib/server_list.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "client/lib/glint_client.h"
#include "client/lib/load_runner.h"
#include "glintd_process.h"

namespace {

using glint::client::ParseServerList;
using glint::test::Glintd;
using glint::test::TempDir;

TEST(ServerList, OneAddressIsKeptAsIs) {
  for (const std::string a : {"127.0.0.1:50051", "dns:///glint:50051", "unix:/tmp/g.sock"}) {
    const auto t = ParseServerList(a);
    EXPECT_EQ(t.target, a);
    EXPECT_EQ(t.servers, 1u);
    EXPECT_FALSE(t.round_robin);
  }
}

TEST(ServerList, ListBecomesAStaticRoundRobinTarget) {
  auto t = ParseServerList("127.0.0.1:1,127.0.0.2:2,localhost:3");
  EXPECT_EQ(t.target, "ipv4:127.0.0.1:1,127.0.0.2:2,127.0.0.1:3");
  EXPECT_EQ(t.servers, 3u);
  EXPECT_TRUE(t.round_robin);
  t = ParseServerList("[::1]:1,[::1]:2");
  EXPECT_EQ(t.target, "ipv6:[::1]:1,[::1]:2");
  EXPECT_EQ(t.servers, 2u);
}

TEST(ServerList, BadEntriesAreRefusedNamingThem) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"127.0.0.1:1,,127.0.0.1:2", "empty entry"},
      {"127.0.0.1:1,127.0.0.1", "'127.0.0.1' is not host:port"},
      {"127.0.0.1:1,dns:///x:2", "'dns:///x:2' has a scheme"},
      {"127.0.0.1:1,127.0.0.1:http", "not a number"},
      {"127.0.0.1:1,[::1]:2", "mixes IPv4 and IPv6"},
      {"127.0.0.1:1,no-such-host.invalid:2", "cannot resolve 'no-such-host.invalid'"},
  };
  for (const auto &[list, why] : bad) {
    try {
      ParseServerList(list);
      ADD_FAILURE() << list << " was accepted";
    } catch (const std::invalid_argument &e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  }
}

// glint_queries_evaluated_total{model="SMOOTH"} of the server whose metrics are on `port`.
double EvaluatedSmooth(int port) {
  httplib::Client http("127.0.0.1", port);
  auto res = http.Get("/metrics");
  EXPECT_TRUE(res) << "no answer from /metrics on port " << port;
  if (!res) return -1;
  std::smatch m;
  const std::regex line(R"(glint_queries_evaluated_total\{model="SMOOTH"\} (\S+))");
  return std::regex_search(res->body, m, line) ? std::strtod(m[1].str().c_str(), nullptr) : 0.0;
}

TEST(ServerListEndToEnd, OneBatchSpreadOverTwoServersEqualsOneServer) {
  TempDir dir("glint_server_list");
  std::string error;
  std::vector<std::unique_ptr<Glintd>> servers;
  std::vector<int> metrics;
  for (const char *name : {"a", "b"}) {
    servers.push_back(
        Glintd::Start(GLINTD_PATH, dir, name, {"--metrics-listen", "127.0.0.1:0"}, &error));
    ASSERT_NE(servers.back(), nullptr) << error;
    metrics.push_back(servers.back()->MetricsPort());  // --metrics-listen 127.0.0.1:0
    ASSERT_GT(metrics.back(), 0) << servers.back()->Stderr();
  }
  glint::v1::EvaluateRequest request;
  auto *m = request.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  constexpr uint32_t kQueries = 50000;
  *request.mutable_queries() = glint::client::MakeLoadQueries(kQueries, true);

  glint::client::ClientOptions options;
  options.max_chunk_queries = 4096;  // 13 chunks
  glint::client::GlintClient both(servers[0]->address() + "," + servers[1]->address(), options);
  EXPECT_EQ(both.servers(), 2u);
  // round_robin picks among the READY subchannels only: until both connections are up, every
  // call goes to the first. Small calls until each server has answered one (bounded), so the
  // spread below meets both connections ready (on a loaded machine the second one can lag).
  {
    const double start[2] = {EvaluatedSmooth(metrics[0]), EvaluatedSmooth(metrics[1])};
    glint::v1::EvaluateRequest small = request;
    *small.mutable_queries() = glint::client::MakeLoadQueries(8, true);
    std::vector<float> ignored;
    // Bounded in time, not in calls: 100 quick calls can all finish before a second connection
    // that lags on a loaded machine is READY.
    bool both_answered = false;
    int calls = 0;
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!both_answered && std::chrono::steady_clock::now() < give_up) {
      ASSERT_TRUE(both.Evaluate(small, &ignored).ok());
      ++calls;
      both_answered =
          EvaluatedSmooth(metrics[0]) > start[0] && EvaluatedSmooth(metrics[1]) > start[1];
      if (!both_answered) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_TRUE(both_answered) << "round_robin never reached both servers in 30 s (" << calls
                               << " calls)";
  }
  const double before[2] = {EvaluatedSmooth(metrics[0]), EvaluatedSmooth(metrics[1])};
  std::vector<float> spread;
  glint::client::EvaluateInfo info;
  uint64_t last_progress = 0;
  grpc::Status s = both.Evaluate(
      request, &spread, [&](uint64_t done, uint64_t) { last_progress = done; }, &info);
  ASSERT_TRUE(s.ok()) << glint::client::FormatStatus(s);
  EXPECT_EQ(info.servers, 2u);
  EXPECT_EQ(info.chunks, (kQueries + 4095) / 4096);
  EXPECT_EQ(last_progress, kQueries);
  const double after[2] = {EvaluatedSmooth(metrics[0]), EvaluatedSmooth(metrics[1])};
  const double moved[2] = {after[0] - before[0], after[1] - before[1]};
  // Every chunk answered exactly once, and each server took part.
  EXPECT_EQ(moved[0] + moved[1], double(kQueries));
  EXPECT_GT(moved[0], 0.0) << "server a evaluated nothing";
  EXPECT_GT(moved[1], 0.0) << "server b evaluated nothing";

  // One server alone (unary or streamed, as the client picks): the same bits.
  glint::client::GlintClient one(servers[1]->address());
  std::vector<float> single;
  s = one.Evaluate(request, &single);
  ASSERT_TRUE(s.ok()) << glint::client::FormatStatus(s);
  ASSERT_EQ(spread.size(), size_t(kQueries) * 3);
  ASSERT_EQ(single.size(), spread.size());
  EXPECT_EQ(std::memcmp(spread.data(), single.data(), spread.size() * sizeof(float)), 0);
}

}  // namespace
