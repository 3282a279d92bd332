// What bench_models (bench/bench_models.cpp) measures for a model: a ModelBenchCase registered
// from the model's file in bench/cases/ (one file per model, compiled into the driver). A case
// gives the model's base material and its quality-knob variants; the driver crosses them with
// the shared query and light sets, the paths (device, host, end_to_end) and the precisions, and
// measures throughput and the error against the case's reference. A model of the model table
// (server/model_table.h) without a case still gets rows: its Model::example material, variant
// "example", no error reference.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"

namespace glint::bench {

// The shared light sets, all in the local frame of the shading point (queries carry no frame):
//   probe              BRDF probes: each query carries wi, no lights (a delta light)
//   directional_point  one directional light (cone 0.5 deg) + one sphere light (radius 0.1)
//   quad               one two-sided 6 x 6 quad 3 above the point (2.1 sr seen from the origin)
//   four_quads         four two-sided 1 x 1 quads at several heights, tilts and offsets
enum class Lights { kProbe, kDirectionalPoint, kQuad, kFourQuads };
inline constexpr Lights kAllLights[] = {Lights::kProbe, Lights::kDirectionalPoint, Lights::kQuad,
                                        Lights::kFourQuads};
const char *LightsName(Lights l);
bool HasPolygons(Lights l);

// Facts about the shared query set a variant may use (e.g. a glint density chosen so that the
// mean footprint holds a given number of facets).
struct QueryStats {
  double mean_footprint_area = 0;  // mean |det J| of the footprints, in uv^2
};

// One quality-knob setting of a model (or an area method of the smooth model).
struct BenchVariant {
  std::string name;            // the row's `variant`, e.g. "k=4", "LTC", "MONTE_CARLO:64"
  std::vector<Lights> lights;  // the light sets it runs with; empty = every set
  bool quick = true;           // also measured with --quick
  // Sets the variant's fields on a request that already holds the case's base material,
  // the lights and the queries (material params, area_method, area_samples, ...).
  std::function<void(glint::v1::EvaluateRequest *request, const QueryStats &stats)> apply;
};

// What a row's error is measured against (error_mean, error_p95, error_max).
enum class ErrorReference {
  kNone,
  // The smooth model's own references: a probe or a directional/point light against the same
  // request in fp64 on the host path (so an fp32 row measures fp32 rounding, an fp64 device row
  // device/host agreement); polygon lights against REFERENCE quadrature in fp64 on the host path
  // with enough nodes for the material's roughness (README "Area lights").
  kExact,
  // Glint models: the relative bias of the batch-mean radiance against the smooth model with the
  // same material and lights, |mean(glint) / mean(smooth) - 1| (the glint models converge to the
  // smooth one in expectation); error_mean only, with its standard error in error_se.
  kSmoothMean,
};

struct ModelBenchCase {
  glint::v1::Model model;
  // NDF, roughness and Fresnel shared by every variant (and by the smooth reference).
  std::function<void(glint::v1::Material *m)> base;
  std::vector<BenchVariant> variants;
  ErrorReference error = ErrorReference::kNone;
  // Optional: rewrites uv and footprints of the shared queries (directions stay shared) where
  // the model's cost depends on the footprint's size in its own units, e.g. CHERMAIN's level-0
  // cells. The smooth reference of the error uses the same rewritten queries.
  std::function<void(glint::v1::QueryBatch *q)> footprints;
  // kSmoothMean: request seeds whose mean the bias is (bench_models' --error-seeds overrides).
  // One seed's standard error understates the spread where a query's radiance is rarely large
  // (BINOMIAL at N_P p << 1: models/binomial/README.md "Bias at N_P = 1e2?"); more seeds cost
  // one evaluation of the error's queries each (KEMPPINEN's four --quick four-quad rows:
  // ~40 s per extra seed at the quiet machine's rates).
  int error_seeds = 1;
  // --quick: seeds (0 = error_seeds) and, per light set, the first queries of the shared set
  // (0 or unset = all of them) behind the bias, where the case's full sample makes the error
  // evaluations most of a --quick run. The row states what it used (error_seeds,
  // error_queries) and its standard error (error_se), which grows as 1/sqrt(seeds x queries);
  // the full run keeps the full sample.
  int quick_error_seeds = 0;
  std::function<uint32_t(Lights)> quick_error_queries;
  // Optional: variants that run the same kernel work under a light set, as a key per (variant,
  // light set) ("" = its own work): the knob they differ in does not reach the pass that set
  // runs. bench_models --quick then times the first of them and reports its timing for the
  // others, each only once its radiance is verified bit-identical on every query of the timed
  // batch (bench_models.cpp Driver::SharedTiming); the full run times every row.
  std::function<std::string(const BenchVariant &, Lights)> same_work;
};

// Registration (see GLINT_BENCH_CASE); returns true so it can initialise a static.
bool RegisterBenchCase(ModelBenchCase (*make)());
// Every registered case, made.
std::vector<ModelBenchCase> BenchCases();

// The smooth model's polygon-light methods as variants: LTC, LECOCQ, LECOCQ_PEARSON,
// MONTE_CARLO:n, REFERENCE:n (the --quick subset marked). Shared with bench_area.
struct AreaMethodChoice {
  glint::v1::AreaMethod method;
  uint32_t samples;  // area_samples (MONTE_CARLO samples, REFERENCE nodes); 0 = none
  bool quick;
};
const std::vector<AreaMethodChoice> &AreaMethodChoices();
std::string AreaMethodLabel(const AreaMethodChoice &c);  // "LTC", "MONTE_CARLO:64"

}  // namespace glint::bench

// In bench/cases/<model>.cpp, inside a namespace where `make` is visible:
// GLINT_BENCH_CASE(MakeMyCase) with ModelBenchCase MakeMyCase().
// The case files are compiled into the bench_models executable itself (not a static library),
// so the registering static is never dropped by the linker.
#define GLINT_BENCH_CASE(make)                                            \
  [[maybe_unused]] static const bool glint_bench_case_registered_##make = \
      ::glint::bench::RegisterBenchCase(make)
