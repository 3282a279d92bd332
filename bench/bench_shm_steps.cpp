// Where the time of one shared-memory Evaluate goes (issue 12, "Same-host shared memory"): the
// steps of glintd's shared-memory path (server/shm_io.cpp RunShared) timed one by one in this
// process on one registered region, then the whole call through glintd's service on loopback
// (client/lib/shm_transport.h ShmSession), next to the in-process device rate on the same batch
// (the SMOOTH schlick fp32 BRDF probes of bench_models), interleaved run by run with the device.
//
//   build/bench/bench_shm_steps [--queries N] [--repeat R] [--cache-dir DIR] [--pieces P,P,...]
//
// Prints one line per step: median milliseconds of R runs and the rate in queries/s. --pieces
// adds a ShmSession::Evaluate row per piece size (ShmSession::set_piece_queries; a size >= N is
// one unpipelined call), default: the library's default piece and N.
#include <grpcpp/grpcpp.h>
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "bench/lib/loopback_service.h"
#include "client/lib/shm_transport.h"
#include "server/eval_plan.h"
#include "server/shm_io.h"
#include "server/shm_regions.h"
#include "server/validation.h"

namespace glint::bench {
namespace {

// CPU seconds of this process so far (user + system, every thread).
double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Step {
  std::string name;
  double ms;
  double cpu_ms;
};

int Main(int argc, char **argv) {
  uint32_t n = 1u << 20;
  int repeat = 9;
  std::string cache_dir = DefaultCacheDir();
  std::vector<uint32_t> pieces;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--queries") {
      n = uint32_t(std::atol(argv[i + 1]));
    } else if (a == "--repeat") {
      repeat = std::max(1, std::atoi(argv[i + 1]));
    } else if (a == "--cache-dir") {
      cache_dir = argv[i + 1];
    } else if (a == "--pieces") {
      std::vector<uint32_t> &list = pieces;
      for (const char *at = argv[i + 1]; *at;) {
        char *end = nullptr;
        list.push_back(uint32_t(std::strtoul(at, &end, 10)));
        if (list.back() == 0 || (*end && *end != ',')) {
          std::fprintf(stderr, "%s %s: expected positive counts separated by commas\n", a.c_str(),
                       argv[i + 1]);
          return 2;
        }
        at = *end == ',' ? end + 1 : end;
      }
    } else {
      std::fprintf(stderr,
                   "usage: bench_shm_steps [--queries N] [--repeat R] [--cache-dir DIR] "
                   "[--pieces P,P,...]\n");
      return 2;
    }
  }
  std::unique_ptr<DeviceEngine> engine;
  if (Status s = CreateEngine(cache_dir, &engine); !s.ok()) {
    std::fprintf(stderr, "bench_shm_steps: %s\n", s.message().c_str());
    return 1;
  }
  glint::v1::EvaluateRequest request;
  auto *m = request.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  request.set_precision(glint::v1::FP32);
  // Probes without uv and footprint: the layout of bench_models' probe rows.
  glint::v1::QueryBatch &q = *request.mutable_queries();
  q = Tile(SharedQueries(65536, true), n);
  q.clear_uv();
  q.clear_footprint();
  ValidationLimits limits;
  limits.fp64_available = engine->info().fp64;

  std::vector<Step> steps;
  auto time = [&](std::vector<Step> *into, const std::string &name, auto &&run) {
    run();  // warm (allocations, kernel compile, page faults)
    const double cpu0 = CpuSeconds();
    const double ms = 1e3 * MedianSeconds(repeat, run);
    into->push_back({name, ms, 1e3 * (CpuSeconds() - cpu0) / repeat});
    std::fprintf(stderr, "  %-52s %9.2f ms (cpu %.2f ms)\n", name.c_str(), ms, into->back().cpu_ms);
  };

  // The reference: the in-process device path as bench_models times it.
  std::vector<float> reference(size_t(n) * 3);
  if (pieces.empty()) pieces = {glint::client::ShmSession::kDefaultPieceQueries, n};
  std::vector<Step> device;
  const EvalPlan device_plan = MakeEvalPlan(request, q);
  time(&device, "device (in process, bench_models' device path)", [&] {
    if (Status s = engine->Evaluate(0, device_plan, q, reference.data()); !s.ok())
      std::fprintf(stderr, "device: %s\n", s.message().c_str());
  });

