// The binomial model's entry in the model table (server/model.h): its
// parameter block (glint.v1.BinomialParams), what it needs of lights and
// queries, and its passes: 16 queries per work-item for directional, point and polygon lights
// by LTC, one per work-item for polygon lights by the other area methods.
#include <sstream>

#include "models/binomial/binomial_params.h"
#include "server/eval_plan.h"
#include "server/host_pass.h"
#include "server/model.h"

// Blocks of 16 queries per fp32 work-item with lights: binomial_lanes.cl regroups the count
// draws of that many blocks by regime when a request has one light (models/binomial/README.md
// "Quad throughput (session 19): one regime per lane group").
#define GLINT_BINOMIAL_LIGHTS_BLOCKS 4

GLINT_DECLARE_HOST_PASS(Binomial)

namespace glint {
namespace {

using glint::v1::Material;

// proto/glint/v1/glint.proto BinomialParams documents the ranges.
Status ValidateBinomialParams(const Material &m) {
  if (!m.has_binomial()) {
    return Status::InvalidArgument(
        "material.binomial: unset; the BINOMIAL model needs at least {\"density\": ...}");
  }
  const auto &b = m.binomial();
  std::ostringstream o;
  if (!(b.density() > 0.0 && b.density() <= 1e30)) {
    o << "material.binomial.density: " << b.density()
      << "; expected facets per unit uv area in (0, 1e30]";
  } else if (!glint::v1::ReflectionProbability_IsValid(b.p_mode())) {
    o << "material.binomial.p_mode: unknown value " << b.p_mode()
      << "; expected AREA or HEURISTIC_R";
  } else if (!(b.r() >= 0.0f && b.r() <= 1e6f)) {
    o << "material.binomial.r: " << b.r() << "; expected a factor in (0, 1e6] (0 = 1)";
  } else if (!(b.normal_threshold() == 0.0f ||
               (b.normal_threshold() >= 1.0f && b.normal_threshold() <= 40.0f))) {
    o << "material.binomial.normal_threshold: " << b.normal_threshold()
      << "; expected a variance in [1, 40] (0 = 9)";
  } else if (!(b.slope_cell() >= 0.0f && b.slope_cell() <= 1e3f)) {
    o << "material.binomial.slope_cell: " << b.slope_cell()
      << "; expected a slope in (0, 1000] (0 = 0.05)";
  } else if (!glint::v1::FootprintInterpolation_IsValid(b.footprint_interpolation())) {
    o << "material.binomial.footprint_interpolation: unknown value " << b.footprint_interpolation()
      << "; expected TRILINEAR, TETRAHEDRAL or STOCHASTIC";
  } else {
    return Status::Ok();
  }
  return Status::InvalidArgument(o.str());
}

// KK24 Sec. 5: a light of zero size has zero probability of meeting a facet, so the AREA
// probability needs a cone (directional) or a radius (point).
Status ValidateBinomialLight(const Material &m, const glint::v1::Light &light,
                             const std::string &field) {
  if (m.binomial().p_mode() == glint::v1::HEURISTIC_R) return Status::Ok();
  if (light.has_directional() && !(light.directional().cone_half_angle_deg() > 0.0f)) {
    return Status::InvalidArgument(
        field +
        ".directional.cone_half_angle_deg: 0; the BINOMIAL model (p_mode AREA) needs a light "
        "of finite size, e.g. 0.26 for the sun");
  }
  if (light.has_point() && !(light.point().radius() > 0.0f)) {
    return Status::InvalidArgument(
        field +
        ".point.radius: 0; the BINOMIAL model (p_mode AREA) needs a sphere light of finite "
        "radius");
  }
  return Status::Ok();
}

Status ValidateBinomialQueries(const glint::v1::EvaluateRequest &, const glint::v1::QueryBatch &q,
                               uint64_t) {
  if (!q.wi().empty()) {
    return Status::InvalidArgument(
        "queries.wi: BRDF probes are a delta light, which no facet reflects; the BINOMIAL "
        "model needs lights of finite size");
  }
  if (q.uv().empty()) {
    return Status::InvalidArgument(
        "queries.uv: empty; the BINOMIAL model needs uv (2 per query) to place the facets");
  }
  if (q.footprint().empty()) {
    return Status::InvalidArgument(
        "queries.footprint: empty; the BINOMIAL model needs the pixel footprint (du/dx, dv/dx, "
        "du/dy, dv/dy per query) to count facets");
  }
  return Status::Ok();
}

void PackBinomialParams(const Material &m, float *params) {
  static_assert(GLINT_BINOMIAL_FLOATS <= GLINT_MODEL_PARAM_FLOATS);
  const auto &b = m.binomial();
  params[0] = static_cast<float>(b.density());
  params[1] = b.p_mode() == glint::v1::HEURISTIC_R ? GLINT_P_MODE_HEURISTIC_R : GLINT_P_MODE_AREA;
  params[2] = b.r() > 0.0f ? b.r() : 1.0f;
  params[3] =
      b.normal_threshold() > 0.0f ? b.normal_threshold() : GLINT_BINOMIAL_DEFAULT_NORMAL_THRESHOLD;
  params[4] = b.slope_cell() > 0.0f ? b.slope_cell() : GLINT_BINOMIAL_DEFAULT_SLOPE_CELL;
  params[5] = b.footprint_interpolation() == glint::v1::TETRAHEDRAL ? GLINT_BINOMIAL_TETRAHEDRAL
                                                                    : GLINT_BINOMIAL_TRILINEAR;
  if (b.footprint_interpolation() == glint::v1::STOCHASTIC) params[5] = GLINT_BINOMIAL_STOCHASTIC;
}

void BinomialExample(Material *m, glint::v1::QueryBatch *one_query) {
  m->mutable_binomial()->set_density(1e6);
  for (float v : {0.5f, 0.5f}) one_query->add_uv(v);
  for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) one_query->add_footprint(v);
}

// The lane pass (binomial_lanes.cl) unless polygon lights need an area method other than LTC,
// which branches per query (binomial.cl). Exactly one of the two runs.
bool BinomialInLanes(const EvalPlan &plan) {
  return plan.n_polygon == 0 || plan.area_method == GLINT_AREA_LTC;
}

bool BinomialOneQueryPerItem(const EvalPlan &plan) {
  return !BinomialInLanes(plan);
}

std::vector<KernelSpec> BinomialWarmSpecs() {
  KernelSpec glints;  // the glint preview: a world frame, a sun and a rect light
  glints.model = glint::v1::BINOMIAL;
  glints.has_frame = true;
  glints.has_directional = true;
  glints.has_polygon = true;
  return {glints};
}

}  // namespace

