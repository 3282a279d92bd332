#include "server/request_cost.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "server/model_table.h"

namespace glint {
namespace {

// The unit is one BRDF evaluation inside REFERENCE's quadrature loop, ~50 ns on the 2-core PoCL
// device under load (bench/bench_request_cost.cpp: 45-69 ns per node). The other weights are
// that run's time per query over 50 ns, rounded up:
// LTC: ~1.0 us per quad, ~3.1 us per 16-gon: ~5 units per vertex.
constexpr double kLtcPerVertex = 5.0;
// Lecocq's adaptive peak fit: ~90 us (quad) to ~112 us (16-gon) per polygon; with the Pearson
// term ~119 to ~147 us.
constexpr double kLecocqBase = 1600.0, kLecocqPerVertex = 40.0;
constexpr double kLecocqPearsonBase = 2200.0, kLecocqPearsonPerVertex = 50.0;
// MONTE_CARLO: ~560 ns per sample (MIS: a light sample and a lobe sample, each a BRDF
// evaluation plus sampling).
constexpr double kMonteCarloPerSample = 11.0;
// A point or directional light, or a probe: one BRDF evaluation (SIMD code: an over-estimate).
constexpr double kPunctual = 1.0;
// Per-query overhead (loads, frame, store), in units.
constexpr double kPerQuery = 1.0;
// The most a model's factor multiplies a polygon light by (see EstimateRequestCost).
constexpr double kPolygonFactor = 8.0;

std::string Format(double x, int digits = 3) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, x);
  return buf;
}

// A limit as the operator gave it: the fewest significant digits (at least 3) that read back as
// the limit itself ("1e+03", "2.5e+07", "1234").
std::string FormatLimit(double limit) {
  int digits = 3;
  while (digits < 17 && std::strtod(Format(limit, digits).c_str(), nullptr) != limit) ++digits;
  return Format(limit, digits);
}

// A cost over `limit`, with enough significant digits (at least 3) that it reads back as more
// than the limit: at 3 digits a cost of 1004 against --max-request-cost 1000 printed
// "request cost: 1e+03 ... exceeds --max-request-cost 1e+03". 17 digits read back as the cost
// itself, so the loop ends by then.
std::string FormatOver(double cost, double limit) {
  int digits = 3;
  while (digits < 17 && std::strtod(Format(cost, digits).c_str(), nullptr) <= limit) ++digits;
  return Format(cost, digits);
}

// REFERENCE: (4 ceil(samples / 4))^2 Gauss-Legendre nodes per fan triangle
// (kernels/area/area_lights.h, area_reference_polygon); clipping to the horizon adds at most
// one vertex to a convex polygon, so at most (vertices - 1) triangles.
double ReferenceCost(int vertices, uint32_t samples) {
  const double nodes = 4.0 * double((samples + 3) / 4 > 0 ? (samples + 3) / 4 : 1);
  return nodes * nodes * double(std::max(1, vertices - 1));
}

}  // namespace