  // One region as ShmSession lays it out: the input blocks, then the output at 64 bytes.
  std::string error;
  const size_t in_bytes = glint::client::SharedMemoryInputBytes(q, n);
  const size_t out_offset = (in_bytes + 63) / 64 * 64;
  auto buffer = glint::client::ShmBuffer::Create(out_offset + size_t(n) * 12, &error);
  if (!buffer) {
    std::fprintf(stderr, "bench_shm_steps: %s\n", error.c_str());
    return 1;
  }
  ShmRegistry registry;
  glint::v1::RegisterSharedMemoryRequest reg;
  reg.set_name("steps");
  reg.set_key(buffer->key());
  reg.set_byte_size(buffer->size());
  if (Status s = registry.Register("", reg); !s.ok()) {
    std::fprintf(stderr, "bench_shm_steps: %s\n", s.message().c_str());
    return 1;
  }
  glint::v1::EvaluateRequest shared = request;
  shared.clear_queries();
  glint::v1::SharedMemoryIo &io = *shared.mutable_shared_memory();
  time(&steps, "client: pack queries into the region",
       [&] { glint::client::PackSharedQueries(q, 0, n, buffer->data(), &io); });
  io.set_input_region("steps");
  io.set_output_region("steps");
  io.set_output_offset(out_offset);
  SharedMemoryCall call;
  time(&steps, "server: resolve regions (lookup, fstat)",
       [&] { (void)ResolveSharedMemoryCall(registry, "", io, &call); });
  glint::v1::QueryBatch loaded;
  time(&steps, "server: copy queries out of the region",
       [&] { (void)LoadSharedQueries(call, io, &loaded); });
  time(&steps, "server: validate", [&] {
    (void)ValidateQueries(loaded, false, limits, 0, false);
    (void)ValidateQueriesForModel(loaded, shared, 0);
  });
  EvalPlan plan;
  time(&steps, "server: plan", [&] { plan = MakeEvalPlan(shared, loaded); });
  std::vector<float> scratch(size_t(n) * 3);
  time(&steps, "server: device evaluate (buffers, kernel, finish)",
       [&] { (void)engine->Evaluate(0, plan, loaded, scratch.data()); });
  // The in-place path (EvaluatesInPlace): validation and kernels on views into the region, the
  // radiance written by the kernels into the output region.
  const QueryView view = SharedQueryView(call, io);
  time(&steps, "server, in place: validate the views",
       [&] { (void)ValidateQueryView(view, false, limits, 0, false); });
  float *region_out = reinterpret_cast<float *>(buffer->data() + out_offset);
  time(&steps, "server, in place: device evaluate into the region",
       [&] { (void)engine->Evaluate(0, plan, view, region_out); });
  time(&steps, "server: store radiance into the region",
       [&] { (void)StoreSharedRadiance(call, scratch.data()); });
  std::vector<float> radiance(size_t(n) * 3);
  time(&steps, "client: copy radiance out of the region", [&] {
    std::memcpy(radiance.data(), buffer->data() + out_offset, radiance.size() * sizeof(float));
  });

