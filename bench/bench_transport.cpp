// Where the time of one end-to-end Evaluate goes (issue 12, "Throughput end to end"): the
// steps of the request path timed one by one in this process on the same batch (the SMOOTH
// schlick fp32 BRDF probes of bench_models), then the whole call through glintd's service on
// loopback TCP. What the whole call takes beyond the sum of the steps is gRPC's transport
// (HTTP/2 framing, the socket both ways, thread hand-offs) and the scheduler.
//
//   build/bench/bench_transport [--queries N] [--repeat R] [--chunk-bytes B] [--cache-dir DIR]
//                               [--end-to-end-only] [--server ADDR]
//
// --server ADDR times the end-to-end call against a running glintd (its CPU time is then not in
// the CPU column, which counts this process only).
//
// Prints one line per step: median milliseconds of R runs and the rate in queries/s.
#include <grpcpp/grpcpp.h>
#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/proto_buffer_writer.h>
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "bench/lib/loopback_service.h"
#include "client/lib/chunk_encoding.h"
#include "server/eval_plan.h"
#include "server/validation.h"

namespace glint::bench {
namespace {

// CPU seconds of this process so far (user + system, every thread): on a loaded machine the
// wall time of a step depends on the share of the cores it gets, its CPU time much less.
double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Step {
  std::string name;
  double ms;
  double cpu_ms;  // CPU time per run over every thread of the process
};

void Serialize(const google::protobuf::Message &m, grpc::ByteBuffer *out) {
  bool own = false;
  out->Clear();
  grpc::GenericSerialize<grpc::ProtoBufferWriter, google::protobuf::Message>(m, out, &own);
}

bool Parse(grpc::ByteBuffer *in, google::protobuf::Message *m) {
  grpc::ProtoBufferReader reader(in);
  return m->ParseFromZeroCopyStream(&reader);
}

int Main(int argc, char **argv) {
  uint32_t n = 1u << 20;
  int repeat = 5;
  size_t chunk_bytes = 0;
  bool e2e_only = false;
  std::string server;  // --server ADDR: the end-to-end call goes to a running glintd there
  std::string cache_dir = DefaultCacheDir();
  for (int i = 1; i < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--end-to-end-only") {
      e2e_only = true;
      --i;
    } else if (i + 1 == argc) {
      std::fprintf(stderr, "bench_transport: %s needs a value\n", a.c_str());
      return 2;
    } else if (a == "--queries") {
      n = uint32_t(std::atol(argv[i + 1]));
    } else if (a == "--repeat") {
      repeat = std::max(1, std::atoi(argv[i + 1]));
    } else if (a == "--chunk-bytes") {
      chunk_bytes = size_t(std::atoll(argv[i + 1]));
    } else if (a == "--server") {
      server = argv[i + 1];
      e2e_only = true;
    } else if (a == "--cache-dir") {
      cache_dir = argv[i + 1];
    } else {
      std::fprintf(stderr,
                   "usage: bench_transport [--queries N] [--repeat R] [--chunk-bytes B] "
                   "[--end-to-end-only] [--server ADDR] [--cache-dir DIR]\n");
      return 2;
    }
  }
  std::unique_ptr<DeviceEngine> engine;
  if (Status s = CreateEngine(cache_dir, &engine); !s.ok()) {
    std::fprintf(stderr, "bench_transport: %s\n", s.message().c_str());
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
  *request.mutable_queries() = Tile(SharedQueries(65536, true), n);
  ValidationLimits limits;
  limits.fp64_available = engine->info().fp64;

  std::vector<Step> steps;
  auto time = [&](const std::string &name, auto &&run) {
    run();  // warm (allocations, kernel compile)
    const double cpu0 = CpuSeconds();
    const double ms = 1e3 * MedianSeconds(repeat, run);
    steps.push_back({name, ms, 1e3 * (CpuSeconds() - cpu0) / repeat});
    std::fprintf(stderr, "  %-44s %9.2f ms (cpu %.2f ms)\n", name.c_str(), ms, steps.back().cpu_ms);
  };

  // The in-process device result, the reference the end-to-end result must equal bit for bit.
  std::vector<float> reference(size_t(n) * 3);
  {
    const EvalPlan plan = MakeEvalPlan(request, request.queries());
    if (Status s = engine->Evaluate(0, plan, request.queries(), reference.data()); !s.ok()) {
      std::fprintf(stderr, "bench_transport: %s\n", s.message().c_str());
      return 1;
    }
  }
  size_t request_bytes = request.ByteSizeLong();
  glint::v1::EvaluateResponse back;
  if (!e2e_only) {
    grpc::ByteBuffer wire;
    time("client: serialize request", [&] { Serialize(request, &wire); });
    request_bytes = wire.Length();
    glint::v1::EvaluateRequest parsed;
    time("server: parse request", [&] {
      Serialize(request, &wire);  // parsing consumes nothing, but keep the buffer fresh
      parsed.Clear();
      Parse(&wire, &parsed);
    });
    // The serialisation above is inside that step: subtract it.
    steps.back().ms -= steps[0].ms;
    steps.back().cpu_ms -= steps[0].cpu_ms;
    steps.back().name += " (minus serialize)";
    time("server: validate", [&] {
      (void)ValidateSettings(parsed, limits);
      (void)ValidateQueries(parsed.queries(), false, limits, 0, false);
      (void)ValidateQueriesForModel(parsed.queries(), parsed, 0);
    });
    EvalPlan plan;
    time("server: plan", [&] { plan = MakeEvalPlan(parsed, parsed.queries()); });
    glint::v1::EvaluateResponse response;
    time("server: response array (resize)", [&] {
      response.Clear();
      response.mutable_radiance()->Resize(int(n) * 3, 0.0f);
    });
    time("server: device evaluate", [&] {
      (void)engine->Evaluate(0, plan, parsed.queries(),
                             response.mutable_radiance()->mutable_data());
    });
    response.set_count(n);
    grpc::ByteBuffer reply;
    time("server: serialize response", [&] { Serialize(response, &reply); });
    grpc::ByteBuffer reply_copy;
    time("client: parse response (+serialize)", [&] {
      Serialize(response, &reply_copy);
      back.Clear();
      Parse(&reply_copy, &back);
    });
    steps.back().ms -= steps[steps.size() - 2].ms;
    steps.back().cpu_ms -= steps[steps.size() - 2].cpu_ms;
    std::vector<float> radiance;
    time("client: copy radiance out",
         [&] { radiance.assign(back.radiance().begin(), back.radiance().end()); });
  }
  // The client's two ways of making the stream's chunks (87295 queries, ~4 MiB each, as the
  // client library sizes them): a sliced message serialised by protobuf, or EncodeChunk.
  std::vector<Step> chunking;
  if (!e2e_only) {
    const uint32_t per = 87295;
    const std::string settings = [&] {
      glint::v1::EvaluateRequest r = request;
      r.clear_queries();
      return r.SerializeAsString();
    }();
    std::vector<grpc::ByteBuffer> out((n + per - 1) / per);
    auto chunk_time = [&](const std::string &name, auto &&make) {
      for (size_t k = 0; k < out.size(); ++k) out[k] = make(k);  // warm
      const double cpu0 = CpuSeconds();
      const double ms = 1e3 * MedianSeconds(repeat, [&] {
                          for (size_t k = 0; k < out.size(); ++k) out[k] = make(k);
                        });
      chunking.push_back({name, ms, 1e3 * (CpuSeconds() - cpu0) / repeat});
    };
    chunk_time("SliceQueries + protobuf serialisation", [&](size_t k) {
      glint::v1::EvaluateChunk c;
      c.set_chunk_index(k);
      const uint32_t b = uint32_t(k) * per, e = std::min(n, b + per);
      *c.mutable_request()->mutable_queries() =
          glint::client::SliceQueries(request.queries(), b, e);
      grpc::ByteBuffer bb;
      Serialize(c, &bb);
      return bb;
    });
    chunk_time("EncodeChunk (client/lib/chunk_encoding.h)", [&](size_t k) {
      const uint32_t b = uint32_t(k) * per, e = std::min(n, b + per);
      return glint::client::EncodeChunk(k, k ? std::string() : settings, request.queries(), b, e);
    });
    chunk_time("EncodeChunkReferencing (views, no copy)", [&](size_t k) {
      const uint32_t b = uint32_t(k) * per, e = std::min(n, b + per);
      return glint::client::EncodeChunkReferencing(k, k ? std::string() : settings,
                                                   request.queries(), b, e);
    });
  }
  double sum = 0, sum_cpu = 0;
  for (const Step &s : steps) sum += s.ms, sum_cpu += s.cpu_ms;

  glint::client::ClientOptions options;
  if (chunk_bytes) options.max_chunk_bytes = chunk_bytes;
  // --server: a glintd process (its own malloc settings and threads), this process the client.
  std::unique_ptr<glint::client::GlintClient> remote;
  if (!server.empty()) remote = std::make_unique<glint::client::GlintClient>(server, options);
  LoopbackService service(engine.get(), options);
  if (!service.ok()) {
    std::fprintf(stderr, "bench_transport: could not start the loopback service\n");
    return 1;
  }
  glint::client::EvaluateInfo info;
  std::vector<float> e2e;
  time("end to end (client library, loopback TCP)", [&] {
    grpc::Status s = remote ? remote->Evaluate(request, &e2e, {}, &info)
                            : service.Evaluate(request, &e2e, &info);
    if (!s.ok()) std::fprintf(stderr, "end to end: %s\n", s.error_message().c_str());
  });
  const double whole = steps.back().ms, whole_cpu = steps.back().cpu_ms;
  const bool same =
      e2e.size() == size_t(n) * 3 && std::equal(e2e.begin(), e2e.end(), reference.begin());

  std::printf(
      "bench_transport: %u SMOOTH fp32 probes, request %.1f MB, %s (%llu chunks of %u), "
      "device %s\n\n| step | ms (median) | queries/s | CPU ms (mean, all threads) |\n"
      "|---|---|---|---|\n",
      n, double(request_bytes) / 1e6, info.streamed ? "stream" : "unary",
      (unsigned long long)info.chunks, info.chunk_queries, engine->info().name.c_str());
  for (const Step &s : steps)
    std::printf("| %s | %.2f | %.3g | %.2f |\n", s.name.c_str(), s.ms, double(n) / (s.ms / 1e3),
                s.cpu_ms);
  std::printf("| sum of the steps before end to end | %.2f | %.3g | %.2f |\n", sum,
              double(n) / (sum / 1e3), sum_cpu);
  std::printf("| end to end minus the steps (transport, hand-offs) | %.2f | | %.2f |\n",
              whole - sum, whole_cpu - sum_cpu);
  if (!chunking.empty()) {
    std::printf(
        "\nclient: making the stream's chunks of the whole batch\n\n| way | ms (median) | CPU ms "
        "|\n|---|---|---|\n");
    for (const Step &s : chunking)
      std::printf("| %s | %.2f | %.2f |\n", s.name.c_str(), s.ms, s.cpu_ms);
  }
  std::printf("\nend-to-end radiance %s the in-process device result\n",
              same ? "bit-identical to" : "DIFFERS from");
  return same ? 0 : 1;
}

}  // namespace
}  // namespace glint::bench

int main(int argc, char **argv) {
  return glint::bench::Main(argc, argv);
}
