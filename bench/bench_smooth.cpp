// Smooth-model throughput for one batch of queries (default 1M), three ways:
//   device  in-process on the OpenCL device (DeviceEngine, one lane)
//   host    in-process on the host scalar path (one thread, same kernels/*.h)
//   glintd  end to end through glintd on loopback with the client library
//           (protobuf encoding and the gRPC transfer both ways; the library
//           streams batches that do not fit one message)
// Reports the median of --repeat runs as evaluations per second.
//
//   build/bench/bench_smooth [--queries N] [--repeat R] [--fp64] [--lights]
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>

#include "client/lib/glint_client.h"
#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "server/device_engine.h"
#include "server/host_path.h"
#include "test_queries.h"

namespace {

using Clock = std::chrono::steady_clock;

template <typename F>
double MedianSeconds(int repeat, F &&run) {
  std::vector<double> t;
  for (int r = 0; r < repeat; ++r) {
    auto t0 = Clock::now();
    run();
    t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

glint::v1::EvaluateRequest MakeRequest(uint32_t n, bool fp64, bool lights) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  r.set_precision(fp64 ? glint::v1::FP64 : glint::v1::FP32);
  *r.mutable_queries() = glint::test::RandomQueries(n, !lights, lights, 42);
  if (lights) {
    auto *d = r.add_lights()->mutable_directional();
    for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
    for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
    auto *p = r.add_lights()->mutable_point();
    for (float v : {0.0f, 1.0f, 2.0f}) p->add_position(v);
    for (float v : {5.0f, 5.0f, 5.0f}) p->add_intensity(v);
  }
  return r;
}

}  // namespace

int main(int argc, char **argv) {
  uint32_t n = 1u << 20;
  int repeat = 5;
  bool fp64 = false, lights = false;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--queries" && i + 1 < argc)
      n = uint32_t(std::stoul(argv[++i]));
    else if (a == "--repeat" && i + 1 < argc)
      repeat = std::stoi(argv[++i]);
    else if (a == "--fp64")
      fp64 = true;
    else if (a == "--lights")
      lights = true;
    else {
      std::fprintf(stderr, "usage: bench_smooth [--queries N] [--repeat R] [--fp64] [--lights]\n");
      return 2;
    }
  }
  glint::v1::EvaluateRequest request = MakeRequest(n, fp64, lights);
  const glint::EvalPlan plan = glint::MakeEvalPlan(request, request.queries());
  std::vector<float> out(size_t(3) * n);
  std::printf("smooth model, %u queries, kernel %s, median of %d\n", n,
              plan.spec.Describe().c_str(), repeat);
  std::printf("| path | seconds | evaluations/s |\n|---|---|---|\n");

  std::unique_ptr<glint::DeviceEngine> engine;
  glint::DeviceEngineOptions options;
  options.workers = 1;
  glint::Status s = glint::DeviceEngine::Create(options, &engine);
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  s = engine->Evaluate(0, plan, request.queries(), out.data());  // compile + warm
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  double device = MedianSeconds(
      repeat, [&] { (void)engine->Evaluate(0, plan, request.queries(), out.data()); });
  std::printf("| device (%s) | %.4f | %.1f M |\n", engine->info().name.c_str(), device,
              n / device / 1e6);
  double host = MedianSeconds(std::max(1, repeat / 2),
                              [&] { glint::HostEvaluate(plan, request.queries(), out.data()); });
  std::printf("| host scalar, 1 thread | %.4f | %.1f M |\n", host, n / host / 1e6);
  engine.reset();

  // glintd on a free loopback port.
  glint::test::TempDir dir("glint_bench");
  std::string error;
  auto server = glint::test::Glintd::Start(GLINTD_PATH, dir, "glintd", {"--workers", "1"}, &error);
  if (!server) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  // Through the client library, as a user would: unary when the batch fits
  // a message, EvaluateStream chunks otherwise.
  glint::client::GlintClient client(server->address());
  bool ok = true;
  glint::client::EvaluateInfo info;
  auto call = [&] {
    std::vector<float> radiance;
    grpc::Status st = client.Evaluate(request, &radiance, {}, &info);
    if (!st.ok()) {
      std::fprintf(stderr, "glintd: %s\n", st.error_message().c_str());
      ok = false;
    }
  };
  call();  // first call pays for connection set-up and any kernel compile
  double e2e = MedianSeconds(repeat, call);
  const std::string transport =
      info.streamed ? "stream, " + std::to_string(info.chunks) + " chunks" : "unary";
  if (ok)
    std::printf("| glintd end to end (loopback, %s) | %.4f | %.1f M |\n", transport.c_str(), e2e,
                n / e2e / 1e6);
  server.reset();
  std::printf("\ndevice / host = %.1fx; end-to-end / device = %.2f\n", host / device, device / e2e);
  return ok ? 0 : 1;
}
