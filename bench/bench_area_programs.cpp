// What bench_models --quick's LTC-only polygon programs (DeviceEngineOptions::ltc_only_programs,
// --area-programs ltc-only) change: for the LTC polygon-light rows of bench_models' cases (each
// model's first quick variant with LTC, quad and four_quads), two device engines on one fresh
// PoCL cache, glintd's (one program per spec with every area method behind the runtime switch)
// and the specialising one (-DGLINT_AREA_ONLY=1):
//   build   each engine's first run of the row (its program's cold build and PoCL's
//           work-group compile), wall and CPU seconds (all threads of this process);
//   same    whether the two engines' radiance is bit-identical on the row's batch (exit 1 if not);
//   cost    interleaved rounds, each engine evaluating the batch once per round (which goes first
//           alternates), the LTC-only / shared ratio of CPU seconds per evaluation per round,
//           and its median: whether the rows time the same kernel speed as glintd's program.
// Label the numbers "loaded" on a shared machine (CPU seconds move less with the load than wall).
//
//   build/bench/bench_area_programs [--models CHERMAIN,KEMPPINEN] [--precisions fp32,fp64]
//                                   [--rounds R] [--queries N] [--cache-dir DIR]
// --cache-dir must be a fresh directory for the build column to be a cold build (default: a new
// directory under /tmp).
#include <stdlib.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "bench/lib/bench_case.h"
#include "bench/lib/bench_lib.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/model_table.h"

namespace glint::bench {
namespace {

using Clock = std::chrono::steady_clock;

struct Row {
  std::string name;
  glint::v1::EvaluateRequest request;
  EvalPlan plan;
  double build_s[2] = {0, 0}, build_cpu[2] = {0, 0};
  bool same = false;
  std::vector<double> ratios;  // specialised / generic CPU seconds per round
  double cpu_per_eval[2] = {0, 0};
};

int Main(int argc, char **argv) {
  std::set<std::string> models = {"SMOOTH", "CHERMAIN", "KEMPPINEN"}, precisions = {"fp32"};
  int rounds = 5;
  uint32_t queries = 4096;
  std::string cache_dir;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--models")
      models = SplitList(v);
    else if (a == "--precisions")
      precisions = SplitList(v);
    else if (a == "--rounds")
      rounds = std::max(1, std::atoi(v.c_str()));
    else if (a == "--queries")
      queries = uint32_t(std::max(8, std::atoi(v.c_str())));
    else if (a == "--cache-dir")
      cache_dir = v;
    else {
      std::fprintf(stderr,
                   "usage: bench_area_programs [--models A,B] [--precisions fp32,fp64] "
                   "[--rounds R] [--queries N] [--cache-dir DIR]\n");
      return 2;
    }
  }
  if (cache_dir.empty()) {
    char dir[] = "/tmp/bench_area_programs.XXXXXX";
    if (!mkdtemp(dir)) return 1;
    cache_dir = dir;
  }
  std::unique_ptr<DeviceEngine> engines[2];
  for (int e = 0; e < 2; ++e)
    if (Status s = CreateEngine(cache_dir, &engines[e], e == 1); !s.ok()) {
      std::fprintf(stderr, "bench_area_programs: %s\n", s.message().c_str());
      return 1;
    }

  // The rows: bench_models' requests (case material, shared queries with the case's footprints,
  // its light sets and seed), each model's first quick variant per area method.
  std::vector<Row> rows;
  const glint::v1::QueryBatch shared = SharedQueries(queries, false);
  for (const ModelBenchCase &c : BenchCases()) {
    const Model *model = FindModel(c.model);
    if (!model || !models.count(model->name)) continue;
    glint::v1::QueryBatch q = shared;
    if (c.footprints) c.footprints(&q);
    const QueryStats stats = StatsOf(q);
    std::set<std::string> seen;  // light set, area method, precision
    for (Lights lights : {Lights::kQuad, Lights::kFourQuads})
      for (const BenchVariant &v : c.variants) {
        if (!v.quick || (!v.lights.empty() &&
                         std::find(v.lights.begin(), v.lights.end(), lights) == v.lights.end()))
          continue;
        for (const std::string &precision : precisions) {
          Row row;
          glint::v1::EvaluateRequest &r = row.request;
          auto *m = r.mutable_material();
          m->set_model(c.model);
          c.base(m);
          r.set_precision(precision == "fp64" ? glint::v1::FP64 : glint::v1::FP32);
          r.set_seed(0x9e3779b97f4aull);
          *r.mutable_queries() = q;
          AddLights(lights, &r);
          if (v.apply) v.apply(&r, stats);
          if (!Validate(r, engines[0]->info().fp64).ok()) continue;
          row.plan = MakeEvalPlan(r, r.queries());
          if (!ResolveRequestTable(r.material(), &row.plan).ok()) continue;
          if (row.plan.area_method != GLINT_AREA_LTC) continue;  // the shared program either way
          const std::string key = std::string(LightsName(lights)) + " " +
                                  std::to_string(row.plan.area_method) + " " + precision;
          if (!seen.insert(key).second) continue;
          row.name =
              std::string(model->name) + " " + v.name + " " + LightsName(lights) + " " + precision;
          rows.push_back(std::move(row));
        }
      }
  }

