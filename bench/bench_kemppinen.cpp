// Kemppinen-model throughput on the OpenCL device (DeviceEngine, fp32, one worker; 8 queries per
// work-item for probes and directional/point lights, one for polygons) per `neighbors` k and
// density, against the smooth model on the same queries and lights (a directional light, a point
// light, with and without a polygon quad via LTC), and the mean glint
// radiance relative to the smooth one (Eq. 2 says 1 away from the disk rim) with its standard
// error (delta method on per-query RGB sums). Median of --repeat timed runs after one warm run.
//
//   cmake --build build --target bench_kemppinen
//   build/bench/bench_kemppinen [--queries N] [--repeat R] [--json] [--host]  (defaults 100000, 3)
// --json prints one JSON object per row instead of the markdown table; --host times the scalar
// C++ host path (HostEvaluate, one thread) instead of the device.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "test_queries.h"

namespace {

using Clock = std::chrono::steady_clock;

glint::v1::EvaluateRequest MakeRequest(const glint::v1::QueryBatch &q, bool quad) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.3f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  r.set_precision(glint::v1::FP32);
  r.set_seed(0x9e3779b97f4aull);
  auto *d = r.add_lights()->mutable_directional();
  for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
  for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
  auto *pt = r.add_lights()->mutable_point();
  for (float v : {-1.0f, 2.0f, 3.0f}) pt->add_position(v);
  for (float v : {5.0f, 5.0f, 4.0f}) pt->add_intensity(v);
  if (quad) {
    auto *p = r.add_lights()->mutable_polygon();
    for (float v : {-3.0f, -3.0f, 3.0f, 3.0f, -3.0f, 3.0f, 3.0f, 3.0f, 3.0f, -3.0f, 3.0f, 3.0f})
      p->add_vertices(v);
    for (float v : {1.0f, 0.5f, 0.25f}) p->add_radiance(v);
    p->set_two_sided(true);
  }
  *r.mutable_queries() = q;
  return r;
}

}  // namespace

int main(int argc, char **argv) {
  uint32_t n = 100000;
  int repeat = 3;
  bool json = false, host = false;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--queries" && i + 1 < argc)
      n = uint32_t(std::stoul(argv[++i]));
    else if (a == "--repeat" && i + 1 < argc)
      repeat = std::stoi(argv[++i]);
    else if (a == "--json")
      json = true;
    else if (a == "--host")
      host = true;
    else {
      std::fprintf(stderr, "usage: bench_kemppinen [--queries N] [--repeat R] [--json] [--host]\n");
      return 2;
    }
  }
  const glint::v1::QueryBatch q = glint::test::RandomQueries(n, false, false, 42);

  std::unique_ptr<glint::DeviceEngine> engine;
  glint::DeviceEngineOptions options;
  options.workers = 1;
  glint::Status s = glint::DeviceEngine::Create(options, &engine);
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  auto run = [&](const glint::v1::EvaluateRequest &request, std::vector<float> *out,
                 double *seconds) -> bool {
    const glint::EvalPlan plan = glint::MakeEvalPlan(request, request.queries());
    out->assign(size_t(3) * n, 0.0f);
    if (host) {  // the scalar C++ path on this thread: the baseline
      std::vector<double> t;
      for (int r = 0; r < repeat; ++r) {
        auto t0 = Clock::now();
        glint::HostEvaluate(plan, request.queries(), out->data());
        t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
      }
      std::sort(t.begin(), t.end());
      *seconds = t[t.size() / 2];
      return true;
    }
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

  if (!json) {
    std::printf(
        "kemppinen vs smooth, %u queries (local frame, GGX alpha 0.3, directional + point "
        "lights, with and without a polygon quad via LTC), %s fp32, median of %d\n\n",
        n, host ? "host path (one thread)" : engine->info().name.c_str(), repeat);
    std::printf("| lights | density | k | evals/s | ratio to smooth | mean / smooth - 1 | se |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
  }
  for (bool quad : {true, false}) {
    const char *lights = quad ? "dir + point + quad" : "dir + point";
    glint::v1::EvaluateRequest request = MakeRequest(q, quad);
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
    if (json) {
      std::printf(
          "{\"model\": \"SMOOTH\", \"lights\": \"%s\", \"queries\": %u, "
          "\"evals_per_s\": %.4g}\n",
          lights, n, n / smooth_s);
    } else {
      std::printf("| %s | smooth | - | %.3f M | 1 | - | - |\n", lights, n / smooth_s / 1e6);
    }
    auto *m = request.mutable_material();
    m->set_model(glint::v1::KEMPPINEN);
    for (double density : {1e5, 1e9})
      for (uint32_t k : {1u, 4u, 9u, 16u}) {
        m->mutable_kemppinen()->set_density(density);
        m->mutable_kemppinen()->set_neighbors(k);
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
        double var = 0;
        for (uint32_t i = 0; i < n; ++i) {
          const double e = gv[i] - ratio * sv[i];
          var += e * e;
        }
        var /= (n - 1);
        const double se = std::sqrt(var / n) / mean_s;
        if (json) {
          std::printf(
              "{\"model\": \"KEMPPINEN\", \"lights\": \"%s\", \"density\": %g, "
              "\"neighbors\": %u, \"evals_per_s\": %.4g, \"ratio_to_smooth\": %.4f, "
              "\"mean_rel_error\": %.4g, \"se\": %.3g}\n",
              lights, density, k, n / sec, smooth_s / sec, ratio - 1.0, se);
        } else {
          std::printf("| %s | %.0e | %u | %.3f M | %.3f | %+.3f | %.3f |\n", lights, density, k,
                      n / sec / 1e6, smooth_s / sec, ratio - 1.0, se);
        }
      }
  }
  return 0;
}
