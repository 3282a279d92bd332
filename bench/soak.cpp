// Soak: mixed load against one glintd for a fixed time while its RSS is sampled from /proc, and
// a check that the RSS stays under the server's stated memory bound (glintd --help, "memory:"):
//
//   peak RSS <= idle RSS + M x (3 x (max-pending + calls being received) + 2 x workers)
//
// with M the largest request. The load (each kind on its own threads and connections, each
// thread one call at a time, so at most that many calls are being received at once):
//   small      256 probes (unary), the preview case; batchable (glintd runs with batching on)
//   large      1M queries, one point light: a 12.6 MB body, M
//   cancelled  a REFERENCE request of ~10 s with a 300 ms deadline, or cancelled by its client
//   refused    a request over --max-query-cost (refused at admission), and an over-limit claim
//              in the call metadata (refused before the body is parsed)
// and with --max-pending 4 the server is overloaded (RESOURCE_EXHAUSTED) much of the time.
// Every call must end OK or with the status its kind expects; glintd must be alive at the end.
//
//   build/bench/glint_soak --glintd build/server/glintd --duration 60 [--json OUT.json]
// Exit status 0 when every check held. The 10 s variant runs in ctest (soak_short); the 60 s
// one is `ctest -L soak_long` when configured with -DGLINT_LONG_TESTS=ON.
#include <grpcpp/grpcpp.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "test_queries.h"

namespace {

namespace v1 = glint::v1;
using Clock = std::chrono::steady_clock;

long ProcStatusKb(pid_t pid, const char *field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field, 0) == 0) return std::atol(line.c_str() + std::strlen(field));
  return -1;
}

double Mb(long kb) {
  return double(kb) / 1024.0;
}

v1::EvaluateRequest Smooth() {
  v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::SMOOTH);
  m->set_ndf(v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.2f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  return r;
}

void AddPointLight(v1::EvaluateRequest *r) {
  auto *p = r->add_lights()->mutable_point();
  for (float v : {0.5f, -1.0f, 2.0f}) p->add_position(v);
  for (float v : {4.0f, 4.0f, 4.0f}) p->add_intensity(v);
}

void AddPolygon(v1::EvaluateRequest *r, int vertices, float dx) {
  auto *p = r->add_lights()->mutable_polygon();
  for (int k = 0; k < vertices; ++k) {
    const double t = -2.0 * 3.14159265358979 * k / vertices;
    for (double c : {dx + 2.0 * std::cos(t), 2.0 * std::sin(t), 3.0}) p->add_vertices(float(c));
  }
  for (float v : {1.0f, 1.0f, 1.0f}) p->add_radiance(v);
  p->set_two_sided(true);
}

struct Tally {
  std::atomic<long> ok{0}, refused{0}, stopped{0}, unexpected{0};
  std::mutex mutex;
  std::string first_unexpected;
  void Unexpected(const char *kind, const grpc::Status &s) {
    ++unexpected;
    std::lock_guard<std::mutex> lock(mutex);
    if (first_unexpected.empty())
      first_unexpected =
          std::string(kind) + ": " + std::to_string(int(s.error_code())) + " " + s.error_message();
  }
};

}  // namespace

