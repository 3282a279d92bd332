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
// ValidateSettings: known model, at most max_lights lights, area_samples <= 1024).
RequestCost EstimateRequestCost(const glint::v1::EvaluateRequest &settings, uint64_t query_count);

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

// OK, or RESOURCE_EXHAUSTED: "request cost 9.4e+17 (1048576 queries x 9.0e+11 per query: ...)
// exceeds --max-request-cost 1e+11; ...".
Status CheckRequestCost(const RequestCost &cost, uint64_t query_count, const CostLimits &limits);

}  // namespace glint
