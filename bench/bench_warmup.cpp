// First-request latency (issue 13): how long glintd's warm-up (server/warmup.h) takes per kernel
// variant, on a fresh kernel cache (compile) or a warm one (disk load). One measurement per
// process, because PoCL's own cache directory is fixed once per process (server/cl_runtime.cpp):
//   bench_warmup --cache-dir DIR [--warm common|all] [--threads T] [--json PATH]
// warms the variants of --warm on an engine with max(T, 1) device queues, T threads in parallel
// (WarmKernels), and prints each variant's first run (its build or disk load, the kernel objects
// and PoCL's first-enqueue work-group compile included) and the total.
// bench/warmup_table.py runs it on a fresh and then a warm cache and prints the README table.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "server/device_engine.h"
#include "server/warmup.h"

int main(int argc, char **argv) {
  std::string cache_dir, json;
  glint::WarmMode mode = glint::WarmMode::kCommon;
  int threads = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--cache-dir") {
      cache_dir = v;
    } else if (a == "--warm" && glint::ParseWarmMode(v, &mode) && mode != glint::WarmMode::kNone) {
    } else if (a == "--threads") {
      threads = std::max(1, std::atoi(v.c_str()));
    } else if (a == "--json") {
      json = v;
    } else {
      std::fprintf(stderr,
                   "usage: bench_warmup --cache-dir DIR [--warm common|all] [--threads T] "
                   "[--json PATH]\n");
      return 2;
    }
  }
  if (cache_dir.empty()) {
    std::fprintf(stderr, "bench_warmup: --cache-dir is required\n");
    return 2;
  }
  glint::DeviceEngineOptions o;
  o.cache_dir = cache_dir;
  o.workers = threads;
  std::unique_ptr<glint::DeviceEngine> engine;
  if (glint::Status s = glint::DeviceEngine::Create(o, &engine); !s.ok()) {
    std::fprintf(stderr, "bench_warmup: %s\n", s.message().c_str());
    return 1;
  }
  const auto specs = glint::WarmSpecsFor(mode, engine->info().fp64);
  std::vector<glint::WarmTiming> timings;
  const auto t0 = std::chrono::steady_clock::now();
  if (glint::Status s = glint::WarmKernels(engine.get(), specs, threads, &timings); !s.ok()) {
    std::fprintf(stderr, "bench_warmup: %s\n", s.message().c_str());
    return 1;
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const int compiled = engine->runtime().programs_compiled();
  const int loaded = engine->runtime().programs_loaded_from_disk();
  std::printf("| variant | first run s |\n|---|---|\n");
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const glint::WarmTiming &t : timings) {
    std::printf("| %s | %.2f |\n", t.spec.Describe().c_str(), t.seconds);
    rows.push_back({{"variant", t.spec.Describe()}, {"seconds", t.seconds}});
  }
  std::printf("\n%zu variants, --warm %s, %d threads: %.2f s (%d programs compiled, %d loaded)\n",
              specs.size(), glint::WarmModeName(mode), threads, total, compiled, loaded);
  if (!json.empty()) {
    nlohmann::ordered_json j = {
        {"warm", glint::WarmModeName(mode)}, {"threads", threads},        {"total_seconds", total},
        {"programs_compiled", compiled},     {"programs_loaded", loaded}, {"rows", rows}};
    std::ofstream(json) << j.dump(1) << "\n";
  }
  return 0;
}
