// Kernel warm-up before glintd reports SERVING (issue 13, first-request latency): the kernel
// variants the models declare (Model::warm_specs) are built (from the disk cache when present)
// and run once on every device queue while the health service says NOT_SERVING. A request of a
// warmed variant then compiles nothing. The threads (one per queue) overlap the disk loads,
// kernel creation and first runs, but not cold compiles: PoCL 3.1 compiles one program, and one
// work-group function, at a time per process (clBuildProgram holds the context's LLVM lock, the
// first-enqueue compile a process-wide lock; bench/bench_models.cpp Driver::WarmUp compiles in
// several processes for that reason). `--warm` chooses how much:
//   none    nothing, not even the KServe --model presets: SERVING at once, each variant is
//           built by its first request (tests, tools), whose EvaluateStats.compile_ms says so
//   common  every model's warm_specs (the default), plus each --model preset's variant
//   all     those shapes with every Fresnel kind and, where the device has fp64, both precisions
// glintd logs how many variants it warmed, how many of them for presets, and the programs the
// runtime compiled and loaded from the disk cache.
#pragma once

#include <string>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/status.h"

namespace glint {

enum class WarmMode { kNone, kCommon, kAll };

// "none", "common" or "all"; false for anything else.
bool ParseWarmMode(const std::string &name, WarmMode *mode);
const char *WarmModeName(WarmMode mode);

// The variants a mode warms, without duplicates, in model-table order.
std::vector<KernelSpec> WarmSpecsFor(WarmMode mode, bool fp64_available);

struct WarmTiming {
  KernelSpec spec;
  double seconds = 0;  // its first run (build or disk load included), on one queue
};

// Warms `specs`: min(threads, engine->workers()) threads each take the next spec and run it on
// their own queue (their cold compiles take turns inside PoCL, see above), then every spec runs
// once on the other queues. Returns the first failure, naming the spec and, when `users` (if not
// null) has a non-empty entry for it, who needs it: glintd passes the --model presets of each
// spec (KServeServiceImpl::PresetsUsing), so that a preset whose kernel fails names its file.
// `timings` (if not null) gets each spec's first run (a cold one includes waiting for the other
// thread's compile).
Status WarmKernels(DeviceEngine *engine, const std::vector<KernelSpec> &specs, int threads,
                   std::vector<WarmTiming> *timings = nullptr,
                   const std::vector<std::string> *users = nullptr);

}  // namespace glint
