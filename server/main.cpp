// glintd: parses flags, builds the engine and the gRPC server, warms the
// default kernels, reports SERVING, and shuts down cleanly on SIGINT/SIGTERM.
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>

#include "server/health_service.h"
#include "server/kserve_service.h"
#include "server/malloc_policy.h"
#include "server/model_table.h"
#include "server/normal_map_store.h"
#include "server/ops.h"
#include "server/service.h"
#include "server/warmup.h"
#include "server/without_reflection.h"

namespace {

struct Flags {
  std::string listen = "127.0.0.1:50051";
  std::string device;  // "" = PoCL CPU if present; "host" = scalar C++ path
  std::string cache_dir;
  std::string port_file;
  uint32_t max_batch = 1u << 20;
  int workers = 2;
  size_t max_local_size = 0;  // --max-work-group (DeviceEngineOptions::max_local_size)
  int max_pending = 16;
  int max_undelivered_mb = 0;  // 0: max-pending x max-message-mb
  int max_message_mb = 64;
  bool quiet = false;
  bool list_devices = false;
  std::vector<std::string> models;       // --model NAME=MATERIAL.json[,LIGHTS.json]
  std::vector<std::string> model_dirs;   // --model-dir DIR
  glint::OpsFlags ops;                   // metrics, TLS, tokens (server/ops.h)
  std::vector<std::string> normal_maps;  // --normal-map FILE
  int normal_map_budget_mb = 1024;
  int normal_map_max_upload_mb = 256;
  double max_request_cost = glint::CostLimits().max_request_cost;
  double max_query_cost = glint::CostLimits().max_query_cost;
  double slice_ms = 50;
  double shutdown_grace = 10;
  glint::ShmLimits shm;        // --max-shm-regions, --max-shm-mb, --shm-direct-output
  long batch_delay_us = 0;     // dynamic batching (server/scheduler.h, server/batch_eval.h)
  long batch_max_queries = 0;  // 0: off
  glint::WarmMode warm = glint::WarmMode::kCommon;  // --warm (server/warmup.h)
};

const char kUsage[] =
    "usage: glintd [options]\n"
    "  --listen ADDR        address to serve on (default 127.0.0.1:50051; port 0 picks a free "
    "one)\n"
    "  --device SEL         OpenCL device: index from --list-devices, or a substring of its\n"
    "                       device/platform name; 'host' runs the scalar C++ path without OpenCL\n"
    "                       (default: PoCL's CPU device, else the first device)\n"
    "  --cache-dir DIR      compiled-kernel cache (default $GLINT_CACHE_DIR, else\n"
    "                       $XDG_CACHE_HOME/glint, else ~/.cache/glint; '' disables)\n"
    "  --max-batch N        queries per unary call or stream chunk (default 1048576)\n"
    "  --workers N          evaluation threads / device queues (default 2)\n"
    "  --max-work-group N   at most N work-items per work-group in every kernel launch, besides\n"
    "                       the device's and each kernel's own limits (default: no further limit)\n"
    "  --max-pending N      queued+running requests before RESOURCE_EXHAUSTED (default 16)\n"
    "  --max-undelivered-mb U  answered unary replies not yet read by their clients before\n"
    "                       new Evaluate calls get RESOURCE_EXHAUSTED (default max-pending x\n"
    "                       max-message-mb)\n"
    "  --max-message-mb N   gRPC message size limit, both directions (default 64); a reply\n"
    "                       may exceed it by its fixed fields (stats, chunk index; < 4 KiB)\n"
    "  --port-file PATH     write the bound port here once SERVING\n"
    "  --model NAME=MATERIAL.json[,LIGHTS.json]\n"
    "                       serve a material preset as model NAME over the Open Inference\n"
    "                       Protocol (inference.GRPCInferenceService); repeatable\n"
    "  --model-dir DIR      serve every DIR/NAME.json preset (material + optional \"lights\")\n"
    "  --normal-map FILE    hold the normal map FILE (OpenEXR / PNG) from the start, as if\n"
    "                       uploaded (prints its digest): a --model preset of the NORMAL_MAP\n"
    "                       model can name it; repeatable. Evictable as uploaded maps are\n"
    "  --normal-map-budget-mb N    memory for uploaded normal maps; least recently used maps\n"
    "                       are evicted beyond it (default 1024)\n"
    "  --normal-map-max-upload-mb N  largest normal-map file accepted (default 256)\n"
    "  --max-request-cost X refuse (RESOURCE_EXHAUSTED) a request or stream chunk whose cost\n"
    "                       exceeds X smooth-BRDF evaluations: queries x lights x method cost x\n"
    "                       model factor (default 1e11, ~1.4 h of the 2-core CPU device)\n"
    "  --max-query-cost X   refuse a request one query of which costs more than X (default 1e7,\n"
    "                       ~1 s of one core: the longest cancellation can wait for a slice)\n"
    "  --slice-ms MS        evaluate in query slices of about MS ms; cancellation, deadlines\n"
    "                       and shutdown act between slices (default 50)\n"
    "  --shutdown-grace S   on SIGTERM/SIGINT: health NOT_SERVING, new work UNAVAILABLE, work in\n"
    "                       flight may finish for S seconds, then is cancelled at its next\n"
    "                       slice; exit 0 (default 10)\n"
    "  --max-shm-regions N  shared-memory regions per client token (or per server without\n"
    "                       --auth-tokens); 0 disables shared memory (default 16)\n"
    "  --max-shm-mb N       registered shared-memory MiB per token / server (default 4096)\n"
    "  --shm-direct-output  obsolete, accepted: the kernels always write the output region\n"
    "                       (a client truncating it mid-call loses only its own call)\n"
    "  --batch-max-queries Q  dynamic batching: concurrent unary Evaluate calls of at most Q/2\n"
    "                       queries with identical settings (material, lights, precision, seed,\n"
    "                       area method and samples, same query arrays) share one device launch\n"
    "                       of up to Q queries; results bit-identical to unbatched (default 0: "
    "off)\n"
    "  --batch-delay-us N   with batching: wait up to N us after a request arrives for others to\n"
    "                       share its launch (default 0: only those already queued)\n"
    "  --warm MODE          kernels built and run before SERVING (health NOT_SERVING until\n"
    "                       then): none, common (each model's usual variants; default) or all\n"
    "                       (those with every Fresnel kind and precision); from the disk\n"
    "                       cache when present (cold compiles run one at a time on PoCL)\n"
    "  --list-devices       print the OpenCL devices and exit\n"
    "  --quiet              no per-request log lines\n"
    "memory: peak RSS <= idle RSS + M x (3 x (max-pending + calls being received) + 2 x\n"
    "  workers) + U, M the largest request (<= max-message-mb), U max-undelivered-mb (replies\n"
    "  waiting on clients that do not read them): an admitted request holds its\n"
    "  parsed body, its radiance and the serialised reply; a worker the device copies of its\n"
    "  queries and radiance; a call being received holds its body (gRPC reads a\n"
    "  whole unary body before any handler runs, so those are bounded by the clients, not by\n"
    "  these flags); a full server refuses before parsing (README 'Limits, cancellation and\n"
    "  shutdown'); with --batch-max-queries Q, M is at least Q x 96 bytes (a launch holds its\n"
    "  batch's concatenated queries, <= 84 bytes each, and radiance)\n";

std::string DefaultCacheDir() {
  if (const char *d = std::getenv("GLINT_CACHE_DIR")) return d;
  if (const char *x = std::getenv("XDG_CACHE_HOME")) return std::string(x) + "/glint";
  if (const char *h = std::getenv("HOME")) return std::string(h) + "/.cache/glint";
  return "";
}

bool ParseFlags(int argc, char **argv, Flags *f) {
  f->cache_dir = DefaultCacheDir();
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto value = [&](const char *name) -> const char * {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "glintd: %s needs a value\n", name);
        std::exit(2);
      }
      return argv[++i];
    };
    auto real = [&](const char *name, double lo, double hi) -> double {
      const char *v = value(name);
      char *end = nullptr;
      double x = std::strtod(v, &end);
      if (*v == '\0' || *end != '\0' || !(x >= lo && x <= hi)) {
        std::fprintf(stderr, "glintd: %s %s: expected a number in [%g, %g]\n", name, v, lo, hi);
        std::exit(2);
      }
      return x;
    };
    auto number = [&](const char *name, long lo, long hi) -> long {
      const char *v = value(name);
      char *end = nullptr;
      long n = std::strtol(v, &end, 10);
      if (*v == '\0' || *end != '\0' || n < lo || n > hi) {
        std::fprintf(stderr, "glintd: %s %s: expected an integer in [%ld, %ld]\n", name, v, lo, hi);
        std::exit(2);
      }
      return n;
    };
    if (a == "--listen")
      f->listen = value("--listen");
    else if (a == "--device")
      f->device = value("--device");
    else if (a == "--cache-dir")
      f->cache_dir = value("--cache-dir");
    else if (a == "--port-file")
      f->port_file = value("--port-file");
    else if (a == "--max-batch")
      f->max_batch = uint32_t(number("--max-batch", 1, 1 << 24));
    else if (a == "--workers")
      f->workers = int(number("--workers", 1, 64));
    else if (a == "--max-work-group")
      f->max_local_size = size_t(number("--max-work-group", 1, 65534));
    else if (a == "--max-pending")
      f->max_pending = int(number("--max-pending", 1, 1 << 16));
    else if (a == "--max-undelivered-mb")
      f->max_undelivered_mb = int(number("--max-undelivered-mb", 1, 1 << 20));
    else if (a == "--max-message-mb")
      f->max_message_mb = int(number("--max-message-mb", 1, 1024));
    else if (a == "--model")
      f->models.push_back(value("--model"));
    else if (a == "--model-dir")
      f->model_dirs.push_back(value("--model-dir"));
    else if (a == "--normal-map")
      f->normal_maps.push_back(value("--normal-map"));
    else if (a == "--normal-map-budget-mb")
      f->normal_map_budget_mb = int(number("--normal-map-budget-mb", 1, 1 << 20));
    else if (a == "--normal-map-max-upload-mb")
      f->normal_map_max_upload_mb = int(number("--normal-map-max-upload-mb", 1, 1 << 16));
    else if (a == "--max-request-cost")
      f->max_request_cost = real("--max-request-cost", 1, 1e30);
    else if (a == "--max-query-cost")
      f->max_query_cost = real("--max-query-cost", 1, 1e30);
    else if (a == "--slice-ms")
      f->slice_ms = real("--slice-ms", 1, 60000);
    else if (a == "--shutdown-grace")
      f->shutdown_grace = real("--shutdown-grace", 0, 3600);
    else if (a == "--max-shm-regions")
      f->shm.max_regions = uint32_t(number("--max-shm-regions", 0, 1 << 16));
    else if (a == "--max-shm-mb")
      f->shm.max_bytes = uint64_t(number("--max-shm-mb", 1, 1 << 24)) << 20;
    else if (a == "--shm-direct-output")
      f->shm.direct_output = true;
    else if (a == "--batch-max-queries")
      f->batch_max_queries = number("--batch-max-queries", 0, 1 << 24);
    else if (a == "--batch-delay-us")
      f->batch_delay_us = number("--batch-delay-us", 0, 1000000);
    else if (a == "--warm") {
      const char *v = value("--warm");
      if (!glint::ParseWarmMode(v, &f->warm)) {
        std::fprintf(stderr, "glintd: --warm %s: expected none, common or all\n", v);
        std::exit(2);
      }
    } else if (a == "--list-devices")
      f->list_devices = true;
    else if (a == "--quiet")
      f->quiet = true;
    else if (glint::ParseOpsFlag(argc, argv, &i, &f->ops)) {
    } else if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::fputs(glint::kOpsUsage, stdout);
      std::exit(0);
    } else {
      std::fprintf(stderr, "glintd: unknown option %s\n%s%s", a.c_str(), kUsage, glint::kOpsUsage);
      return false;
    }
  }
  return true;
}

}  // namespace

