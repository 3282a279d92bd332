// Binomial-model throughput on the OpenCL device (DeviceEngine, fp32, one
// lane) against the smooth model on the same queries and lights, and the bias
// of its expected value: mean glint radiance / mean smooth radiance - 1 over
// the batch, with its standard error (delta method on per-query RGB sums).
// Local frame, one directional light (cone 0.5 deg) and one polygon quad.
// Density is set so the mean footprint holds N_P facets (density = N_P / mean
// |det J| of the batch). Median of --repeat runs.
//
//   cmake -S /work/main -B /work/main/build && cmake --build /work/main/build --target
//   bench_binomial build/bench/bench_binomial [--queries N] [--repeat R]     (defaults 200000, 3)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "test_queries.h"

namespace {

using Clock = std::chrono::steady_clock;

glint::v1::EvaluateRequest MakeRequest(const glint::v1::QueryBatch &q) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  r.set_precision(glint::v1::FP32);
  r.set_seed(0x9e3779b97f4aull);
  auto *d = r.add_lights()->mutable_directional();
  for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
  for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
  d->set_cone_half_angle_deg(0.5f);
  auto *p = r.add_lights()->mutable_polygon();
  for (float v : {-3.0f, -3.0f, 3.0f, 3.0f, -3.0f, 3.0f, 3.0f, 3.0f, 3.0f, -3.0f, 3.0f, 3.0f})
    p->add_vertices(v);
  for (float v : {1.0f, 0.5f, 0.25f}) p->add_radiance(v);
  p->set_two_sided(true);
  *r.mutable_queries() = q;
  return r;
}

}  // namespace

int main(int argc, char **argv) {
  uint32_t n = 200000;
  int repeat = 3;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--queries" && i + 1 < argc)
      n = uint32_t(std::stoul(argv[++i]));
    else if (a == "--repeat" && i + 1 < argc)
      repeat = std::stoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: bench_binomial [--queries N] [--repeat R]\n");
      return 2;
    }
  }
  const glint::v1::QueryBatch q = glint::test::RandomQueries(n, false, false, 42);
  double mean_area = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const float *f = q.footprint().data() + 4 * i;
    mean_area += std::fabs(double(f[0]) * f[3] - double(f[2]) * f[1]);
  }
  mean_area /= n;

  std::unique_ptr<glint::DeviceEngine> engine;
  glint::DeviceEngineOptions options;
  options.workers = 1;
  glint::Status s = glint::DeviceEngine::Create(options, &engine);
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  // Median seconds of `repeat` timed runs after one untimed (compile + warm);
  // `out` keeps the last run's radiance.
  auto run = [&](const glint::v1::EvaluateRequest &request, std::vector<float> *out,
                 double *seconds) -> bool {
    const glint::EvalPlan plan = glint::MakeEvalPlan(request, request.queries());
    out->assign(size_t(3) * n, 0.0f);
    glint::Status st = engine->Evaluate(0, plan, request.queries(), out->data());
    if (!st.ok()) {
      std::fprintf(stderr, "%s\n", st.message().c_str());
      return false;
    }
    std::vector<double> t;
    for (int r = 0; r < repeat; ++r) {
      auto t0 = Clock::now();
      st = engine->Evaluate(0, plan, request.queries(), out->data());
      t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
      if (!st.ok()) {
        std::fprintf(stderr, "%s\n", st.message().c_str());
        return false;
      }
    }
    std::sort(t.begin(), t.end());
    *seconds = t[t.size() / 2];
    return true;
  };

  glint::v1::EvaluateRequest request = MakeRequest(q);
  std::vector<float> smooth, glint;
  double smooth_s = 0;
  if (!run(request, &smooth, &smooth_s)) return 1;
  std::vector<double> sv(n);
  double mean_s = 0;
  for (uint32_t i = 0; i < n; ++i) {
    sv[i] = double(smooth[3 * i]) + smooth[3 * i + 1] + smooth[3 * i + 2];
    mean_s += sv[i];
  }
  mean_s /= n;

  std::printf(
      "binomial vs smooth, %u queries (local frame, directional cone 0.5 deg + polygon "
      "quad), device %s fp32 1 lane, median of %d; mean |det J| = %.3g\n",
      n, engine->info().name.c_str(), repeat, mean_area);
  std::printf("smooth: %.1f M evals/s\n\n", n / smooth_s / 1e6);
  std::printf("| N_P | threshold | evals/s | ratio to smooth | \\|E error\\| | se |\n");
  std::printf("|---|---|---|---|---|---|\n");
  auto *m = request.mutable_material();
  m->set_model(glint::v1::BINOMIAL);
  for (double np : {1e2, 1e4, 1e6})
    for (float threshold : {1.0f, 9.0f, 40.0f}) {
      m->mutable_binomial()->set_density(np / mean_area);
      m->mutable_binomial()->set_normal_threshold(threshold);
      double sec = 0;
      if (!run(request, &glint, &sec)) return 1;
      double mean_g = 0;
      std::vector<double> gv(n);
      for (uint32_t i = 0; i < n; ++i) {
        gv[i] = double(glint[3 * i]) + glint[3 * i + 1] + glint[3 * i + 2];
        mean_g += gv[i];
      }
      mean_g /= n;
      const double ratio = mean_g / mean_s;
      // Delta method: var(mean_g / mean_s) ~ var(g - ratio s) / (n mean_s^2).
      double var = 0;
      for (uint32_t i = 0; i < n; ++i) {
        const double e = gv[i] - ratio * sv[i];
        var += e * e;
      }
      var /= (n - 1);
      const double se = std::sqrt(var / n) / mean_s;
      std::printf("| %.0e | %g | %.2f M | %.3f | %.2e | %.1e |\n", np, threshold, n / sec / 1e6,
                  smooth_s / sec, std::fabs(ratio - 1.0), se);
    }
  return 0;
}
