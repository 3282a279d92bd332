// Chermain-model throughput on the OpenCL device (DeviceEngine, fp32, one lane) per dictionary
// size and maximum anisotropy, against the smooth model (Beckmann) on the same queries and
// light. Queries: random uv in [0, 4]^2, random view, footprints of a random orientation with
// minor axis 2^-15 .. 2^-9 uv (1 .. 64 level-0 cells) and anisotropy 1 .. 32 (log-uniform), so
// the eccentricity clamp decides how many cells are visited. One directional light. Median of
// --repeat runs; then a quad light instead of the sun (the polygon pass). With --json, one JSON
// object per row on stdout instead of the table.
//
//   cmake --build build --target bench_chermain && build/bench/bench_chermain [--queries N]
//   [--repeat R] [--json]                                                  (defaults 200000, 3)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"

namespace {

using Clock = std::chrono::steady_clock;

glint::v1::QueryBatch Queries(uint32_t n) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  glint::v1::QueryBatch q;
  q.set_count(n);
  for (uint32_t i = 0; i < n; ++i) {
    q.add_uv(4 * u(rng));
    q.add_uv(4 * u(rng));
    const float minor = std::exp2(-15.0f + 6.0f * u(rng)), major = minor * std::exp2(5 * u(rng));
    const float phi = 6.2832f * u(rng), c = std::cos(phi), s = std::sin(phi);
    // Columns du/dx = major (c, s), du/dy = minor (-s, c).
    for (float f : {major * c, major * s, -minor * s, minor * c}) q.add_footprint(f);
    const float t = 1.3f * u(rng), p = 6.2832f * u(rng);
    for (float v : {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)}) q.add_wo(v);
  }
  return q;
}

glint::v1::EvaluateRequest MakeRequest(const glint::v1::QueryBatch &q) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::BECKMANN);
  m->set_alpha_x(0.5f);
  m->set_alpha_y(0.5f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  r.set_precision(glint::v1::FP32);
  r.set_seed(0x9e3779b97f4aull);
  auto *d = r.add_lights()->mutable_directional();
  for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
  for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
  *r.mutable_queries() = q;
  return r;
}

}  // namespace