RequestCost EstimateRequestCost(const glint::v1::EvaluateRequest &settings, uint64_t query_count) {
  RequestCost c;
  const uint32_t samples = settings.area_samples() ? settings.area_samples() : 64;
  const glint::v1::AreaMethod method = settings.area_method() == glint::v1::AREA_METHOD_UNSPECIFIED
                                           ? glint::v1::LTC
                                           : settings.area_method();
  double punctual_cost = 0, polygon_cost = 0;
  int punctual = 0, polygons = 0, max_vertices = 0;
  for (const glint::v1::Light &light : settings.lights()) {
    if (!light.has_polygon()) {
      ++punctual;
      punctual_cost += kPunctual;
      continue;
    }
    ++polygons;
    const int v = light.polygon().vertices_size() / 3;
    max_vertices = std::max(max_vertices, v);
    switch (method) {
      case glint::v1::REFERENCE:
        polygon_cost += ReferenceCost(v, samples);
        break;
      case glint::v1::MONTE_CARLO:
        polygon_cost += kMonteCarloPerSample * double(samples);
        break;
      case glint::v1::LECOCQ:
        polygon_cost += kLecocqBase + kLecocqPerVertex * v;
        break;
      case glint::v1::LECOCQ_PEARSON:
        polygon_cost += kLecocqPearsonBase + kLecocqPearsonPerVertex * v;
        break;
      case glint::v1::AUTO:
        // The dearest it may pick (kernels/area/area_auto.h): REFERENCE 32, MONTE_CARLO 1024
        // or LECOCQ_PEARSON; admission bounds the worst case, not the likely one.
        polygon_cost += std::max({ReferenceCost(v, 32), kMonteCarloPerSample * 1024.0,
                                  kLecocqPearsonBase + kLecocqPearsonPerVertex * v});
        break;
      default:
        polygon_cost += kLtcPerVertex * v;
        break;
    }
  }
  if (settings.lights_size() == 0) punctual_cost = kPunctual;  // a BRDF probe
  const Model *model = FindModel(settings.material().model());
  const double factor =
      model && model->cost_factor ? std::max(1.0, model->cost_factor(settings.material())) : 1.0;
  // The model's factor multiplies its own per-light work (a probe, point and directional
  // lights); a polygon light is the smooth area integral plus that work once, measured at 6-7x
  // the smooth LTC cost for BINOMIAL, so polygons take at most kPolygonFactor.
  // A model whose polygon work was measured on its own (Model::polygon_cost) adds it per polygon
  // light to the smooth area integral instead.
  const double polygon_part =
      model && model->polygon_cost
          ? polygon_cost + double(polygons) * model->polygon_cost(settings.material())
          : std::min(factor, kPolygonFactor) * polygon_cost;
  c.per_query = kPerQuery + factor * punctual_cost + polygon_part;
  c.total = c.per_query * double(query_count);

  std::string parts;
  if (settings.lights_size() == 0) parts = "probe";
  if (punctual) parts = std::to_string(punctual) + " point/directional lights";
  if (polygons) {
    if (!parts.empty()) parts += " + ";
    parts += std::to_string(polygons) + " polygon lights (up to " + std::to_string(max_vertices) +
             " vertices) by ";
    if (model && model->polygon_method) {
      // The model's own integrator: naming area_method would tell the client to change a
      // field the model ignores.
      parts += model->polygon_method(settings);
    } else {
      parts += glint::v1::AreaMethod_Name(method);
      if (method == glint::v1::REFERENCE) parts += " " + std::to_string(samples) + " nodes";
      if (method == glint::v1::MONTE_CARLO) parts += " " + std::to_string(samples) + " samples";
    }
  }
  c.lights_part = parts;
  if (factor != 1.0) parts += " x " + std::string(model->name) + " factor " + Format(factor);
  c.parts = parts;
  return c;
}

RequestCost EstimateQueriesCost(const glint::v1::EvaluateRequest &settings,
                                const glint::v1::QueryBatch &queries, uint64_t first_query) {
  RequestCost c = EstimateRequestCost(settings, queries.count());
  // A model whose work depends on each query counts it from the queries: the most expensive
  // query bounds the slice, the sum is the request's.
  const Model *model = FindModel(settings.material().model());
  double max_units = 0, sum_units = 0;
  std::string counted;
  if (model && model->query_costs && queries.count() > 0 &&
      model->query_costs(settings, queries, first_query, &max_units, &sum_units, &counted)) {
    c.per_query = max_units;
    c.total = sum_units;
    c.counted_per_query = true;
    c.parts = c.lights_part + " x " + model->name + ": " + counted;
    c.query_remedy =
        "use smaller footprints, fewer lights, polygon lights or area_samples, or cheaper "
        "material settings (the work per query grows with its footprint)";
  }
  return c;
}

