// NORMAL_MAP (Yan et al. 2014) throughput on the OpenCL device (DeviceEngine, fp32) against the
// footprint size, the cut-off and the subdivision, on a generated bumpy map (tools/normal_map,
// 512 x 512, RMS slope 0.2, sigma_r 0.02), with the smooth model (GGX alpha 0.2) on the same
// queries as the yardstick. Queries: random uv, random view within 60 degrees of the normal,
// isotropic footprints of standard deviation `sigma_texels` texels (G_p = 0.5 px J J^T, so
// |J| = 2 sigma / 512), one directional light. Median of --repeat runs; --json: one JSON object
// per row. A second table: polygon lights (a square light) against footprint and area_samples.
//
//   cmake --build build --target bench_normal_map && build/bench/bench_normal_map
//   [--queries N] [--repeat R] [--json]                             (defaults 20000, 3)
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
#include "server/normal_map_store.h"
#include "tools/normal_map/normal_map_gen.h"

namespace {

using Clock = std::chrono::steady_clock;
constexpr uint32_t kMapSize = 512;

glint::v1::QueryBatch Queries(uint32_t n, double sigma_texels) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  glint::v1::QueryBatch q;
  q.set_count(n);
  const float j = float(2.0 * sigma_texels / kMapSize);  // sigma = 0.5 px |J| W
  for (uint32_t i = 0; i < n; ++i) {
    q.add_uv(u(rng));
    q.add_uv(u(rng));
    for (float f : {j, 0.0f, 0.0f, j}) q.add_footprint(f);
    const float t = 1.05f * u(rng), p = 6.2832f * u(rng);
    for (float v : {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)}) q.add_wo(v);
  }
  return q;
}

}  // namespace

