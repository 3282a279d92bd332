// Validation of the AUTO area method (kernels/area/area_auto.h) on held-out configurations:
// random polygon lights and views from tools/area_auto MakeConfigs with seed 2 (the table was
// fitted on seed 1; one view in four between 85 deg and the horizon), GGX and Beckmann, truth by
// the adaptive integration in double. Per budget:
//   exceed     fraction of queries (that see some of the light) whose relative error (|x - truth| /
//   max(truth, 1e-3)) is
//              above the budget, and the error's median / 95th percentile / max;
//   evals/s    device fp32 throughput of AUTO on these configurations (DeviceEngine, one worker,
//              in process, buffer set-up and read-back included): one request per light, its
//              views tiled to --tile queries; sum of queries / sum of times;
//   vs REF32   that throughput over the same for REFERENCE 32 (the most accurate candidate,
//              what a user who must meet any budget would otherwise pick), and LTC's;
//   feasible   share of queries where the table predicts some candidate meets the budget (the
//              others get the candidate of smallest predicted error), and the exceed fraction
//              among those: the fraction AUTO's contract is about;
//   grazing    the three fractions above over the views at theta_o >= 85 deg only;
//   mix        the methods AUTO chose (host-side replay of the kernel's choice).
// Also one row per fixed candidate (its error and throughput), for the plot.
//
//   build/bench/bench_area_auto --csv docs/area_auto_validation.csv    # ~10 min loaded
//   python3 bench/plot_area_auto.py docs/area_auto_validation.csv       # -> docs/area_auto.png
//
// Flags: --configs N (lights per NDF, default 60, 8 views each), --tile T (default 128),
// --csv PATH, --budgets b1,b2,... (default 0.005,0.01,0.02,0.05,0.1,0.2,0.5).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "tools/area_auto/area_auto_data.h"

namespace {

using glint::bench::Clock;
using namespace glint::area_auto;

struct Row {
  std::string ndf, variant;
  double budget = 0;  // 0 for the fixed methods
  size_t queries = 0;
  double exceed = NAN, p50 = NAN, p95 = NAN, max = NAN, mean = NAN;
  // AUTO: the share of queries where the table predicted some method meets the budget, and
  // the fraction above the budget among those.
  double feasible = NAN, exceed_feasible = NAN;
  // The same over the grazing views only (theta_o >= 85 deg, the table's last view bin).
  size_t grazing = 0;
  double exceed_grazing = NAN, feasible_grazing = NAN, exceed_feasible_grazing = NAN;
  double evals_per_s = NAN;
  std::map<std::string, double> mix;  // AUTO only: share of (query, light) per method
};

std::string MethodName(int method, int samples) {
  switch (method) {
    case GLINT_AREA_LTC:
      return "LTC";
    case GLINT_AREA_LECOCQ:
      return "LECOCQ";
    case GLINT_AREA_LECOCQ_PEARSON:
      return "LECOCQ_PEARSON";
    case GLINT_AREA_REFERENCE:
      return "REFERENCE:" + std::to_string(samples);
    default:
      return samples <= 16    ? "MONTE_CARLO:<=16"
             : samples <= 128 ? "MONTE_CARLO:<=128"
                              : "MONTE_CARLO:>128";
  }
}

double Quant(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(std::ceil(q * double(v.size()))) - 1)];
}

