// Shared benchmark helpers (bench_models and bench_area): timing, query tiling, the shared
// light sets, request validation as the server does it, the device engine and error statistics.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "bench/lib/bench_case.h"
#include "glint/v1/glint.pb.h"
#include "server/device_engine.h"
#include "server/status.h"

namespace glint::bench {

using Clock = std::chrono::steady_clock;

// Median wall time in seconds of `repeat` calls of run().
template <typename F>
double MedianSeconds(int repeat, F &&run) {
  std::vector<double> t;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    run();
    t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

// The median of `v` (the upper one of an even count).
inline double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// CPU seconds used by the whole process (every thread, PoCL's included): a rate per CPU-second
// holds still on a shared machine where wall-clock rates swing 2x.
double ProcessCpuSeconds();

// The first `count` queries of `base` repeated cyclically (queries 0, 1, ..., n-1, 0, 1, ...),
// every per-query field `base` carries.
glint::v1::QueryBatch Tile(const glint::v1::QueryBatch &base, uint32_t count);

// The shared query sets: `count` random queries in the local frame with uv and footprint
// (tests/service/test_queries.h RandomQueries, seed 42); probes also carry wi.
glint::v1::QueryBatch SharedQueries(uint32_t count, bool probe);
QueryStats StatsOf(const glint::v1::QueryBatch &q);

// Adds the light set's lights to `request` (see Lights in bench_case.h).
void AddLights(Lights lights, glint::v1::EvaluateRequest *request);

// The server's checks (ValidateSettings, ValidateQueries, ValidateQueriesForModel): a request
// the service would refuse is not measured.
Status Validate(const glint::v1::EvaluateRequest &request, bool fp64_available);

// The non-empty items of a comma-separated command-line list ("SMOOTH,KEMPPINEN").
std::set<std::string> SplitList(const std::string &s);

// glintd's default kernel cache: $GLINT_CACHE_DIR, else $XDG_CACHE_HOME/glint, else
// ~/.cache/glint.
std::string DefaultCacheDir();
// A device engine with one command queue (one worker), the kernel cache in `cache_dir`.
// ltc_only_programs: DeviceEngineOptions::ltc_only_programs (bench_models --quick).
Status CreateEngine(const std::string &cache_dir, std::unique_ptr<DeviceEngine> *engine,
                    bool ltc_only_programs = false);

// Mean, 95th percentile and max of a set of errors (NaN when empty).
struct ErrorStats {
  double mean, p95, max;
};
ErrorStats Summarise(std::vector<double> errors);

// Per-query relative error of RGB radiance: |sum x - sum ref| / max(sum ref, floor) over the
// first n queries, the sums over the three channels, `floor` keeping queries whose reference is
// ~0 (a lobe that misses the light) from dividing by 0. Queries whose x is not finite are left
// out and counted in *nonfinite (the driver reports the count; the kernels should give none).
std::vector<double> RelativeErrors(const float *x, const std::vector<double> &ref_sum, double floor,
                                   uint32_t *nonfinite);
// The per-query RGB sums of radiance (3 floats per query).
std::vector<double> RgbSums(const float *rgb, uint32_t n);

}  // namespace glint::bench