extern const Model kBinomialModel;
// Admission cost per evaluation relative to the smooth model (server/request_cost.h), from the
// dearest case measured (bench/binomial_breakdown, device fp32, CPU time, interleaved with
// SMOOTH): directional + point light at N_P = 1e6 facets per footprint costs 62x the smooth
// model's query on the same lights (1e4: 25x, 1e2: 15x). Smooth there is kPerQuery + 2 lights =
// 3 units, so 1 + 2 f = 3 x 62 gives f ~ 90 per light. The cost grows with N_P (the count
// regimes, binomial_count.h), which admission cannot see (footprints are per query), so it
// bounds the dear end. Polygons are capped at request_cost.cpp's kPolygonFactor (8): one quad
// by LTC measured 30-50x the smooth directional + point query = 90-150 units, vs 161 charged.
// TETRAHEDRAL (4 grids, binomial_tetrahedral.h): its dearest case, directional + point at
// N_P = 1e6, measured 0.027-0.029 of SMOOTH (35-37x; binomial_breakdown --interpolation
// trilinear,tetrahedral, 2026-12-01, loaded), so 1 + 2 f = 3 x 37 gives f ~ 55. Its quad
// (0.044-0.063 of SMOOTH directional + point) is cheaper than TRILINEAR's, under the same
// polygon cap (request_cost.cpp kPolygonFactor).
// STOCHASTIC (one grid, binomial_stochastic.h): directional + point at N_P = 1e6, again its
// dearest case, measured 0.056 of SMOOTH (18x; binomial_breakdown --interpolation
// trilinear,tetrahedral,stochastic, 2026-12-01, loaded), so 1 + 2 f = 3 x 18 gives f ~ 27; its
// quad measured 0.063-0.088 of SMOOTH directional + point.
double BinomialCostFactor(const glint::v1::Material &m) {
  if (m.binomial().footprint_interpolation() == glint::v1::STOCHASTIC) return 27.0;
  return m.binomial().footprint_interpolation() == glint::v1::TETRAHEDRAL ? 55.0 : 90.0;
}

const Model kBinomialModel = {
    .id = glint::v1::BINOMIAL,
    .name = "BINOMIAL",
    .params_field = "binomial",
    // 16 lanes in both precisions: 8 fp64 lanes (ModelPass::simd_width_fp64) measured no faster
    // with one quad (0.88-1.08 of 16) and 0.75-0.98 with directional + point
    // (models/binomial/README.md "fp64 lanes (session 16)").
    .passes = {{"models/binomial/binomial_lanes.cl", "glint_binomial_lanes", 16, BinomialInLanes,
                BinomialF32, BinomialF64, 0, 0, GLINT_BINOMIAL_LIGHTS_BLOCKS},
               {"models/binomial/binomial.cl", "glint_binomial", 1, BinomialOneQueryPerItem,
                BinomialF32, BinomialF64}},
    .validate_params = ValidateBinomialParams,
    .validate_light = ValidateBinomialLight,
    .validate_queries = ValidateBinomialQueries,
    .pack_params = PackBinomialParams,
    .example = BinomialExample,
    .warm_specs = BinomialWarmSpecs,
    .sample = {.unsupported_reason =
                   "its glints are a count of reflecting facets per light (Kneiphof & Klein "
                   "2024), not a normal distribution that directions could be drawn from"},
    .cost_factor = BinomialCostFactor,
};

}  // namespace glint
