// Calibration of the admission cost (server/request_cost.h): for request shapes that span the
// cost model (probe, point lights, polygons by every area method, the glint models), the
// estimated units per query, the device time per query and the ns per unit. The weights in
// request_cost.cpp and the models' cost_factor hooks are chosen so that ns per unit stays
// within a small factor across shapes; the slice sizing (server/sliced_eval.h) divides by the
// units per ms printed at the end.
//
//   cmake --build build --target bench_request_cost
//   build/bench/bench_request_cost [--json]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/model_table.h"
#include "server/request_cost.h"
#include "server/validation.h"
#include "test_queries.h"

namespace {

using Clock = std::chrono::steady_clock;
namespace v1 = glint::v1;

struct Shape {
  std::string name;
  v1::EvaluateRequest request;  // settings only
};

v1::EvaluateRequest Base(v1::Model model) {
  v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(model);
  m->set_ndf(model == v1::CHERMAIN ? v1::BECKMANN : v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.3f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  v1::QueryBatch unused;
  if (const glint::Model *spec = glint::FindModel(model); spec && spec->example)
    spec->example(m, &unused);
  r.set_seed(7);
  return r;
}

void AddPoint(v1::EvaluateRequest *r) {
  auto *p = r->add_lights()->mutable_point();
  for (float v : {-1.0f, 2.0f, 3.0f}) p->add_position(v);
  for (float v : {5.0f, 5.0f, 4.0f}) p->add_intensity(v);
  p->set_radius(0.1f);
}

void AddPolygon(v1::EvaluateRequest *r, int vertices) {
  auto *p = r->add_lights()->mutable_polygon();
  for (int k = 0; k < vertices; ++k) {  // a regular polygon overhead, counter-clockwise from below
    const double t = -2.0 * 3.14159265358979 * k / vertices;
    for (double c : {2.0 * std::cos(t), 2.0 * std::sin(t), 3.0}) p->add_vertices(float(c));
  }
  for (float v : {1.0f, 1.0f, 1.0f}) p->add_radiance(v);
  p->set_two_sided(true);
}

std::vector<Shape> Shapes() {
  std::vector<Shape> s;
  s.push_back({"SMOOTH probe", Base(v1::SMOOTH)});
  {
    Shape x{"SMOOTH 4 point lights", Base(v1::SMOOTH)};
    for (int k = 0; k < 4; ++k) AddPoint(&x.request);
    s.push_back(x);
  }
  for (int v : {4, 16}) {
    for (v1::AreaMethod m : {v1::LTC, v1::LECOCQ, v1::LECOCQ_PEARSON}) {
      Shape x{"SMOOTH " + std::to_string(v) + "-gon " + v1::AreaMethod_Name(m), Base(v1::SMOOTH)};
      AddPolygon(&x.request, v);
      x.request.set_area_method(m);
      s.push_back(x);
    }
  }
  for (uint32_t n : {16u, 64u, 256u}) {
    Shape x{"SMOOTH quad MONTE_CARLO " + std::to_string(n), Base(v1::SMOOTH)};
    AddPolygon(&x.request, 4);
    x.request.set_area_method(v1::MONTE_CARLO);
    x.request.set_area_samples(n);
    s.push_back(x);
  }
  for (auto [v, n] : {std::pair{4, 8u}, {4, 32u}, {4, 128u}, {16, 32u}}) {
    Shape x{"SMOOTH " + std::to_string(v) + "-gon REFERENCE " + std::to_string(n),
            Base(v1::SMOOTH)};
    AddPolygon(&x.request, v);
    x.request.set_area_method(v1::REFERENCE);
    x.request.set_area_samples(n);
    s.push_back(x);
  }
  for (v1::Model model : {v1::BINOMIAL, v1::CHERMAIN, v1::KEMPPINEN}) {
    const std::string name = v1::Model_Name(model);
    Shape point{name + " 4 point lights", Base(model)};
    for (int k = 0; k < 4; ++k) AddPoint(&point.request);
    s.push_back(point);
    Shape quad{name + " quad LTC", Base(model)};
    AddPolygon(&quad.request, 4);
    s.push_back(quad);
  }
  // The polygon pass per neighbourhood (session 20: it honours material.kemppinen.neighborhood;
  // Model::polygon_cost in kemppinen_model.cpp).
  for (auto [hood, hood_name] : {std::pair{v1::KEMPPINEN_ONE_LEVEL, "ONE_LEVEL"},
                                 std::pair{v1::KEMPPINEN_ONE_CELL, "ONE_CELL"}}) {
    Shape quad{std::string("KEMPPINEN ") + hood_name + " quad LTC", Base(v1::KEMPPINEN)};
    quad.request.mutable_material()->mutable_kemppinen()->set_neighborhood(hood);
    AddPolygon(&quad.request, 4);
    s.push_back(quad);
  }
  {
    Shape x{"KEMPPINEN k=16 4 point lights", Base(v1::KEMPPINEN)};
    x.request.mutable_material()->mutable_kemppinen()->set_neighbors(16);
    for (int k = 0; k < 4; ++k) AddPoint(&x.request);
    s.push_back(x);
  }
  return s;
}

}  // namespace

int main(int argc, char **argv) {
  const bool json = argc > 1 && std::string(argv[1]) == "--json";
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::unique_ptr<glint::DeviceEngine> engine;
  glint::DeviceEngineOptions options;
  options.workers = 1;
  if (const char *d = std::getenv("GLINT_CACHE_DIR")) options.cache_dir = d;
  glint::Status s = glint::DeviceEngine::Create(options, &engine);
  if (!s.ok()) {
    std::fprintf(stderr, "bench_request_cost: %s\n", s.message().c_str());
    return 1;
  }
  if (!json) {
    std::printf("| shape | units/query | queries | ms | ns/query | ns/unit |\n");
    std::printf("| --- | ---: | ---: | ---: | ---: | ---: |\n");
  }
  std::vector<double> ns_per_unit;
  for (Shape &shape : Shapes()) {
    if (glint::Status v = glint::ValidateSettings(shape.request, glint::ValidationLimits());
        !v.ok()) {  // e.g. CHERMAIN refuses polygon lights
      if (!json)
        std::printf("| %s | refused: %s | | | | |\n", shape.name.c_str(), v.message().c_str());
      continue;
    }
    const glint::RequestCost unit = glint::EstimateRequestCost(shape.request, 1);
    // Timed on 256 queries first, then on as many as take about 200 ms (at most 1M).
    const bool probe = shape.request.lights_size() == 0;
    auto time = [&](uint32_t count, double *ms) -> glint::Status {
      v1::QueryBatch q = glint::test::RandomQueries(count, probe, false, 42);
      const glint::EvalPlan plan = glint::MakeEvalPlan(shape.request, q);
      std::vector<float> out(size_t(count) * 3);
      glint::Status st = engine->Evaluate(0, plan, q, out.data());  // compile + warm
      *ms = 1e30;
      for (int r = 0; st.ok() && r < 2; ++r) {
        const auto t0 = Clock::now();
        st = engine->Evaluate(0, plan, q, out.data());
        *ms = std::min(*ms, std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      }
      return st;
    };
    double best = 0;
    s = time(256, &best);
    uint32_t n = 256;
    if (s.ok()) {
      n = uint32_t(std::clamp(256.0 * 200.0 / std::max(best, 1e-3), 256.0, 1048576.0));
      if (n > 256) s = time(n, &best);
    }
    if (!s.ok()) {
      std::fprintf(stderr, "%s: %s\n", shape.name.c_str(), s.message().c_str());
      return 1;
    }
    const double ns_query = best * 1e6 / n, ns_unit = ns_query / unit.per_query;
    ns_per_unit.push_back(ns_unit);
    if (json)
      std::printf(
          "{\"shape\": \"%s\", \"units_per_query\": %.4g, \"queries\": %u, \"ms\": %.3f, "
          "\"ns_per_query\": %.4g, \"ns_per_unit\": %.4g}\n",
          shape.name.c_str(), unit.per_query, n, best, ns_query, ns_unit);
    else
      std::printf("| %s | %.4g | %u | %.1f | %.4g | %.3g |\n", shape.name.c_str(), unit.per_query,
                  n, best, ns_query, ns_unit);
  }
  std::sort(ns_per_unit.begin(), ns_per_unit.end());
  std::printf("ns per unit: min %.3g median %.3g max %.3g (whole device, %u compute units)\n",
              ns_per_unit.front(), ns_per_unit[ns_per_unit.size() / 2], ns_per_unit.back(),
              engine->info().compute_units);
  return 0;
}