// Errors (untiled) and throughput (tiled) of one method over the configurations.
Row Run(glint::DeviceEngine &engine, const std::vector<Config> &set,
        const std::vector<std::vector<double>> &truth, glint::v1::AreaMethod method,
        uint32_t samples, float budget, uint32_t tile) {
  Row row;
  std::vector<double> err;
  size_t feasible = 0, feasible_above = 0;
  size_t g = 0, g_above = 0, g_feasible = 0, g_feasible_above = 0;
  double seconds = 0;
  uint64_t timed = 0;
  for (size_t i = 0; i < set.size(); ++i) {
    const glint::v1::EvaluateRequest r = MakeRequest(set[i], method, samples, 7, budget);
    glint::Status s = glint::bench::Validate(r, engine.info().fp64);
    if (!s.ok()) {
      std::fprintf(stderr, "refused: %s\n", s.message().c_str());
      std::exit(1);
    }
    const glint::EvalPlan plan = glint::MakeEvalPlan(r, r.queries());
    std::vector<float> out(3 * size_t(r.queries().count()));
    s = engine.Evaluate(0, plan, r.queries(), out.data());
    if (!s.ok()) {
      std::fprintf(stderr, "engine: %s\n", s.message().c_str());
      std::exit(1);
    }
    // Queries that see nothing of the light (every method gives 0) are left out.
    const std::vector<int> cells = Cells(set[i]);
    const std::vector<Choice> choice = Choices(set[i], budget);
    for (uint32_t q = 0; q < r.queries().count(); ++q) {
      if (cells[q] < 0) continue;
      err.push_back(RelativeError(out[3 * q], truth[i][q]));
      const bool over = err.back() > double(budget);
      const bool grazing = set[i].wo[q][2] < kGrazingMaxCos;
      g += grazing;
      g_above += grazing && over;
      if (method == glint::v1::AUTO && choice[q].predicted <= budget) {
        ++feasible;
        feasible_above += over;
        g_feasible += grazing;
        g_feasible_above += grazing && over;
      }
    }
    const glint::v1::QueryBatch big = glint::bench::Tile(r.queries(), tile);
    std::vector<float> big_out(3 * size_t(tile));
    seconds +=
        glint::bench::MedianSeconds(3, [&] { engine.Evaluate(0, plan, big, big_out.data()); });
    timed += tile;
  }
  row.queries = err.size();
  double sum = 0;
  size_t above = 0;
  for (double e : err) {
    sum += e;
    above += e > double(budget);
  }
  if (budget > 0) row.exceed = double(above) / double(err.size());
  row.grazing = g;
  if (budget > 0) row.exceed_grazing = double(g_above) / double(std::max<size_t>(g, 1));
  if (method == glint::v1::AUTO) {
    row.feasible = double(feasible) / double(err.size());
    row.exceed_feasible = double(feasible_above) / double(std::max<size_t>(feasible, 1));
    row.feasible_grazing = double(g_feasible) / double(std::max<size_t>(g, 1));
    row.exceed_feasible_grazing =
        double(g_feasible_above) / double(std::max<size_t>(g_feasible, 1));
  }
  row.mean = sum / double(err.size());
  row.p50 = Quant(err, 0.5);
  row.p95 = Quant(err, 0.95);
  row.max = Quant(err, 1.0);
  row.evals_per_s = double(timed) / seconds;
  return row;
}