RequestCost EstimateSampleCost(const glint::v1::EvaluateRequest &settings,
                               uint32_t samples_per_query, uint64_t query_count) {
  glint::v1::EvaluateRequest probe;  // the material alone: one evaluation of the model
  *probe.mutable_material() = settings.material();
  // KEMPPINEN's sampler draws and weighs by the paper's neighbourhood whatever
  // material.kemppinen.neighborhood says (kemppinen_sample.h: only f follows the setting), so a
  // sample costs at least a paper evaluation. The cheaper neighbourhoods' evaluation factors
  // (2x and, at k = 4, 4.4x below the paper's) would under-charge it: bench_sample with the
  // neighbourhoods added, k = 4, loaded, 2026-12-01: PAPER 0.35-0.39 M samples/s, ONE_LEVEL
  // 0.45-0.50 M (1.3x), ONE_CELL 0.53-0.62 M (1.5-1.7x).
  if (probe.material().has_kemppinen())
    probe.mutable_material()->mutable_kemppinen()->clear_neighborhood();
  const RequestCost one = EstimateRequestCost(probe, 1);
  RequestCost c;
  c.per_query = one.per_query * double(samples_per_query);
  c.total = c.per_query * double(query_count);
  c.parts = std::to_string(samples_per_query) + " samples_per_query x " + Format(one.per_query) +
            " per sample (one evaluation: " + one.parts + ")";
  c.query_remedy = "use fewer samples_per_query (a query's samples run in one slice)";
  c.request_remedy = "split the queries over several calls, or use fewer samples_per_query";
  return c;
}

RequestCost EstimateSampleCost(const glint::v1::EvaluateRequest &settings,
                               uint32_t samples_per_query, const glint::v1::QueryBatch &queries) {
  RequestCost c = EstimateSampleCost(settings, samples_per_query, queries.count());
  const Model *model = FindModel(settings.material().model());
  if (!model || !model->query_costs) return c;
  glint::v1::EvaluateRequest probe;  // a sample costs one probe of its query (see above)
  *probe.mutable_material() = settings.material();
  const RequestCost probes = EstimateQueriesCost(probe, queries);
  if (!probes.counted_per_query) return c;  // the model could not count these queries
  c.per_query = probes.per_query * double(samples_per_query);
  c.total = probes.total * double(samples_per_query);
  c.parts = std::to_string(samples_per_query) + " samples_per_query x up to " +
            Format(probes.per_query) + " per sample (one evaluation: " + probes.parts + ")";
  c.query_remedy =
      "use fewer samples_per_query or smaller footprints (a query's samples run in one slice, "
      "and the work per sample grows with its footprint)";
  return c;
}

Status CheckRequestCost(const RequestCost &cost, uint64_t query_count, const CostLimits &limits) {
  const bool query_over = cost.per_query > limits.max_query_cost;
  // The per-query cost reads the same in the headline and in the parts.
  const std::string per_query =
      query_over ? FormatOver(cost.per_query, limits.max_query_cost) : Format(cost.per_query);
  std::string what = "(";  // built by appending: GCC 12 warns falsely on "(" + std::string
  what += std::to_string(query_count);
  what += " queries x " + per_query + " per query: " + cost.parts + ")";
  if (query_over) {
    return Status::ResourceExhausted(
        "request cost: " + per_query + " BRDF evaluations per query " + what +
        " exceeds --max-query-cost " + FormatLimit(limits.max_query_cost) +
        " (a query is the smallest interruptible piece of work); " +
        (cost.query_remedy.empty() ? "use fewer or simpler polygon lights, fewer area_samples "
                                     "or a cheaper area_method"
                                   : cost.query_remedy));
  }
  if (cost.total > limits.max_request_cost) {
    return Status::ResourceExhausted(
        "request cost: " + FormatOver(cost.total, limits.max_request_cost) + " BRDF evaluations " +
        what + " exceeds --max-request-cost " + FormatLimit(limits.max_request_cost) + "; " +
        (cost.request_remedy.empty() ? "split the batch into smaller requests or stream chunks, "
                                       "or use a cheaper area_method"
                                     : cost.request_remedy));
  }
  return Status::Ok();
}

}  // namespace glint
