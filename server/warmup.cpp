#include "server/warmup.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>

#include "kernels/layout.h"
#include "server/model_table.h"

namespace glint {

bool ParseWarmMode(const std::string &name, WarmMode *mode) {
  if (name == "none")
    *mode = WarmMode::kNone;
  else if (name == "common")
    *mode = WarmMode::kCommon;
  else if (name == "all")
    *mode = WarmMode::kAll;
  else
    return false;
  return true;
}

const char *WarmModeName(WarmMode mode) {
  switch (mode) {
    case WarmMode::kNone:
      return "none";
    case WarmMode::kCommon:
      return "common";
    case WarmMode::kAll:
      return "all";
  }
  return "?";
}

std::vector<KernelSpec> WarmSpecsFor(WarmMode mode, bool fp64_available) {
  std::vector<KernelSpec> specs;
  auto add = [&specs](const KernelSpec &s) {
    if (std::find(specs.begin(), specs.end(), s) == specs.end()) specs.push_back(s);
  };
  if (mode == WarmMode::kNone) return specs;
  for (const Model *model : Models()) {
    if (!model->warm_specs) continue;
    for (const KernelSpec &declared : model->warm_specs()) {
      KernelSpec base = declared;
      base.model = model->id;
      add(base);
      if (mode != WarmMode::kAll) continue;
      for (int fresnel : {GLINT_FRESNEL_SCHLICK, GLINT_FRESNEL_CONDUCTOR, GLINT_FRESNEL_DIELECTRIC})
        for (bool fp64 : {false, true}) {
          if (fp64 && !fp64_available) continue;
          KernelSpec s = base;
          s.fresnel = fresnel;
          s.fp64 = fp64;
          add(s);
        }
    }
  }
  return specs;
}

namespace {
// "warm-up of SPEC (for USERS): MESSAGE".
Status WarmFailure(const std::vector<KernelSpec> &specs, const std::vector<std::string> *users,
                   size_t i, const Status &s) {
  std::string who;
  if (users && i < users->size() && !(*users)[i].empty()) who = " (for " + (*users)[i] + ")";
  return Status::Internal("warm-up of " + specs[i].Describe() + who + ": " + s.message());
}
}  // namespace

Status WarmKernels(DeviceEngine *engine, const std::vector<KernelSpec> &specs, int threads,
                   std::vector<WarmTiming> *timings, const std::vector<std::string> *users) {
  const int n_threads = std::max(1, std::min({threads, engine->workers(), int(specs.size())}));
  std::vector<WarmTiming> timed(specs.size());
  std::vector<int> ran_on(specs.size(), -1);
  std::atomic<size_t> next{0};
  std::mutex error_mutex;
  Status first_error = Status::Ok();
  auto work = [&](int worker) {
    for (size_t i; (i = next.fetch_add(1)) < specs.size();) {
      const auto t0 = std::chrono::steady_clock::now();
      Status s = engine->Warm(specs[i], worker);
      timed[i] = {specs[i],
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()};
      ran_on[i] = worker;
      if (!s.ok()) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (first_error.ok()) first_error = WarmFailure(specs, users, i, s);
        next = specs.size();  // stop the others early
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < n_threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (std::thread &t : pool) t.join();
  if (!first_error.ok()) return first_error;
  // The other queues: the programs are in memory now, this only creates their kernels and runs
  // them once (PoCL builds its work-group function per kernel and local size at first enqueue;
  // the one-query run's function serves every batch: launches stay below PoCL's small-grid
  // limit, server/launch_grid.h).
  for (size_t i = 0; i < specs.size(); ++i)
    for (int w = 0; w < engine->workers(); ++w) {
      if (w == ran_on[i]) continue;
      Status s = engine->Warm(specs[i], w);
      if (!s.ok()) return WarmFailure(specs, users, i, s);
    }
  if (timings) *timings = std::move(timed);
  return Status::Ok();
}

}  // namespace glint