std::string F(double v, const char *f = "%.3g") {
  if (std::isnan(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

}  // namespace

int main(int argc, char **argv) {
  int configs = 60;
  uint32_t tile = 128;
  std::string csv;
  std::vector<float> budgets = {0.005f, 0.01f, 0.02f, 0.05f, 0.1f, 0.2f, 0.5f};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--configs" && i + 1 < argc)
      configs = std::stoi(argv[++i]);
    else if (a == "--tile" && i + 1 < argc)
      tile = uint32_t(std::stoul(argv[++i]));
    else if (a == "--csv" && i + 1 < argc)
      csv = argv[++i];
    else if (a == "--budgets" && i + 1 < argc) {
      budgets.clear();
      std::stringstream ss(argv[++i]);
      for (std::string t; std::getline(ss, t, ',');) budgets.push_back(std::stof(t));
    } else {
      std::fprintf(stderr,
                   "usage: bench_area_auto [--configs N] [--tile T] [--csv PATH] [--budgets "
                   "b1,b2,...]\n");
      return 2;
    }
  }
  std::unique_ptr<glint::DeviceEngine> engine;
  glint::Status st = glint::bench::CreateEngine(glint::bench::DefaultCacheDir(), &engine);
  if (!st.ok()) {
    std::fprintf(stderr, "%s\n", st.message().c_str());
    return 1;
  }
  std::printf("# AUTO area method on held-out configurations (seed 2)\n\n");
  std::printf(
      "device: %s, fp32, one worker; %d lights x 8 views per NDF; timing tiles each "
      "light's views to %u queries (machine shared with other jobs: absolute rates are "
      "loaded, ratios are what to read)\n\n",
      engine->info().name.c_str(), configs, tile);
  std::vector<Row> rows;
  for (int ndf : {1, 2}) {
    const char *ndf_name = ndf == 2 ? "beckmann" : "ggx";
    const std::vector<Config> set = MakeConfigs(2, configs, 8, ndf);
    std::vector<std::vector<double>> truth(set.size());
    {
      std::atomic<size_t> next{0};
      auto work = [&] {
        for (size_t i; (i = next.fetch_add(1)) < set.size();) truth[i] = Truth(set[i]);
      };
      std::thread a(work), b(work);
      a.join();
      b.join();
    }
    std::printf(
        "## %s\n\n| method | budget | exceed | feasible | exceed where feasible | grazing: exceed "
        "| feasible | exceed where feasible | median | p95 | max | evals/s | vs REF32 | mix "
        "|\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        ndf == 2 ? "Beckmann" : "GGX");
    std::vector<Row> fixed;
    for (int k = 0; k < 7; ++k) {
      const glint::v1::AreaMethod m = k == 0   ? glint::v1::LTC
                                      : k == 1 ? glint::v1::LECOCQ
                                      : k == 2 ? glint::v1::LECOCQ_PEARSON
                                               : glint::v1::REFERENCE;
      const uint32_t n = k < 3 ? 0u : 4u << (k - 3);
      Row r = Run(*engine, set, truth, m, n, 0.0f, tile);
      r.ndf = ndf_name;
      r.variant = MethodName(int(m), int(n));
      fixed.push_back(r);
    }
    for (uint32_t n : {16u, 256u}) {
      Row r = Run(*engine, set, truth, glint::v1::MONTE_CARLO, n, 0.0f, tile);
      r.ndf = ndf_name;
      r.variant = "MONTE_CARLO:" + std::to_string(n);
      fixed.push_back(r);
    }
    const double ref32 = fixed[6].evals_per_s;
    for (const Row &r : fixed) {
      std::printf("| %s | - | - | - | - | - | - | - | %s | %s | %s | %s | %s | |\n",
                  r.variant.c_str(), F(r.p50).c_str(), F(r.p95).c_str(), F(r.max).c_str(),
                  F(r.evals_per_s).c_str(), F(r.evals_per_s / ref32).c_str());
      rows.push_back(r);
    }
    for (float b : budgets) {
      Row r = Run(*engine, set, truth, glint::v1::AUTO, 0, b, tile);
      r.ndf = ndf_name;
      r.variant = "AUTO";
      r.budget = b;
      size_t total = 0;
      for (const Config &c : set)
        for (const Choice &ch : Choices(c, b)) {
          r.mix[MethodName(ch.method, ch.samples)] += 1;
          ++total;
        }
      std::string mix;
      for (auto &[name, count] : r.mix) {
        count /= double(total);
        mix += name + " " + F(100 * count, "%.0f") + "% ";
      }
      std::printf("| AUTO | %g | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s|\n",
                  double(b), F(r.exceed).c_str(), F(r.feasible).c_str(),
                  F(r.exceed_feasible).c_str(), F(r.exceed_grazing).c_str(),
                  F(r.feasible_grazing).c_str(), F(r.exceed_feasible_grazing).c_str(),
                  F(r.p50).c_str(), F(r.p95).c_str(), F(r.max).c_str(), F(r.evals_per_s).c_str(),
                  F(r.evals_per_s / ref32).c_str(), mix.c_str());
      std::fflush(stdout);
      rows.push_back(r);
    }
    std::printf("\n");
  }
  if (!csv.empty()) {
    std::ofstream f(csv);
    f << "ndf,variant,budget,queries,exceed,feasible,exceed_feasible,mean,p50,p95,max,evals_per_s,"
         "mix,grazing_queries,exceed_grazing,feasible_grazing,exceed_feasible_grazing\n";
    for (const Row &r : rows) {
      std::string mix;
      for (auto &[name, share] : r.mix) mix += name + "=" + F(share, "%.4f") + ";";
      f << r.ndf << ',' << r.variant << ',' << F(r.budget, "%g") << ',' << r.queries << ','
        << F(r.exceed, "%.5g") << ',' << F(r.feasible, "%.5g") << ','
        << F(r.exceed_feasible, "%.5g") << ',' << F(r.mean, "%.5g") << ',' << F(r.p50, "%.5g")
        << ',' << F(r.p95, "%.5g") << ',' << F(r.max, "%.5g") << ',' << F(r.evals_per_s, "%.5g")
        << ',' << mix << ',' << r.grazing << ',' << F(r.exceed_grazing, "%.5g") << ','
        << F(r.feasible_grazing, "%.5g") << ',' << F(r.exceed_feasible_grazing, "%.5g") << "\n";
    }
    std::printf("wrote %s\n", csv.c_str());
  }
  return 0;
}
