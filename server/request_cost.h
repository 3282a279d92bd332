// Admission-time cost of a request, before any device work: queries x (what one query costs:
// its lights x each light's integration method) x the model's factor, in units of one smooth
// BRDF evaluation f(wi, wo) cos(theta_i) on the device. glintd refuses a request (or a stream
// chunk) whose total exceeds --max-request-cost, or one query of which exceeds --max-query-cost
// (a query is the smallest piece of work the engine can interrupt between; see
// server/sliced_eval.h), with RESOURCE_EXHAUSTED naming the cost, its parts and the limit; the
// engine sizes its query slices from the per-query cost.
//
// The per-light weights are counts of BRDF evaluations where the method has them (REFERENCE:
// nodes; MONTE_CARLO: samples, each one light-sample and one lobe-sample evaluation) and, for
// the closed-form methods, their measured time relative to one evaluation on PoCL's CPU device
// (bench/bench_request_cost.cpp prints ns per unit for every shape; the weights keep it within
// a small factor across shapes). They bound work, they do not predict it to the millisecond.
#pragma once

#include <cstdint>
#include <string>

#include "glint/v1/glint.pb.h"
#include "server/status.h"

namespace glint {

struct RequestCost {
  double per_query = 0;  // units for one query
  double total = 0;      // per_query x queries
  std::string parts;     // e.g. "3 polygon lights (REFERENCE 1024 nodes) x BINOMIAL factor 3"
  // What the refusal advises (empty: Evaluate's advice on lights, area_samples, area_method).
  std::string query_remedy, request_remedy;
  // The lights and how they are integrated, without the model's part (e.g. "1 polygon lights (up
  // to 4 vertices) by LTC").
  std::string lights_part;
  // Whether the model counted each query (Model::query_costs), not its material-only estimate.
  bool counted_per_query = false;
};

struct CostLimits {
  // 1e11 units: ~1.4 h of the 2-core PoCL device under load (~50 ns per unit): a bound on
  // runaway work, not a quota. Admits every example material x light list as a 512x512 preview
  // by LTC, LECOCQ or REFERENCE at the default 64 nodes and at 1M queries by LTC, and 1M probes
  // (2e6); refuses the 1M queries x 64 sixteen-vertex polygons x REFERENCE 1024 nodes
  // (1e15).
  double max_request_cost = 1e11;
  // 1e7 units: ~0.5 s of the device, ~1 s of one core (a single query runs on one). A query
  // cannot be split, so this bounds how long cancellation, deadlines and shutdown wait for the
  // slice in progress. Admits 64 sixteen-vertex polygons by REFERENCE at the default 64 nodes
  // (3.9e6) or a quad at 1024 nodes (3.1e6); refuses 64 sixteen-vertex polygons at 1024 (1e9).
  double max_query_cost = 1e7;
};

// The cost of evaluating `query_count` queries with `settings` (a request that passed
// ValidateSettings: known model, at most max_lights lights, area_samples <= 1024) from the
// settings alone: the model's material-only estimate (Model::cost_factor, polygon_cost).
// settings.queries() is not read. For a model whose cost depends on each query
// (Model::query_costs) this is only a guess; glintd admits and slices every request it holds
// the queries of with EstimateQueriesCost instead.
RequestCost EstimateRequestCost(const glint::v1::EvaluateRequest &settings, uint64_t query_count);

// THE per-query cost of evaluating `queries` with `settings` (its material, lights, area
// method; settings.queries() is not read, so a stream's settings serve every chunk). Every path
// that holds the queries admits and slices by it: unary Evaluate, each stream chunk, each
// member of a dynamic batch, shared-memory queries once copied out of the region, and (through
// EstimateSampleCost) the Sample RPC. A model with Model::query_costs (NORMAL_MAP: the
// footprint's cut-off box) counts each query: per_query is the dearest query's (it bounds a
// slice), total the sum; the refusal names the dearest query as `first_query` + its index (its
// place in the stream). Other models: EstimateRequestCost(settings, queries.count()).
RequestCost EstimateQueriesCost(const glint::v1::EvaluateRequest &settings,
                                const glint::v1::QueryBatch &queries, uint64_t first_query = 0);

// The cost of a Sample request (server/sample.h) of `query_count` queries with
// `samples_per_query` samples each; `settings` holds its material (a request that passed
// ValidateSampleSettings). Every model's sampler evaluates the model once per sample (models/
// */*_sample.h: SMOOTH, KEMPPINEN and CHERMAIN weight a sample by f cos_i / pdf with the model's
// f; NORMAL_MAP's pdf is its P-NDF D(s), the dominant cost of f), so one sample costs what a BRDF
// probe query does, and a query K times that: its K samples run in the same slice. KEMPPINEN's
// is charged at the paper's neighbourhood whatever material.kemppinen.neighborhood says (its
// sampler's pdf runs the paper's).
RequestCost EstimateSampleCost(const glint::v1::EvaluateRequest &settings,
                               uint32_t samples_per_query, uint64_t query_count);
// The same for the Sample request's own `queries`: one sample of query i costs what a BRDF probe
// of query i does (EstimateQueriesCost of the material alone), so NORMAL_MAP is charged by each
// query's footprint; per_query is the dearest query's K samples.
RequestCost EstimateSampleCost(const glint::v1::EvaluateRequest &settings,
                               uint32_t samples_per_query, const glint::v1::QueryBatch &queries);

// OK, or RESOURCE_EXHAUSTED: "request cost 9.4e+17 (1048576 queries x 9.0e+11 per query: ...)
// exceeds --max-request-cost 1e+11; ...".
Status CheckRequestCost(const RequestCost &cost, uint64_t query_count, const CostLimits &limits);

}  // namespace glint
