// NORMAL_MAP admission cost (models/normal_map/normal_map_cost.h) against device time: a flat
// map queried at its normal (probes wi = wo = n, so h = n and no cell is pruned by the normals'
// cut-off: every cell in the footprint's box is integrated, the worst case the estimate
// bounds), for footprints from one texel to the 2-period clamp, cut-off 5 and 10, subdivision 1
// and 4, and the probe's 1 x 4097 map under a polygon light. Prints the estimated units per
// query and the device's ns per unit (server/request_cost.cpp's unit is ~50 ns).
//
//   cmake --build build --target bench_normal_map_cost && build/bench/bench_normal_map_cost
//   [--json]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "models/normal_map/normal_map_cost.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/normal_map_store.h"
#include "server/request_cost.h"

namespace {

using Clock = std::chrono::steady_clock;

std::string FlatMap(uint32_t w, uint32_t h) {
  glint::DecodedNormalMap map;
  map.width = w;
  map.height = h;
  map.xyz.assign(size_t(3) * w * h, 0.0f);
  for (size_t i = 0; i < size_t(w) * h; ++i) map.xyz[3 * i + 2] = 1.0f;
  glint::v1::NormalMapInfo info;
  if (!glint::NormalMaps().Insert("flat", map, &info).ok()) return "";
  return info.digest();
}

}  // namespace

int main(int argc, char **argv) {
  const bool json = argc > 1 && std::string(argv[1]) == "--json";
  std::unique_ptr<glint::DeviceEngine> engine;
  glint::DeviceEngineOptions options;
  options.workers = 1;
  if (glint::Status s = glint::DeviceEngine::Create(options, &engine); !s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  struct Row {
    uint32_t w, h;
    double fp;  // du/dx = dv/dy
    float cutoff, sigma_r;
    int subdivision;
    bool polygon;
  };
  const Row rows[] = {
      {256, 256, 2.0 / 256, 5, 0.01f, 1, false},  {256, 256, 8.0 / 256, 5, 0.01f, 1, false},
      {256, 256, 32.0 / 256, 5, 0.01f, 1, false}, {256, 256, 8.0 / 256, 10, 0.01f, 1, false},
      {256, 256, 2.0 / 256, 5, 0.01f, 4, false},  {256, 256, 8.0 / 256, 5, 0.01f, 4, false},
      {256, 256, 1.0, 5, 0.01f, 1, false},        {1, 4097, 1.0, 10, 1e-4f, 4, false},
      {1, 4097, 1.0, 10, 1e-4f, 4, true},
  };
  if (!json)
    std::printf(
        "| map | footprint J | cutoff | subdivision | lights | cells in box | units per query "
        "| queries | device ms per query | ns per unit "
        "|\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row &row : rows) {
    glint::v1::EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(glint::v1::NORMAL_MAP);
    m->mutable_schlick()->add_f0(1.0f);
    auto *p = m->mutable_normal_map();
    p->set_digest(FlatMap(row.w, row.h));
    p->set_intrinsic_roughness(row.sigma_r);
    p->set_cutoff_sigma(row.cutoff);
    p->set_subdivision(uint32_t(row.subdivision));
    if (row.polygon) {  // the probe's quad: half-size 1e6 at z = 1, 16 + 16 MIS samples
      auto *poly = r.add_lights()->mutable_polygon();
      for (float v : {-1e6f, -1e6f, 1.0f, 1e6f, -1e6f, 1.0f, 1e6f, 1e6f, 1.0f, -1e6f, 1e6f, 1.0f})
        poly->add_vertices(v);
      for (float v : {1.0f, 1.0f, 1.0f}) poly->add_radiance(v);
      poly->set_two_sided(true);
      r.set_area_samples(16);
    }
    const float fp[4] = {float(row.fp), 0.0f, 0.0f, float(row.fp)};
    const double cells = glint::NormalMapFootprintCells(
        row.w * row.subdivision, row.h * row.subdivision, 0.5f, 0.5f, fp, row.cutoff);
    const double triangles = 2.0 * cells * (row.polygon ? 32.0 : 1.0);
    const uint32_t n = uint32_t(std::clamp(3e7 / triangles, 2.0, 2000.0));
    auto *q = r.mutable_queries();
    q->set_count(n);
    for (uint32_t i = 0; i < n; ++i) {
      for (float v : {0.5f, 0.5f}) q->add_uv(v);
      for (float v : fp) q->add_footprint(v);
      for (float v : {0.0f, 0.0f, 1.0f}) q->add_wo(v);
      if (!row.polygon)
        for (float v : {0.0f, 0.0f, 1.0f}) q->add_wi(v);
    }
    const double units = glint::EstimateQueriesCost(r, r.queries()).per_query;
    glint::EvalPlan plan = glint::MakeEvalPlan(r, r.queries());
    if (glint::Status st = glint::ResolveRequestTable(r.material(), &plan); !st.ok()) {
      std::fprintf(stderr, "%s\n", st.message().c_str());
      return 1;
    }
    std::vector<float> out(size_t(3) * n);
    if (glint::Status st = engine->Evaluate(0, plan, r.queries(), out.data()); !st.ok()) {
      std::fprintf(stderr, "%s\n", st.message().c_str());
      return 1;
    }
    const auto t0 = Clock::now();
    if (!engine->Evaluate(0, plan, r.queries(), out.data()).ok()) return 1;
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / n;
    const std::string map = std::to_string(row.w) + "x" + std::to_string(row.h);
    const char *lights = row.polygon ? "quad 16+16 MIS" : "probe";
    if (json)
      std::printf(
          "{\"bench\": \"normal_map_cost\", \"map\": \"%s\", \"footprint\": %.4g, \"cutoff\": %g, "
          "\"subdivision\": %d, \"lights\": \"%s\", \"cells\": %.6g, \"units_per_query\": %.4g, "
          "\"queries\": %u, \"ms_per_query\": %.4g, \"ns_per_unit\": %.3g}\n",
          map.c_str(), row.fp, double(row.cutoff), row.subdivision, lights, cells, units, n, ms,
          ms * 1e6 / units);
    else
      std::printf("| %s | %.4g | %g | %d | %s | %.6g | %.4g | %u | %.4g | %.3g |\n", map.c_str(),
                  row.fp, double(row.cutoff), row.subdivision, lights, cells, units, n, ms,
                  ms * 1e6 / units);
    std::fflush(stdout);
  }
  return 0;
}