  std::vector<float> out[2];
  auto run = [&](int e, Row &row, uint32_t n, double *cpu) {
    const glint::v1::QueryBatch q = Tile(row.request.queries(), n);
    out[e].assign(3 * size_t(n), -1.0f);
    const double cpu0 = ProcessCpuSeconds();
    Status s = engines[e]->Evaluate(0, row.plan, q, out[e].data());
    *cpu = ProcessCpuSeconds() - cpu0;
    if (!s.ok()) std::fprintf(stderr, "%s: %s\n", row.name.c_str(), s.message().c_str());
    return s.ok();
  };
  bool all_same = true;
  for (Row &row : rows) {
    for (int e = 0; e < 2; ++e) {  // the cold build: a one-query run
      const auto t0 = Clock::now();
      if (!run(e, row, 1, &row.build_cpu[e])) return 1;
      row.build_s[e] = std::chrono::duration<double>(Clock::now() - t0).count();
    }
    double cpu = 0;
    for (int e = 0; e < 2; ++e)
      if (!run(e, row, queries, &cpu)) return 1;
    row.same = std::memcmp(out[0].data(), out[1].data(), out[0].size() * sizeof(float)) == 0;
    all_same = all_same && row.same;
    std::fprintf(stderr, "%s: build %.1f / %.1f CPU-s (shared / LTC only), radiance %s\n",
                 row.name.c_str(), row.build_cpu[0], row.build_cpu[1],
                 row.same ? "bit-identical" : "DIFFERENT");
  }
  for (int round = 0; round < rounds; ++round)
    for (Row &row : rows) {
      double cpu[2] = {0, 0};
      for (int k = 0; k < 2; ++k) {
        const int e = (round + k) % 2;
        if (!run(e, row, queries, &cpu[e])) return 1;
      }
      row.ratios.push_back(cpu[1] / cpu[0]);
      for (int e = 0; e < 2; ++e) row.cpu_per_eval[e] += cpu[e] / (double(queries) * rounds);
    }
  std::printf("%u queries, %d interleaved rounds, PoCL cache %s\n\n", queries, rounds,
              cache_dir.c_str());
  std::printf(
      "| row | build CPU-s shared | LTC only | build s shared | LTC only | "
      "radiance | CPU-us/eval shared | LTC only | ratio median | min | max |\n");
  std::printf("| --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: |\n");
  double build[2] = {0, 0};
  for (const Row &row : rows) {
    std::printf("| %s | %.2f | %.2f | %.1f | %.1f | %s | %.3g | %.3g | %.3f | %.3f | %.3f |\n",
                row.name.c_str(), row.build_cpu[0], row.build_cpu[1], row.build_s[0],
                row.build_s[1], row.same ? "bit-identical" : "DIFFERENT", 1e6 * row.cpu_per_eval[0],
                1e6 * row.cpu_per_eval[1], Median(row.ratios),
                *std::min_element(row.ratios.begin(), row.ratios.end()),
                *std::max_element(row.ratios.begin(), row.ratios.end()));
    for (int e = 0; e < 2; ++e) build[e] += row.build_cpu[e];
  }
  std::printf(
      "\nfirst runs (builds where a program was new to its engine): %.1f CPU-s shared, "
      "%.1f LTC only\n",
      build[0], build[1]);
  return all_same ? 0 : 1;
}

}  // namespace
}  // namespace glint::bench

int main(int argc, char **argv) {
  return glint::bench::Main(argc, argv);
}