int main(int argc, char **argv) {
  std::string glintd_path, json_path;
  double duration = 60;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--glintd" && i + 1 < argc)
      glintd_path = argv[++i];
    else if (a == "--duration" && i + 1 < argc)
      duration = std::atof(argv[++i]);
    else if (a == "--json" && i + 1 < argc)
      json_path = argv[++i];
    else {
      std::fprintf(stderr, "usage: glint_soak --glintd PATH [--duration S] [--json OUT]\n");
      return 2;
    }
  }
  if (glintd_path.empty() || !(duration > 0 && duration <= 3600)) {
    std::fprintf(stderr, "glint_soak: --glintd PATH and --duration in (0, 3600] needed\n");
    return 2;
  }
  constexpr int kWorkers = 2, kMaxPending = 4, kSmall = 3, kLarge = 2, kCancel = 1, kRefused = 1;
  glint::test::TempDir dir("glint_soak");
  std::string error;
  auto server = glint::test::Glintd::Start(
      glintd_path, dir, "soak",
      {"--workers", std::to_string(kWorkers), "--max-pending", std::to_string(kMaxPending),
       "--max-message-mb", "16", "--slice-ms", "50", "--batch-max-queries", "4096",
       "--batch-delay-us", "200", "--max-batch", "1048576"},
      &error);
  if (!server) {
    std::fprintf(stderr, "glint_soak: %s\n", error.c_str());
    return 1;
  }
  grpc::ChannelArguments args;
  args.SetMaxSendMessageSize(16 << 20);
  args.SetMaxReceiveMessageSize(16 << 20);
  auto stub = [&] {
    return v1::GlintService::NewStub(
        grpc::CreateCustomChannel(server->address(), grpc::InsecureChannelCredentials(), args));
  };
  v1::EvaluateRequest small = Smooth();
  *small.mutable_queries() = glint::test::RandomQueries(256, true, false, 1);
  v1::EvaluateRequest large = Smooth();
  AddPointLight(&large);
  large.mutable_queries()->set_count(1u << 20);
  for (uint32_t i = 0; i < (1u << 20); ++i)
    for (float v : {0.0f, 0.6f, 0.8f}) large.mutable_queries()->add_wo(v);
  v1::EvaluateRequest slow = Smooth();  // REFERENCE, 4 quads x 512 nodes: ~50 ms per query
  for (int k = 0; k < 4; ++k) AddPolygon(&slow, 4, 0.5f * float(k));
  slow.set_area_method(v1::REFERENCE);
  slow.set_area_samples(512);
  *slow.mutable_queries() = glint::test::RandomQueries(200, false, false, 5);
  v1::EvaluateRequest costly = Smooth();  // 64 sixteen-gons x 1024 nodes: over --max-query-cost
  for (int k = 0; k < 64; ++k) AddPolygon(&costly, 16, 0.01f * float(k));
  costly.set_area_method(v1::REFERENCE);
  costly.set_area_samples(1024);
  *costly.mutable_queries() = glint::test::RandomQueries(16, false, false, 8);
  const double m_bytes = double(large.ByteSizeLong());

  auto call = [](v1::GlintService::Stub *s, const v1::EvaluateRequest &r,
                 std::chrono::milliseconds timeout, const char *claim = nullptr,
                 bool cancel = false) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + timeout);
    if (claim) ctx.AddMetadata("glint-query-count", claim);
    v1::EvaluateResponse res;
    std::thread canceller;
    if (cancel)
      canceller = std::thread([&ctx] {
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
        ctx.TryCancel();
      });
    grpc::Status st = s->Evaluate(&ctx, r, &res);
    if (canceller.joinable()) canceller.join();
    return st;
  };
  {  // Warm: the kernels and gRPC's buffers exist before idle is read.
    auto s = stub();
    if (!call(s.get(), large, std::chrono::seconds(120)).ok() ||
        !call(s.get(), small, std::chrono::seconds(120)).ok()) {
      std::fprintf(stderr, "glint_soak: warm-up requests failed\n");
      return 1;
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const long idle_kb = ProcStatusKb(server->pid(), "VmRSS:");
  const double bound_kb =
      double(idle_kb) +
      m_bytes / 1024 *
          (3.0 * (kMaxPending + kSmall + kLarge + kCancel + kRefused) + 2.0 * kWorkers);

  Tally small_t, large_t, cancel_t, refused_t;
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(duration));
  std::atomic<long> peak_sampled_kb{idle_kb};
  std::atomic<bool> done{false};
  std::vector<std::pair<double, long>> rss_series;  // (s, kB) every second, for the report
  std::thread sampler([&] {
    const auto t0 = Clock::now();
    int tick = 0;
    while (!done) {
      const long kb = ProcStatusKb(server->pid(), "VmRSS:");
      if (kb > peak_sampled_kb) peak_sampled_kb = kb;
      if (tick++ % 20 == 0)
        rss_series.push_back({std::chrono::duration<double>(Clock::now() - t0).count(), kb});
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  std::vector<std::thread> threads;
  auto loop = [&](Tally &t, const char *kind, auto body) {
    threads.emplace_back([&t, kind, body, &end, &stub] {
      auto s = stub();
      for (long k = 0; k < 1000000 && Clock::now() < end; ++k) body(s.get(), t, kind, k);
    });
  };
  auto expect = [](Tally &t, const char *kind, const grpc::Status &s,
                   std::initializer_list<grpc::StatusCode> stop_codes) {
    if (s.ok()) {
      ++t.ok;
    } else if (s.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      ++t.refused;
    } else {
      for (grpc::StatusCode c : stop_codes)
        if (s.error_code() == c) {
          ++t.stopped;
          return;
        }
      t.Unexpected(kind, s);
    }
  };
  for (int i = 0; i < kSmall; ++i)
    loop(small_t, "small", [&](v1::GlintService::Stub *s, Tally &t, const char *kind, long) {
      expect(t, kind, call(s, small, std::chrono::seconds(60)), {});
    });
  for (int i = 0; i < kLarge; ++i)
    loop(large_t, "large", [&](v1::GlintService::Stub *s, Tally &t, const char *kind, long) {
      expect(t, kind, call(s, large, std::chrono::seconds(60)), {});
    });
  for (int i = 0; i < kCancel; ++i)
    loop(cancel_t, "cancelled", [&](v1::GlintService::Stub *s, Tally &t, const char *kind, long k) {
      const bool by_client = k % 2 == 0;
      grpc::Status st =
          call(s, slow, std::chrono::milliseconds(by_client ? 60000 : 300), nullptr, by_client);
      if (st.ok())
        t.Unexpected(kind, grpc::Status(grpc::StatusCode::UNKNOWN, "a 10 s request finished"));
      else
        expect(t, kind, st, {grpc::StatusCode::CANCELLED, grpc::StatusCode::DEADLINE_EXCEEDED});
    });
  for (int i = 0; i < kRefused; ++i)
    loop(refused_t, "refused", [&](v1::GlintService::Stub *s, Tally &t, const char *kind, long k) {
      // Over the cost limit (RESOURCE_EXHAUSTED naming it), or an over-limit claim
      // (INVALID_ARGUMENT from the metadata); both must be refused, never run.
      grpc::Status st = k % 2 == 0 ? call(s, costly, std::chrono::seconds(60))
                                   : call(s, small, std::chrono::seconds(60), "99999999");
      const bool refused = st.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED ||
                           (st.error_code() == grpc::StatusCode::INVALID_ARGUMENT &&
                            st.error_message().find("call metadata") != std::string::npos);
      if (refused)
        ++t.refused;
      else
        t.Unexpected(kind, st);
    });
  for (auto &t : threads) t.join();
  done = true;
  sampler.join();
  const long hwm_kb = ProcStatusKb(server->pid(), "VmHWM:");
  const long end_kb = ProcStatusKb(server->pid(), "VmRSS:");
  const bool alive = server->Alive();
  const long unexpected =
      small_t.unexpected + large_t.unexpected + cancel_t.unexpected + refused_t.unexpected;
  std::printf(
      "soak %.0f s: glintd --workers %d --max-pending %d --max-message-mb 16, batching on\n",
      duration, kWorkers, kMaxPending);
  std::printf("%-10s %8s %8s %8s %10s\n", "kind", "ok", "refused", "stopped", "unexpected");
  for (auto [name, t] : {std::pair{"small", &small_t}, std::pair{"large", &large_t},
                         std::pair{"cancelled", &cancel_t}, std::pair{"refused", &refused_t}})
    std::printf("%-10s %8ld %8ld %8ld %10ld\n", name, t->ok.load(), t->refused.load(),
                t->stopped.load(), t->unexpected.load());
  std::printf(
      "RSS: idle %.0f MB, peak sampled %.0f MB, VmHWM %.0f MB, at end %.0f MB; bound %.0f MB "
      "(M = %.1f MB)\n",
      Mb(idle_kb), Mb(peak_sampled_kb.load()), Mb(hwm_kb), Mb(end_kb), bound_kb / 1024.0,
      m_bytes / 1048576.0);
  std::printf("RSS over time (s, MB):");
  for (auto [t, kb] : rss_series) std::printf(" %.0f:%.0f", t, Mb(kb));
  std::printf("\n");
  for (Tally *t : {&small_t, &large_t, &cancel_t, &refused_t})
    if (!t->first_unexpected.empty())
      std::printf("first unexpected: %s\n", t->first_unexpected.c_str());
  if (!json_path.empty()) {
    std::ofstream(json_path) << "{\"duration_s\": " << duration << ", \"idle_mb\": " << Mb(idle_kb)
                             << ", \"peak_mb\": " << Mb(hwm_kb) << ", \"end_mb\": " << Mb(end_kb)
                             << ", \"bound_mb\": " << bound_kb / 1024.0
                             << ", \"small_ok\": " << small_t.ok << ", \"large_ok\": " << large_t.ok
                             << ", \"refused\": "
                             << small_t.refused + large_t.refused + refused_t.refused
                             << ", \"stopped\": " << cancel_t.stopped
                             << ", \"unexpected\": " << unexpected << "}\n";
  }
  bool pass = true;
  auto check = [&](bool ok, const char *what) {
    if (!ok) std::printf("FAIL: %s\n", what);
    pass = pass && ok;
  };
  check(alive, "glintd is alive at the end");
  check(unexpected == 0, "every call ended OK or with its kind's expected status");
  check(double(hwm_kb) <= bound_kb, "peak RSS (VmHWM) within the stated memory bound");
  check(small_t.ok > 0 && large_t.ok > 0, "small and large requests were served");
  check(cancel_t.stopped > 0 && refused_t.refused > 0, "cancelled and refused calls happened");
  return pass ? 0 : 1;
}