int main(int argc, char **argv) {
  // Request bodies, parsed arrays and replies are megabytes each: kept in two shared heaps for
  // reuse instead of mapped afresh per message (server/malloc_policy.h says why and the bound).
  if (!glint::ConfigureMallocForMessages())
    std::fprintf(stderr, "glintd: warning: glibc refused a malloc setting (mallopt)\n");
  Flags flags;
  if (!ParseFlags(argc, argv, &flags)) return 2;
  if (flags.list_devices) {
    auto devices = glint::ListDevices();
    for (size_t i = 0; i < devices.size(); ++i) {
      const auto &d = devices[i];
      std::printf("%zu: %s | %s | %s | %u compute units | fp64 %s\n", i, d.name.c_str(),
                  d.platform_name.c_str(), d.opencl_version.c_str(), d.compute_units,
                  d.fp64 ? "yes" : "no");
    }
    if (devices.empty()) std::printf("no OpenCL devices (use --device host)\n");
    return 0;
  }

  // SIGHUP re-reads --auth-tokens (server/auth.h installs that handler); without tokens there
  // is nothing to reload, and its default action (terminate, no drain) would end the server on
  // an ops habit like `systemctl reload` or a log rotation.
  signal(SIGHUP, SIG_IGN);
  // Block the stop signals in every thread; main waits for them with sigwait.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  std::unique_ptr<glint::DeviceEngine> engine;
  glint::ServiceOptions options;
  options.limits.max_batch = flags.max_batch;
  options.max_message_bytes = uint64_t(flags.max_message_mb) << 20;
  options.limits.max_message_bytes = options.max_message_bytes;
  options.log_requests = !flags.quiet;
  {
    glint::NormalMapLimits nm = glint::NormalMaps().limits();
    nm.budget_bytes = uint64_t(flags.normal_map_budget_mb) << 20;
    nm.max_upload_bytes = uint64_t(flags.normal_map_max_upload_mb) << 20;
    glint::NormalMaps().Configure(nm);
  }
  // Maps held from the start: a NORMAL_MAP preset (--model) is validated like a request, which
  // needs its map held (NOT_FOUND otherwise), and the store starts empty, so without them no
  // NORMAL_MAP preset could be served.
  for (const std::string &file : flags.normal_maps) {
    std::ifstream in(file, std::ios::binary);
    const bool opened = in.is_open();
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    glint::v1::NormalMapInfo info;
    const glint::Status s =
        opened ? glint::NormalMaps().Upload(file.substr(file.find_last_of('/') + 1), bytes, &info)
               : glint::Status::InvalidArgument("cannot open the file");
    if (!s.ok()) {
      std::fprintf(stderr, "glintd: --normal-map %s: %s\n", file.c_str(), s.message().c_str());
      return 2;
    }
    std::fprintf(stderr, "glintd: normal map %s: %s (%ux%u)\n", file.c_str(), info.digest().c_str(),
                 info.width(), info.height());
  }
  options.cost.max_request_cost = flags.max_request_cost;
  options.cost.max_query_cost = flags.max_query_cost;
  options.slice_ms = flags.slice_ms;
  options.max_undelivered_bytes =
      uint64_t(flags.max_undelivered_mb > 0 ? flags.max_undelivered_mb
                                            : flags.max_pending * flags.max_message_mb)
      << 20;
  if (flags.device != "host") {
    glint::DeviceEngineOptions eo;
    eo.device = flags.device;
    eo.cache_dir = flags.cache_dir;
    eo.workers = flags.workers;
    eo.max_local_size = flags.max_local_size;
    glint::Status s = glint::DeviceEngine::Create(eo, &engine);
    if (!s.ok()) {
      std::fprintf(stderr, "glintd: %s\n", s.message().c_str());
      return 1;
    }
    options.limits.fp64_available = engine->info().fp64;
  }
  glint::Scheduler scheduler(flags.workers, size_t(flags.max_pending));
  // The port opens before the warm-up: a request that arrives meanwhile is queued (or refused
  // when the queue is full), not run beside a warm-up thread on the same device queue.
  if (engine) scheduler.Hold();
  glint::Ops ops(flags.ops);
  if (std::string error; !ops.Init(&error)) {
    std::fprintf(stderr, "glintd: %s\n", error.c_str());
    return 2;
  }
  options.metrics = ops.metrics();
  options.auth = ops.auth();
  glint::ShmRegistry shm_regions(flags.shm);  // unmapped when main returns (after Shutdown)
  options.shm = &shm_regions;
  glint::GlintServiceImpl service(engine.get(), &scheduler, options);
  if (flags.batch_max_queries > 0) {
    scheduler.EnableBatching(
        {std::chrono::microseconds(flags.batch_delay_us), uint32_t(flags.batch_max_queries)},
        [&service](int worker, const glint::Scheduler::Members &members) {
          return service.RunEvaluateBatch(worker, members);
        });
  }
  std::vector<glint::KServeModel> kserve_models;
  if (glint::Status s =
          glint::LoadKServeModels(flags.models, flags.model_dirs, options.limits, &kserve_models);
      !s.ok()) {
    std::fprintf(stderr, "glintd: %s\n", s.message().c_str());
    return 2;
  }
  glint::KServeServiceImpl kserve(&service, std::move(kserve_models));

  // Our own health service (server/health_service.h): NOT_SERVING from the first check on.
  glint::HealthService health({glint::v1::GlintService::service_full_name()});
  // Reflection is gRPC's own service, which the token check cannot guard: off with tokens.
  if (!ops.auth()) grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  if (ops.auth()) builder.SetOption(std::make_unique<glint::WithoutReflection>());
  int port = 0;
  builder.AddListeningPort(flags.listen, ops.ServerCredentials(), &port);
  ops.WarnIfExposed(flags.listen);
  builder.SetMaxReceiveMessageSize(flags.max_message_mb << 20);
  // Replies may carry a little more than their requests: the stats (two doubles and the device
  // name), a stream result's chunk_index and first_query. A request or stream chunk just within
  // the limit got RESOURCE_EXHAUSTED "Sent message larger than max (1048594 vs. 1048576)" after
  // its work was done (outside-client probe, session 11). The send limit allows that overhead;
  // replies that grow with something else are refused before the work (Sample: server/sample.h).
  constexpr int kReplyOverheadBytes = 4096;
  builder.SetMaxSendMessageSize((flags.max_message_mb << 20) + kReplyOverheadBytes);
  builder.RegisterService(&service);
  builder.RegisterService(&kserve);
  builder.RegisterService(&health);
  ops.Configure(&builder, &scheduler, engine.get());
  if (glint::Metrics *metrics = ops.metrics())
    metrics->SetAbandonedSource([&service] { return service.abandoned().counts(); });
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server || port == 0) {
    std::fprintf(stderr, "glintd: could not listen on %s\n", flags.listen.c_str());
    return 1;
  }
  if (std::string error; !ops.Start(&error)) {
    std::fprintf(stderr, "glintd: %s\n", error.c_str());
    scheduler.Release();
    server->Shutdown();
    return 1;
  }

  if (engine) {
    const auto t0 = std::chrono::steady_clock::now();
    // The kernels requests use (--warm, server/warmup.h), built and run before SERVING: the
    // variants the models declare, then those of the --model presets not among them. Others are
    // compiled on first use (and then come from the disk cache). --warm none builds nothing at
    // all, presets included (it used to compile every preset and log "0 kernels warm").
    std::vector<glint::KernelSpec> warm_specs =
        glint::WarmSpecsFor(flags.warm, engine->info().fp64);
    const size_t declared = warm_specs.size();
    if (flags.warm != glint::WarmMode::kNone)
      for (const glint::KernelSpec &spec : kserve.WarmSpecs())
        if (std::find(warm_specs.begin(), warm_specs.end(), spec) == warm_specs.end())
          warm_specs.push_back(spec);
    // Each variant's --model presets, so that a failure names the preset and its file.
    std::vector<std::string> users;
    for (const glint::KernelSpec &spec : warm_specs) users.push_back(kserve.PresetsUsing(spec));
    if (glint::Status s =
            glint::WarmKernels(engine.get(), warm_specs, engine->workers(), nullptr, &users);
        !s.ok()) {
      std::fprintf(stderr, "glintd: %s\n", s.message().c_str());
      scheduler.Release();  // the held requests run (and fail or finish) so Shutdown can end
      server->Shutdown();
      return 1;
    }
    // "(C compiled, D from cache DIR)": the runtime's program counters (tests read them).
    std::ostringstream counted;
    counted << '(' << engine->runtime().programs_compiled() << " compiled, "
            << engine->runtime().programs_loaded_from_disk() << " from cache "
            << (flags.cache_dir.empty() ? std::string("(disabled)") : flags.cache_dir) << ')';
    const std::string programs = counted.str();
    if (flags.warm == glint::WarmMode::kNone) {
      std::fprintf(stderr,
                   "glintd: device %s (%s), --warm none: no kernels built before SERVING %s; "
                   "each variant is built by its first request\n",
                   engine->info().name.c_str(), engine->info().platform_name.c_str(),
                   programs.c_str());
    } else {
      std::fprintf(
          stderr,
          "glintd: device %s (%s), %zu kernel variants warm (--warm %s: %zu declared by the "
          "models, %zu more for --model presets) in %.0f ms %s\n",
          engine->info().name.c_str(), engine->info().platform_name.c_str(), warm_specs.size(),
          glint::WarmModeName(flags.warm), declared, warm_specs.size() - declared,
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(),
          programs.c_str());
    }
  } else {
    std::fprintf(stderr, "glintd: device host (scalar C++ path, no OpenCL)\n");
  }

  scheduler.Release();
  health.SetServing(true);
  kserve.SetReady(true);
  std::string host = flags.listen.substr(0, flags.listen.rfind(':'));
  // A unix socket has no port (gRPC reports 1): the path is the address.
  if (flags.listen.rfind("unix", 0) == 0)
    std::fprintf(stderr, "glintd: SERVING on %s\n", flags.listen.c_str());
  else
    std::fprintf(stderr, "glintd: SERVING on %s:%d\n", host.c_str(), port);
  if (!flags.port_file.empty()) {
    std::string tmp = flags.port_file + ".tmp";
    { std::ofstream(tmp) << port << "\n"; }
    std::rename(tmp.c_str(), flags.port_file.c_str());
  }

  int sig = 0;
  sigwait(&stop_signals, &sig);
  // Graceful shutdown: load balancers see NOT_SERVING, new work is refused with UNAVAILABLE,
  // work in flight may finish within --shutdown-grace and is then cancelled at its next slice
  // boundary (at most one slice, bounded by --max-query-cost); then the RPCs still open (idle
  // streams) get a second to end before gRPC cancels them.
  using SteadyClock = std::chrono::steady_clock;
  const auto t0 = SteadyClock::now();
  const auto since = [&] { return std::chrono::duration<double>(SteadyClock::now() - t0).count(); };
  std::fprintf(stderr,
               "glintd: signal %d, shutting down: NOT_SERVING, %zu requests in flight, grace "
               "%.3g s\n",
               sig, scheduler.pending(), flags.shutdown_grace);
  health.SetServing(false);
  kserve.SetReady(false);
  service.BeginShutdown();
  const auto grace_end = t0 + std::chrono::duration_cast<SteadyClock::duration>(
                                  std::chrono::duration<double>(flags.shutdown_grace));
  while (scheduler.pending() > 0 && SteadyClock::now() < grace_end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  if (scheduler.pending() > 0) {
    std::fprintf(stderr, "glintd: grace over after %.2f s, cancelling %zu requests in flight\n",
                 since(), scheduler.pending());
    service.CancelInFlight();
    while (scheduler.pending() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(1));
  // /metrics (owned by ops, which outlives service) must not read service once it is gone: the
  // source is swapped under the lock Render holds while it calls it.
  if (glint::Metrics *metrics = ops.metrics()) metrics->SetAbandonedSource(nullptr);
  shm_regions.Clear();
  // The abandoned-work count (server/abandoned_work.h) in the last line, also without /metrics:
  // how much work this replica's shutdown (and its clients) gave up.
  const glint::AbandonedCounts abandoned = service.abandoned().counts();
  std::fprintf(stderr,
               "glintd: stopped after %.2f s; queries abandoned: %llu cancelled, %llu deadline, "
               "%llu shutdown\n",
               since(), static_cast<unsigned long long>(abandoned.cancelled),
               static_cast<unsigned long long>(abandoned.deadline),
               static_cast<unsigned long long>(abandoned.shutdown));
  return 0;
}