  LoopbackService service(engine.get());
  if (!service.ok()) {
    std::fprintf(stderr, "bench_shm_steps: could not start the loopback service\n");
    return 1;
  }
  // The whole calls, interleaved with the device path run by run (the machine's load changes
  // all three alike):
  //  - ShmSession::Evaluate: the client library's call from a QueryBatch (packs the queries into
  //    its region, copies the radiance out);
  //  - in place: the queries already in a registered region (written there by the application,
  //    as Triton's perf_analyzer prepares its shared-memory inputs once), one Evaluate naming
  //    it, the radiance read where the server wrote it.
  auto stub = glint::v1::GlintService::NewStub(
      grpc::CreateChannel(service.address(), grpc::InsecureChannelCredentials()));
  {
    grpc::ClientContext c;
    glint::v1::RegisterSharedMemoryResponse out;
    if (grpc::Status st = stub->RegisterSharedMemory(&c, reg, &out); !st.ok()) {
      std::fprintf(stderr, "bench_shm_steps: register: %s\n", st.error_message().c_str());
      return 1;
    }
  }
  std::vector<float> e2e;
  auto session_call = [&] {
    grpc::Status st = service.EvaluateShared(request, &e2e);
    if (!st.ok()) std::fprintf(stderr, "shared memory: %s\n", st.error_message().c_str());
  };
  // The server's own time of each in-place call (EvaluateResponse.stats.compute_ms: from the
  // start of the kernels' slices to their end, the overlapped value check included): the rest
  // of the call's wall time is the round trip, admission and the checks made before the kernels.
  std::vector<double> t_in_place_compute;
  auto in_place_call = [&] {
    grpc::ClientContext c;
    glint::v1::EvaluateResponse response;
    grpc::Status st = stub->Evaluate(&c, shared, &response);
    if (!st.ok()) std::fprintf(stderr, "in place: %s\n", st.error_message().c_str());
    t_in_place_compute.push_back(response.stats().compute_ms());
  };
  session_call();
  in_place_call();
  t_in_place_compute.clear();  // the warm call
  // ShmSession::Evaluate with each piece size (its own session: its own region).
  glint::client::GlintClient piece_client(service.address());
  std::vector<std::unique_ptr<glint::client::ShmSession>> piece_sessions;
  std::vector<std::vector<float>> piece_out(pieces.size());
  std::vector<std::vector<double>> t_pieces(pieces.size());
  std::vector<double> cpu_pieces(pieces.size(), 0.0);
  std::vector<std::tuple<std::function<void()>, std::vector<double> *, double *>> runs;
  for (size_t k = 0; k < pieces.size(); ++k) {
    piece_sessions.push_back(std::make_unique<glint::client::ShmSession>(&piece_client));
    piece_sessions.back()->set_piece_queries(pieces[k]);
    auto piece_call = [&, k] {
      grpc::Status st = piece_sessions[k]->Evaluate(request, &piece_out[k]);
      if (!st.ok()) std::fprintf(stderr, "pieces %u: %s\n", pieces[k], st.error_message().c_str());
    };
    piece_call();  // warm: the region created, registered and first touched
    runs.emplace_back(piece_call, &t_pieces[k], &cpu_pieces[k]);
  }
  std::vector<double> t_device, t_session, t_in_place;
  double cpu_device = 0, cpu_session = 0, cpu_in_place = 0;
  runs.emplace_back([&] { (void)engine->Evaluate(0, device_plan, q, reference.data()); }, &t_device,
                    &cpu_device);
  runs.emplace_back(session_call, &t_session, &cpu_session);
  runs.emplace_back(in_place_call, &t_in_place, &cpu_in_place);
  for (int r = 0; r < repeat; ++r) {
    for (auto &[run, t, cpu] : runs) {
      const double c0 = CpuSeconds();
      t->push_back(MedianSeconds(1, run) * 1e3);
      *cpu += (CpuSeconds() - c0) * 1e3 / repeat;
    }
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const double whole = median(t_session), in_place = median(t_in_place), dev = median(t_device);
  steps.push_back({"whole call: ShmSession::Evaluate (pack + copy out)", whole, cpu_session});
  steps.push_back({"whole call: in place (queries already in the region)", in_place, cpu_in_place});
  steps.push_back(
      {"  of which server compute_ms (kernels + overlapped check)", median(t_in_place_compute), 0});
  std::vector<double> piece_ratio;
  auto variant_name = [&](size_t k) { return "pieces of " + std::to_string(pieces[k]); };
  for (size_t k = 0; k < pieces.size(); ++k) {
    const double ms = median(t_pieces[k]);
    piece_ratio.push_back(dev / ms);
    steps.push_back({"whole call: ShmSession::Evaluate, " + variant_name(k), ms, cpu_pieces[k]});
  }
  device[0] = {"device (interleaved with the whole calls)", dev, cpu_device};
  bool pieces_same = true;
  for (const std::vector<float> &out : piece_out)
    pieces_same = pieces_same && out.size() == reference.size() &&
                  std::memcmp(out.data(), reference.data(), out.size() * sizeof(float)) == 0;
  const bool same = pieces_same && e2e.size() == reference.size() &&
                    std::memcmp(e2e.data(), reference.data(), e2e.size() * sizeof(float)) == 0 &&
                    std::memcmp(region_out, reference.data(), e2e.size() * sizeof(float)) == 0;

  std::printf(
      "bench_shm_steps: %u SMOOTH fp32 probes (%.1f MB in, %.1f MB out), device %s\n\n"
      "| step | ms (median) | queries/s | CPU ms (mean, all threads) |\n|---|---|---|---|\n",
      n, double(in_bytes) / 1e6, double(n) * 12 / 1e6, engine->info().name.c_str());
  for (const std::vector<Step> *list : {&device, &steps})
    for (const Step &s : *list)
      std::printf("| %s | %.2f | %.3g | %.2f |\n", s.name.c_str(), s.ms, double(n) / (s.ms / 1e3),
                  s.cpu_ms);
  std::printf(
      "\nrate / device rate (medians of %d interleaved runs): ShmSession::Evaluate %.2f, in place "
      "%.2f\n",
      repeat, dev / whole, dev / in_place);
  for (size_t k = 0; k < pieces.size(); ++k)
    std::printf("rate / device rate: ShmSession::Evaluate, %s: %.2f\n", variant_name(k).c_str(),
                piece_ratio[k]);
  std::printf("shared-memory radiance %s the in-process device result\n",
              same ? "bit-identical to" : "DIFFERS from");
  return same ? 0 : 1;
}

}  // namespace
}  // namespace glint::bench

int main(int argc, char **argv) {
  return glint::bench::Main(argc, argv);
}