int main(int argc, char **argv) {
  uint32_t n = 20000;
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
      std::fprintf(stderr, "usage: bench_normal_map [--queries N] [--repeat R] [--json]\n");
      return 2;
    }
  }
  glint::DecodedNormalMap map;
  std::string error;
  if (!glint::normal_map_gen::Generate({"bumpy", kMapSize, 1, 0.2}, &map, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  glint::v1::NormalMapInfo info;
  if (glint::Status st = glint::NormalMaps().Insert("bench bumpy", map, &info); !st.ok()) {
    std::fprintf(stderr, "%s\n", st.message().c_str());
    return 1;
  }
  std::unique_ptr<glint::DeviceEngine> engine;
  glint::DeviceEngineOptions options;
  options.workers = 1;
  if (glint::Status s = glint::DeviceEngine::Create(options, &engine); !s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  auto run = [&](const glint::v1::EvaluateRequest &request, double *seconds) -> bool {
    glint::EvalPlan plan = glint::MakeEvalPlan(request, request.queries());
    if (glint::Status st = glint::ResolveRequestTable(request.material(), &plan); !st.ok()) {
      std::fprintf(stderr, "%s\n", st.message().c_str());
      return false;
    }
    std::vector<float> out(size_t(3) * n);
    glint::Status st = engine->Evaluate(0, plan, request.queries(), out.data());
    if (!st.ok()) {
      std::fprintf(stderr, "%s\n", st.message().c_str());
      return false;
    }
    std::vector<double> t;
    for (int r = 0; r < repeat; ++r) {
      auto t0 = Clock::now();
      st = engine->Evaluate(0, plan, request.queries(), out.data());
      t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
      if (!st.ok()) return false;
    }
    std::sort(t.begin(), t.end());
    *seconds = t[t.size() / 2];
    return true;
  };
  auto request_for = [&](double sigma_texels) {
    glint::v1::EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(glint::v1::SMOOTH);
    m->set_ndf(glint::v1::GGX);
    m->set_alpha_x(0.2f);
    m->set_alpha_y(0.2f);
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
    auto *d = r.add_lights()->mutable_directional();
    for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
    for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
    *r.mutable_queries() = Queries(n, sigma_texels);
    return r;
  };
  double smooth_s = 0;
  if (!run(request_for(1.0), &smooth_s)) return 1;
  if (json) {
    std::printf(
        "{\"bench\": \"normal_map\", \"model\": \"SMOOTH\", \"queries\": %u, "
        "\"evals_per_s\": %.4g}\n",
        n, n / smooth_s);
  } else {
    std::printf(
        "NORMAL_MAP on a %ux%u bumpy map (sigma_r 0.02), %u queries, device %s fp32, "
        "1 worker, median of %d; smooth GGX: %.3f M evals/s\n\n",
        kMapSize, kMapSize, n, engine->info().name.c_str(), repeat, n / smooth_s / 1e6);
    std::printf(
        "| footprint sigma (texels) | texels in the cut-off box | cut-off | subdivision | "
        "evals/s | ratio to smooth |\n|---|---|---|---|---|---|\n");
  }
  for (double sigma : {0.25, 1.0, 4.0, 16.0})
    for (float cutoff : {3.0f, 5.0f})
      for (uint32_t sub : {1u, 4u}) {
        if (sub == 4 && cutoff != 5.0f) continue;
        glint::v1::EvaluateRequest r = request_for(sigma);
        auto *m = r.mutable_material();
        m->set_model(glint::v1::NORMAL_MAP);
        m->mutable_normal_map()->set_digest(info.digest());
        m->mutable_normal_map()->set_intrinsic_roughness(0.02f);
        m->mutable_normal_map()->set_cutoff_sigma(cutoff);
        m->mutable_normal_map()->set_subdivision(sub);
        double sec = 0;
        if (!run(r, &sec)) return 1;
        const double box = std::pow(2 * cutoff * sigma, 2);
        if (json) {
          std::printf(
              "{\"bench\": \"normal_map\", \"model\": \"NORMAL_MAP\", \"queries\": %u, "
              "\"footprint_sigma_texels\": %g, \"box_texels\": %.4g, \"cutoff\": %g, "
              "\"subdivision\": %u, \"evals_per_s\": %.4g, \"ratio_to_smooth\": %.4g}\n",
              n, sigma, box, cutoff, sub, n / sec, smooth_s / sec);
        } else {
          std::printf("| %g | %.3g | %g | %u | %.4g | %.3g |\n", sigma, box, cutoff, sub, n / sec,
                      smooth_s / sec);
        }
        std::fflush(stdout);
      }
  // Polygon lights (models/normal_map/normal_map_polygons.h): a square light of about 40 degrees
  // overhead, two-sided, integrated by MIS of light and P-NDF sampling with `area_samples`
  // samples per technique; each light sample and each P-NDF sample that hits costs one P-NDF
  // evaluation.
  if (!json)
    std::printf(
        "\n| footprint sigma (texels) | cut-off | light | area_samples | evals/s | ratio to smooth "
        "|\n|---|---|---|---|---|---|\n");
  for (double sigma : {0.25, 1.0, 4.0})
    for (uint32_t samples : {4u, 16u, 64u}) {
      glint::v1::EvaluateRequest r = request_for(sigma);
      r.clear_lights();
      auto *p = r.add_lights()->mutable_polygon();
      for (float v :
           {-0.75f, -0.75f, 2.0f, 0.75f, -0.75f, 2.0f, 0.75f, 0.75f, 2.0f, -0.75f, 0.75f, 2.0f})
        p->add_vertices(v);
      for (float v : {1.0f, 1.0f, 1.0f}) p->add_radiance(v);
      p->set_two_sided(true);
      r.set_area_samples(samples);
      auto *m = r.mutable_material();
      m->set_model(glint::v1::NORMAL_MAP);
      m->mutable_normal_map()->set_digest(info.digest());
      m->mutable_normal_map()->set_intrinsic_roughness(0.02f);
      m->mutable_normal_map()->set_cutoff_sigma(5.0f);
      double sec = 0;
      if (!run(r, &sec)) return 1;
      if (json) {
        std::printf(
            "{\"bench\": \"normal_map\", \"model\": \"NORMAL_MAP\", \"queries\": %u, "
            "\"footprint_sigma_texels\": %g, \"cutoff\": 5, \"light\": \"polygon\", "
            "\"area_samples\": %u, \"evals_per_s\": %.4g, \"ratio_to_smooth\": %.4g}\n",
            n, sigma, samples, n / sec, smooth_s / sec);
      } else {
        std::printf("| %g | 5 | square 40 deg | %u | %.4g | %.3g |\n", sigma, samples, n / sec,
                    smooth_s / sec);
      }
      std::fflush(stdout);
    }
  return 0;
}