int main(int argc, char **argv) {
  uint32_t n = 200000;
  int repeat = 3;
  bool json = false;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--queries" && i + 1 < argc) {
      n = uint32_t(std::stoul(argv[++i]));
    } else if (a == "--repeat" && i + 1 < argc) {
      repeat = std::stoi(argv[++i]);
    } else if (a == "--json") {
      json = true;
    } else {
      std::fprintf(stderr, "usage: bench_chermain [--queries N] [--repeat R] [--json]\n");
      return 2;
    }
  }
  const glint::v1::QueryBatch q = Queries(n);
  std::unique_ptr<glint::DeviceEngine> engine;
  glint::DeviceEngineOptions options;
  options.workers = 1;
  glint::Status s = glint::DeviceEngine::Create(options, &engine);
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  // Median seconds of `repeat` timed runs after one untimed (compile + warm).
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
      if (!st.ok()) return false;
    }
    std::sort(t.begin(), t.end());
    *seconds = t[t.size() / 2];
    return true;
  };

  glint::v1::EvaluateRequest request = MakeRequest(q);
  std::vector<float> smooth, glint;
  double smooth_s = 0;
  if (!run(request, &smooth, &smooth_s)) return 1;
  double mean_smooth = 0;
  for (float v : smooth) mean_smooth += v;
  mean_smooth /= double(n);
  if (json) {
    std::printf(
        "{\"bench\": \"chermain\", \"model\": \"SMOOTH\", \"queries\": %u, "
        "\"evals_per_s\": %.4g}\n",
        n, n / smooth_s);
  } else {
    std::printf(
        "chermain vs smooth (Beckmann alpha 0.5), %u queries, device %s fp32 1 lane, "
        "median of %d; smooth: %.2f M evals/s\n\n",
        n, engine->info().name.c_str(), repeat, n / smooth_s / 1e6);
    std::printf(
        "| ln(rho) | dictionary | max anisotropy | evals/s | ratio to smooth | mean L / "
        "smooth |\n|---|---|---|---|---|---|\n");
  }
  auto *m = request.mutable_material();
  m->set_model(glint::v1::CHERMAIN);
  m->mutable_chermain()->set_density_randomisation(2.0f);
  for (float ld : {20.0f, 30.0f})
    for (uint32_t dict : {16u, 64u, 192u, 512u})
      for (float gamma : {4.0f, 8.0f, 16.0f}) {
        if (ld != 20.0f && dict != 192u) continue;
        m->mutable_chermain()->set_log_density(ld);
        m->mutable_chermain()->set_dictionary_size(dict);
        m->mutable_chermain()->set_max_anisotropy(gamma);
        double sec = 0;
        if (!run(request, &glint, &sec)) return 1;
        double mean = 0;
        for (float v : glint) mean += v;
        mean /= double(n);
        if (json) {
          std::printf(
              "{\"bench\": \"chermain\", \"model\": \"CHERMAIN\", \"queries\": %u, "
              "\"log_density\": %g, \"dictionary_size\": %u, \"max_anisotropy\": %g, "
              "\"evals_per_s\": %.4g, \"ratio_to_smooth\": %.4g, "
              "\"mean_over_smooth\": %.4g}\n",
              n, ld, dict, gamma, n / sec, smooth_s / sec, mean / mean_smooth);
        } else {
          std::printf("| %g | %u | %g | %.3f M | %.3f | %.3f |\n", ld, dict, gamma, n / sec / 1e6,
                      smooth_s / sec, mean / mean_smooth);
        }
      }

  // A quad light (polygon pass, LTC) in place of the sun: the smooth model against CHERMAIN
  // (chermain_polygons.h: the smooth integral times the glint ratio at one direction).
  glint::v1::EvaluateRequest lit = MakeRequest(q);
  lit.clear_lights();
  auto *quad = lit.add_lights()->mutable_polygon();
  for (float v : {-1.5f, -0.5f, 2.0f, -1.5f, 0.5f, 2.0f, -0.5f, 0.5f, 2.0f, -0.5f, -0.5f, 2.0f})
    quad->add_vertices(v);
  for (float v : {1.0f, 1.0f, 1.0f}) quad->add_radiance(v);
  quad->set_two_sided(true);
  double smooth_quad_s = 0;
  if (!run(lit, &smooth, &smooth_quad_s)) return 1;
  double mean_smooth_quad = 0;
  for (float v : smooth) mean_smooth_quad += v;
  mean_smooth_quad /= double(n);
  auto *mq = lit.mutable_material();
  mq->set_model(glint::v1::CHERMAIN);
  mq->mutable_chermain()->set_density_randomisation(2.0f);
  mq->mutable_chermain()->set_log_density(20.0f);
  mq->mutable_chermain()->set_dictionary_size(192);
  mq->mutable_chermain()->set_max_anisotropy(8.0f);
  double quad_s = 0;
  if (!run(lit, &glint, &quad_s)) return 1;
  double mean_quad = 0;
  for (float v : glint) mean_quad += v;
  mean_quad /= double(n);
  if (json) {
    std::printf(
        "{\"bench\": \"chermain\", \"light\": \"quad\", \"smooth_evals_per_s\": %.4g, "
        "\"evals_per_s\": %.4g, \"ratio_to_smooth\": %.4g, \"mean_over_smooth\": %.4g}\n",
        n / smooth_quad_s, n / quad_s, smooth_quad_s / quad_s, mean_quad / mean_smooth_quad);
  } else {
    std::printf(
        "\nquad light (LTC) instead of the sun, ln(rho) 20, N = 192, max anisotropy 8: smooth "
        "%.3f M evals/s, CHERMAIN %.3f M evals/s (ratio %.3f), mean L / smooth %.3f\n",
        n / smooth_quad_s / 1e6, n / quad_s / 1e6, smooth_quad_s / quad_s,
        mean_quad / mean_smooth_quad);
  }
  return 0;
}
