// Is bench_models' BINOMIAL error row a bias? (issue 13, session 10.) bench_models evaluates the
// BINOMIAL model once, with one seed, on its shared queries, and reports the relative difference
// of the batch mean from the smooth model's with a delta-method standard error over queries.
// This driver repeats exactly that evaluation (the same queries, lights, material, density and
// threshold: bench/cases/binomial.cpp) for many request seeds on the host path, and reports
//   - the mean over seeds of the relative difference and its standard error from the seeds'
//     spread (independent realisations of every count: the seed enters every cell key), so a
//     bias shows as a mean many of its standard errors from 0;
//   - the spread of the per-seed differences against the per-seed standard error bench_models
//     prints (their ratio is 1 when that standard error is right);
//   - per-query means over the seeds, binned by the query's N_P and by its share of the smooth
//     radiance, to say where a bias comes from.
//
//   binomial_bias [--seeds 200] [--queries 16384] [--np 1e2] [--lights quad]
//                 [--interpolation trilinear|tetrahedral|stochastic] [--threshold 9] [--fp64]
//                 [--seed-base 0]
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "client/lib/glint_client.h"
#include "server/eval_plan.h"
#include "server/host_path.h"

namespace {

using namespace glint;
using namespace glint::bench;

// Host evaluation of `request` split over `threads` threads in chunks of 64 queries (chunking
// does not change results: the determinism contract).
std::vector<double> HostSums(const glint::v1::EvaluateRequest &request, int threads) {
  const glint::v1::QueryBatch &q = request.queries();
  const uint32_t n = q.count();
  const EvalPlan plan = MakeEvalPlan(request, q);
  std::vector<float> out(3 * size_t(n));
  std::atomic<uint32_t> next{0};
  auto work = [&] {
    for (uint32_t b; (b = next.fetch_add(256)) < n;) {
      const uint32_t e = std::min(n, b + 256);
      HostEvaluate(plan, glint::client::SliceQueries(q, b, e), out.data() + 3 * size_t(b));
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto &t : pool) t.join();
  return RgbSums(out.data(), n);
}

}  // namespace

int main(int argc, char **argv) {
  int seeds = 200, threads = 2;
  uint32_t n_queries = 16384;
  double np = 1e2;
  float threshold = 9.0f;
  bool fp64 = false, vary_uv = false;
  uint64_t seed_base = 0, seed_step = 0x100000001ull;
  std::string lights_name = "quad", interpolation = "trilinear", dump;
  int group = 16;  // bench_models' --error-seeds: its statistic over consecutive seeds
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--fp64") {
      fp64 = true;
    } else if (a == "--vary-uv") {
      vary_uv = true;
    } else if (has && a == "--seeds") {
      seeds = std::stoi(argv[++i]);
    } else if (has && a == "--queries") {
      n_queries = uint32_t(std::stoul(argv[++i]));
    } else if (has && a == "--np") {
      np = std::stod(argv[++i]);
    } else if (has && a == "--threshold") {
      threshold = std::stof(argv[++i]);
    } else if (has && a == "--lights") {
      lights_name = argv[++i];
    } else if (has && a == "--interpolation") {
      interpolation = argv[++i];
    } else if (has && a == "--threads") {
      threads = std::stoi(argv[++i]);
    } else if (has && a == "--group") {
      group = std::max(1, std::stoi(argv[++i]));
    } else if (has && a == "--dump") {
      dump = argv[++i];
    } else if (has && a == "--seed-step") {
      seed_step = std::stoull(argv[++i], nullptr, 0);
    } else if (has && a == "--seed-base") {
      seed_base = std::stoull(argv[++i], nullptr, 0);
    } else {
      std::fprintf(stderr, "binomial_bias: unknown flag %s\n", a.c_str());
      return 2;
    }
  }
  const Lights lights = lights_name == "quad"         ? Lights::kQuad
                        : lights_name == "four_quads" ? Lights::kFourQuads
                                                      : Lights::kDirectionalPoint;
  const glint::v1::QueryBatch queries = SharedQueries(n_queries, false);
  const QueryStats stats = StatsOf(queries);
  auto request = [&](glint::v1::Model model) {
    glint::v1::EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(model);
    m->set_ndf(glint::v1::GGX);
    m->set_alpha_x(0.3f);
    m->set_alpha_y(0.1f);
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
    r.set_precision(glint::v1::FP64);
    *r.mutable_queries() = queries;
    AddLights(lights, &r);
    return r;
  };
  // The smooth reference as bench_models makes it: fp64 host.
  const std::vector<double> sv = HostSums(request(glint::v1::SMOOTH), threads);
  glint::v1::EvaluateRequest g = request(glint::v1::BINOMIAL);
  g.set_precision(fp64 ? glint::v1::FP64 : glint::v1::FP32);
  auto *b = g.mutable_material()->mutable_binomial();
  b->set_density(np / stats.mean_footprint_area);
  b->set_normal_threshold(threshold);
  if (interpolation == "tetrahedral") b->set_footprint_interpolation(glint::v1::TETRAHEDRAL);
  if (interpolation == "stochastic") b->set_footprint_interpolation(glint::v1::STOCHASTIC);
  if (Status s = Validate(g, true); !s.ok()) {
    std::fprintf(stderr, "binomial_bias: %s\n", s.message().c_str());
    return 1;
  }
  const uint32_t n = n_queries;
  double mean_s = 0;
  for (double v : sv) mean_s += v;
  mean_s /= n;

  // Per seed: bench_models' statistic (relative difference, delta-method s.e.).
  std::vector<double> diffs, ses;
  // Per seed: sum_i g^2 and sum_i g s, for bench_models' pooled statistic over a group of seeds.
  std::vector<double> seed_g2, seed_gs;
  double sum_s2 = 0;
  for (double v : sv) sum_s2 += v * v;
  // Per query: sums over seeds of g and g^2.
  std::vector<double> sum_g(n, 0.0), sum_g2(n, 0.0);
  for (int k = 0; k < seeds; ++k) {
    if (vary_uv) {  // bench_models' seed, the queries moved by (16 k, 8 k) in uv
      g.set_seed(0x9e3779b97f4aull + seed_base);
      *g.mutable_queries() = queries;
      for (uint32_t i = 0; i < n; ++i) {
        g.mutable_queries()->mutable_uv()->Set(2 * i, queries.uv(2 * i) + 16.0f * float(k));
        g.mutable_queries()->mutable_uv()->Set(2 * i + 1, queries.uv(2 * i + 1) + 8.0f * float(k));
      }
    } else {
      g.set_seed(0x9e3779b97f4aull + seed_base + uint64_t(k) * seed_step);
    }
    const std::vector<double> gv = HostSums(g, threads);
    double mean_g = 0;
    for (uint32_t i = 0; i < n; ++i) mean_g += gv[i], sum_g[i] += gv[i], sum_g2[i] += gv[i] * gv[i];
    mean_g /= n;
    const double ratio = mean_g / mean_s;
    double var = 0;
    for (uint32_t i = 0; i < n; ++i) var += (gv[i] - ratio * sv[i]) * (gv[i] - ratio * sv[i]);
    var /= (n - 1);
    diffs.push_back(ratio - 1.0);
    ses.push_back(std::sqrt(var / n) / mean_s);
    double g2 = 0, gs = 0;
    for (uint32_t i = 0; i < n; ++i) g2 += gv[i] * gv[i], gs += gv[i] * sv[i];
    seed_g2.push_back(g2);
    seed_gs.push_back(gs);
    if (k < 10 || (k + 1) % 50 == 0)
      std::printf("seed %4d: rel diff %+.5f  s.e. %.5f  (%+.2f s.e.)\n", k, ratio - 1.0, ses.back(),
                  (ratio - 1.0) / ses.back());
    std::fflush(stdout);
  }
  if (!dump.empty()) {  // one line per seed: relative difference, bench_models' s.e.
    if (FILE *f = std::fopen(dump.c_str(), "w")) {
      for (int k = 0; k < seeds; ++k) std::fprintf(f, "%.9g %.9g\n", diffs[k], ses[k]);
      std::fclose(f);
    }
  }
  double md = 0, ms = 0;
  for (int k = 0; k < seeds; ++k) md += diffs[k], ms += ses[k];
  md /= seeds, ms /= seeds;
  double vd = 0;
  for (double d : diffs) vd += (d - md) * (d - md);
  vd /= (seeds - 1);
  // The spread the per-seed means would have if the queries were independent: the sum of the
  // per-query variances over the seeds (each query's own variance, its rare large values
  // included, which one seed's sample variance mostly misses).
  double var_independent = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const double m = sum_g[i] / seeds;
    var_independent += (sum_g2[i] / seeds - m * m) * seeds / (seeds - 1);
  }
  const double sd_independent = std::sqrt(var_independent) / (n * mean_s);
  std::vector<double> sorted_ses = ses, sorted_diffs = diffs;
  std::sort(sorted_ses.begin(), sorted_ses.end());
  std::sort(sorted_diffs.begin(), sorted_diffs.end());
  double m4 = 0;
  for (double d : diffs) m4 += std::pow(d - md, 4);
  m4 /= seeds;
  int beyond3 = 0;
  for (int k = 0; k < seeds; ++k) beyond3 += std::fabs(diffs[k]) > 3 * ses[k];
  std::printf(
      "\n%s N_P=%g threshold %g %s %s, %u queries, %d seeds:\n"
      "  mean rel diff over seeds %+.6f +- %.6f (its s.e. from the seeds' spread: %+.2f s.e.)\n"
      "  spread of the per-seed rel diff %.6f; mean per-seed s.e. (bench_models') %.6f; "
      "ratio %.3f\n"
      "  seeds with |diff| > 3 of their own s.e.: %d of %d (normal: %.1f)\n",
      lights_name.c_str(), np, threshold, interpolation.c_str(), fp64 ? "fp64" : "fp32", n, seeds,
      md, std::sqrt(vd / seeds), md / std::sqrt(vd / seeds), std::sqrt(vd), ms, std::sqrt(vd) / ms,
      beyond3, seeds, 0.0027 * seeds);
  std::printf(
      "  spread predicted from the per-query variances (independent queries) %.6f\n"
      "  per-seed s.e.: median %.6f, 10%% %.6f, 90%% %.6f; per-seed diff: 1%% %+.6f, median "
      "%+.6f, 99%% %+.6f; kurtosis %.2f (normal 3)\n",
      sd_independent, sorted_ses[seeds / 2], sorted_ses[seeds / 10], sorted_ses[seeds * 9 / 10],
      sorted_diffs[seeds / 100], sorted_diffs[seeds / 2], sorted_diffs[seeds * 99 / 100],
      m4 / (vd * vd));
  // Where the first seed (bench_models' own) falls among all of them.
  const double below = double(std::lower_bound(sorted_diffs.begin(), sorted_diffs.end(), diffs[0]) -
                              sorted_diffs.begin());
  std::printf("  seed 0 (bench_models' seed): diff %+.6f, %.4f of the seeds below it\n", diffs[0],
              below / seeds);

  // bench_models' statistic (Driver::Errors) over groups of `group` consecutive seeds: the mean
  // ratio, the larger of the pooled delta-method variance and the groups' own spread; how often
  // |mean - 1| exceeds 2 and 3 of it, and the spread of the group means against its median.
  if (group > 1 && seeds / group >= 2) {
    const int groups = seeds / group;
    std::vector<double> gmean, gse;
    int beyond2 = 0, beyond3g = 0;
    for (int j = 0; j < groups; ++j) {
      double r = 0, g2 = 0, gs = 0;
      for (int k = j * group; k < (j + 1) * group; ++k)
        r += (diffs[k] + 1.0) / group, g2 += seed_g2[k], gs += seed_gs[k];
      // sum over seeds x queries of (g - r s)^2 = sum g^2 - 2 r sum g s + r^2 seeds sum s^2
      const double total = double(group) * n;
      const double pooled =
          (g2 - 2 * r * gs + r * r * group * sum_s2) / ((total - 1) * total) / (mean_s * mean_s);
      double spread = 0;
      for (int k = j * group; k < (j + 1) * group; ++k)
        spread += std::pow(diffs[k] + 1.0 - r, 2) / ((group - 1) * double(group));
      gmean.push_back(r - 1.0);
      gse.push_back(std::sqrt(std::max(pooled, spread)));
      beyond2 += std::fabs(r - 1.0) > 2 * gse.back();
      beyond3g += std::fabs(r - 1.0) > 3 * gse.back();
    }
    double mg = 0, vg = 0;
    for (double x : gmean) mg += x / groups;
    for (double x : gmean) vg += (x - mg) * (x - mg) / (groups - 1);
    std::vector<double> sorted_gse = gse;
    std::sort(sorted_gse.begin(), sorted_gse.end());
    std::printf(
        "\n  bench_models' statistic over %d seeds, %d groups: spread of the group means %.6f, "
        "their s.e. median %.6f (ratio %.3f); |mean| > 2 s.e. in %d (normal: %.1f), > 3 s.e. "
        "in %d (normal: %.1f)\n",
        group, groups, std::sqrt(vg), sorted_gse[groups / 2],
        std::sqrt(vg) / sorted_gse[groups / 2], beyond2, 0.0455 * groups, beyond3g,
        0.0027 * groups);
  }

  // Where: per-query mean over seeds minus the smooth value, summed by N_P bin, relative to the
  // batch's smooth sum; with its standard error from the per-query spread over seeds.
  const double density = np / stats.mean_footprint_area;
  const double edges[] = {0, 0.1, 0.3, 1, 3, 10, 30, 100, 300, 1e3, 1e4, 1e30};
  const int bins = int(sizeof edges / sizeof edges[0]) - 1;
  std::vector<double> bias(bins, 0.0), var(bins, 0.0), smooth(bins, 0.0);
  std::vector<int> count(bins, 0);
  for (uint32_t i = 0; i < n; ++i) {
    const float *f = queries.footprint().data() + 4 * i;
    const double n_p = density * std::fabs(double(f[0]) * f[3] - double(f[2]) * f[1]);
    int bin = 0;
    while (bin + 1 < bins && n_p >= edges[bin + 1]) ++bin;
    const double m = sum_g[i] / seeds;
    const double v = (sum_g2[i] / seeds - m * m) * seeds / (seeds - 1);
    bias[bin] += m - sv[i];
    var[bin] += v / seeds;
    smooth[bin] += sv[i];
    ++count[bin];
  }
  const double total = mean_s * n;
  std::printf(
      "\n  N_P bin          queries  smooth share  bias / total smooth   +- s.e.   (s.e.)\n");
  for (int k = 0; k < bins; ++k)
    std::printf("  [%6g, %6g)  %7d  %10.4f   %+12.6f   %10.6f   %+6.2f\n", edges[k], edges[k + 1],
                count[k], smooth[k] / total, bias[k] / total, std::sqrt(var[k]) / total,
                var[k] > 0 ? bias[k] / std::sqrt(var[k]) : 0.0);
  return 0;
}
