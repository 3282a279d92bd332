// The Kemppinen model's entry in the model table (server/model.h): its
// parameter block (glint.v1.KemppinenParams), what it needs of queries, and
// two passes as the smooth model has: 16-lane SIMD for probes and
// directional/point lights, one query per work-item for polygon lights.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "models/kemppinen/kemppinen_params.h"
#include "server/eval_plan.h"
#include "server/host_pass.h"
#include "server/model.h"

GLINT_DECLARE_HOST_SAMPLE(KemppinenSample)
GLINT_DECLARE_HOST_PASS(KemppinenLights)
GLINT_DECLARE_HOST_PASS(KemppinenPolygons)

namespace glint {
namespace {

using glint::v1::Material;

bool HasProbesOrPunctualLights(const EvalPlan &plan) {
  // Also when nothing else runs, so a batch always gets its output written.
  return plan.spec.probe || plan.n_directional > 0 || plan.n_point > 0 || plan.n_polygon == 0;
}

bool HasPolygons(const EvalPlan &plan) {
  return plan.n_polygon > 0;
}

// proto/glint/v1/glint.proto KemppinenParams documents the ranges.
Status ValidateKemppinenParams(const Material &m) {
  if (!m.has_kemppinen()) {
    return Status::InvalidArgument(
        "material.kemppinen: unset; the KEMPPINEN model needs at least {\"density\": ...}");
  }
  const auto &k = m.kemppinen();
  std::ostringstream o;
  const uint32_t n = k.neighbors();
  if (!(k.density() >= 1e-6 && k.density() <= 1e30)) {
    o << "material.kemppinen.density: " << k.density()
      << "; expected facets per unit uv area in [1e-6, 1e30]";
  } else if (!(k.microroughness() == 0.0f ||
               (k.microroughness() >= 1e-5f && k.microroughness() <= 1.0f))) {
    o << "material.kemppinen.microroughness: " << k.microroughness()
      << "; expected a facet lobe width in [1e-5, 1] radians (0 = 0.02)";
  } else if (!(k.filter_size() == 0.0f || (k.filter_size() >= 0.1f && k.filter_size() <= 4.0f))) {
    o << "material.kemppinen.filter_size: " << k.filter_size()
      << "; expected a pixel-filter width in [0.1, 4] footprints (0 = 0.7)";
  } else if (!(n == 0 || n == 1 || n == 4 || n == 9 || n == 16)) {
    o << "material.kemppinen.neighbors: " << n << "; expected 1, 4, 9 or 16 (0 = 4)";
  } else if (!(k.anisotropy() == 0.0f || (k.anisotropy() >= 0.05f && k.anisotropy() <= 20.0f))) {
    o << "material.kemppinen.anisotropy: " << k.anisotropy()
      << "; expected a stretch in [0.05, 20] (0 = 1)";
  } else if (!(k.colors_size() % 3 == 0 && k.colors_size() <= 3 * GLINT_KEMPPINEN_MAX_COLORS)) {
    o << "material.kemppinen.colors: " << k.colors_size()
      << " values; expected flat RGB triples, 0 to " << GLINT_KEMPPINEN_MAX_COLORS
      << " colours (a multiple of 3, at most " << 3 * GLINT_KEMPPINEN_MAX_COLORS << " values)";
  } else if (!std::all_of(k.colors().begin(), k.colors().end(),
                          [](float c) { return c >= 0.0f && c <= 1.0f; })) {
    o << "material.kemppinen.colors: a channel outside [0, 1]; expected RGB in [0, 1]";
  } else if (!glint::v1::KemppinenNeighborhood_IsValid(k.neighborhood())) {
    o << "material.kemppinen.neighborhood: " << k.neighborhood()
      << "; expected KEMPPINEN_PAPER, KEMPPINEN_ONE_LEVEL or KEMPPINEN_ONE_CELL (unset = "
         "KEMPPINEN_PAPER)";
  } else {
    return Status::Ok();
  }
  return Status::InvalidArgument(o.str());
}

Status ValidateKemppinenQueries(const glint::v1::EvaluateRequest &, const glint::v1::QueryBatch &q,
                                uint64_t first_query) {
  if (q.uv().empty()) {
    // K25's uv-free variant (Sec. 3.3.6, "UV-free") projects position on three planes, but
    // "the partial derivatives are still required" (Sec. 4): the pixel filter (Eq. 5) needs
    // dp/dx, dp/dy, which QueryBatch does not carry (its footprint is the uv Jacobian). A client
    // that has them can project position itself and send uv with its footprint.
    return Status::InvalidArgument(
        "queries.uv: empty; the KEMPPINEN model needs uv (2 per query) and its footprint to place "
        "the facets and filter them. The paper's uv-free triplanar variant is not offered: it "
        "still needs the pixel footprint of the position (dp/dx, dp/dy), which queries do not "
        "carry; project position to uv (planar or triplanar) in the client and send uv with its "
        "footprint");
  }
  if (q.footprint().empty()) {
    return Status::InvalidArgument(
        "queries.footprint: empty; the KEMPPINEN model needs the pixel footprint (du/dx, dv/dx, "
        "du/dy, dv/dy per query) for its pixel filter (Eq. 5)");
  }
  // The facet grid's cell arithmetic overflows in fp32 for |uv| near the float range (NaN found
  // by the stability sweep at uv = 3.4e38); DESIGN.md asks for uv up to 1e7, which is exact.
  constexpr float kMaxUv = 1e7f;
  for (int i = 0; i < q.uv_size(); ++i) {
    if (!(std::fabs(q.uv(i)) <= kMaxUv)) {
      std::ostringstream o;
      o << "queries.uv[" << first_query + uint64_t(i / 2) << "]: (" << q.uv(i - i % 2) << ", "
        << q.uv(i - i % 2 + 1) << ") beyond |u|, |v| <= 1e7; the KEMPPINEN model's facet grid "
        << "is only defined up to there (tile or wrap uv)";
      return Status::InvalidArgument(o.str());
    }
  }
  return Status::Ok();
}

// glint.v1.KemppinenNeighborhood as the kernels' GLINT_KEMPPINEN_NEIGHBORHOOD_* (unset = the
// paper's, so a material without the field packs the same block as before it existed).
int KemppinenNeighborhoodCode(glint::v1::KemppinenNeighborhood n) {
  switch (n) {
    case glint::v1::KEMPPINEN_ONE_LEVEL:
      return GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL;
    case glint::v1::KEMPPINEN_ONE_CELL:
      return GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL;
    default:
      return GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER;
  }
}

void PackKemppinenParams(const Material &m, float *params) {
  static_assert(GLINT_KEMPPINEN_FLOATS <= GLINT_MODEL_PARAM_FLOATS);
  const auto &k = m.kemppinen();
  params[GLINT_KEMPPINEN_DENSITY] = static_cast<float>(k.density());
  params[GLINT_KEMPPINEN_MICRO] =
      k.microroughness() > 0.0f ? k.microroughness() : GLINT_KEMPPINEN_DEFAULT_MICROROUGHNESS;
  params[GLINT_KEMPPINEN_FILTER] =
      k.filter_size() > 0.0f ? k.filter_size() : GLINT_KEMPPINEN_DEFAULT_FILTER_SIZE;
  params[GLINT_KEMPPINEN_NEIGHBORS] = static_cast<float>(
      k.neighbors() > 0 ? k.neighbors() : uint32_t(GLINT_KEMPPINEN_DEFAULT_NEIGHBORS));
  params[GLINT_KEMPPINEN_ANISO] =
      k.anisotropy() > 0.0f ? k.anisotropy() : GLINT_KEMPPINEN_DEFAULT_ANISOTROPY;
  // Colours as given (validated: flat RGB triples in [0, 1], at most GLINT_KEMPPINEN_MAX_COLORS).
  params[GLINT_KEMPPINEN_N_COLORS] = static_cast<float>(k.colors_size() / 3);
  for (int i = 0; i < k.colors_size(); ++i) params[GLINT_KEMPPINEN_COLORS + i] = k.colors(i);
  params[GLINT_KEMPPINEN_NEIGHBORHOOD] = float(KemppinenNeighborhoodCode(k.neighborhood()));
}

void KemppinenExample(Material *m, glint::v1::QueryBatch *one_query) {
  m->mutable_kemppinen()->set_density(1e6);
  for (float v : {0.5f, 0.5f}) one_query->add_uv(v);
  for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) one_query->add_footprint(v);
}

std::vector<KernelSpec> KemppinenWarmSpecs() {
  KernelSpec glints;  // the glint preview: a world frame, a sun and a rect light
  glints.model = glint::v1::KEMPPINEN;
  glints.has_frame = true;
  glints.has_directional = true;
  glints.has_polygon = true;
  return {glints};
}

}  // namespace

extern const Model kKemppinenModel;
// Admission cost per evaluation relative to the smooth model (server/request_cost.h): k angular
// neighbours per cell and level are evaluated explicitly. bench_request_cost (2-core PoCL CPU,
// loaded, 2026-11-30; the unit measured in the same run: REFERENCE 128 at 30.6 ns per node):
// 4 point lights 875 ns per query at k = 4 and 2969 ns at k = 16, i.e. 7.2 and 24 units per
// light: 1.5 + 1.4 k (k = 1: 2.9; bench_models' k = 1 directional + point runs 2.5x the k = 4
// rate, 2.9 units). The former 6 k (22 / 63 units at k = 4 / 16) predates the 16-lane pass.
// The cheaper neighbourhoods (glint.v1.KemppinenNeighborhood) from their rates relative to the
// paper's in one interleaved run (kemppinen_throughput --lights directional_point --ks 1,4,9,16
// --neighborhoods paper,one_level,one_cell, loaded 2-core machine, 2026-12-01; README
// "Neighbourhood"): ONE_LEVEL evaluates half the facets and runs 1.9-2.0x the paper's rate, so
// half its factor; ONE_CELL runs 2.9x at k = 1 and 4.6x at k = 4 (its cost is mostly the
// query's fixed part: T, the smooth BRDF, the compensation), 0.8 + 0.2 k units per light.
double KemppinenCostFactor(const glint::v1::Material &m) {
  const uint32_t k = m.kemppinen().neighbors() ? m.kemppinen().neighbors() : 4;
  switch (m.kemppinen().neighborhood()) {
    case glint::v1::KEMPPINEN_ONE_LEVEL:
      return 0.75 + 0.7 * double(k);
    case glint::v1::KEMPPINEN_ONE_CELL:
      return 0.8 + 0.2 * double(k);
    default:
      return 1.5 + 1.4 * double(k);
  }
}

// A polygon light's glints beyond its smooth area integral (kemppinen_polygons.h: per level up
// to 4 x 4 angular cells x 2 x 2 spatial cells of facets, each lobe's mass over the light's
// image, and the block's expected mass): bench_request_cost's quad (LTC) 30.2 us per query in
// the run above, 985 units at 30.6 ns; the explicit block is widened to 4 x 4 cells for a light
// that large whatever k, so one figure for every k. (With the former min(factor, 8) x the LTC
// integral it was estimated at 161 units, 6x under.)
// The cheaper neighbourhoods (session 20: the polygon pass honours them) from their rates
// relative to the paper's, kemppinen_throughput --lights quad --neighborhoods
// paper,one_level,one_cell --ks 1,4 (and four_quads), 2 runs, loaded 2-core machine,
// 2026-12-07 (README "Polygon lights and the neighbourhood, session 20"): ONE_LEVEL (one
// level's E and facets) 1.80-1.85x per CPU-second for the quad, 1.60-1.63x for four quads,
// bench_request_cost's quad 1.83-1.90x (3 runs); ONE_CELL (also one spatial cell of four)
// 2.30-2.43x, 2.22-2.26x, 2.44-2.55x. A level's E (the block's expected mass), the image and
// the smooth integral stay, so neither reaches the point pass's 2-4.6x: 550 and 420 units.
double KemppinenPolygonCost(const glint::v1::Material &m) {
  switch (m.kemppinen().neighborhood()) {
    case glint::v1::KEMPPINEN_ONE_LEVEL:
      return 550.0;
    case glint::v1::KEMPPINEN_ONE_CELL:
      return 420.0;
    default:
      return 1000.0;
  }
}

const Model kKemppinenModel = {
    .id = glint::v1::KEMPPINEN,
    .name = "KEMPPINEN",
    .params_field = "kemppinen",
    // 16 lanes: fp32 +55% (probes) and +58% (directional + point) per CPU-second over 8 on the
    // AVX-512 CPU device at k = 1, fp64 +5% / +12% (bench_models rows in the README).
    .passes = {{"models/kemppinen/kemppinen.cl", "glint_kemppinen", 16, HasProbesOrPunctualLights,
                KemppinenLightsF32, KemppinenLightsF64},
               {"models/kemppinen/kemppinen_area.cl", "glint_kemppinen_area", 1, HasPolygons,
                KemppinenPolygonsF32, KemppinenPolygonsF64}},
    .validate_params = ValidateKemppinenParams,
    .validate_light = nullptr,
    .validate_queries = ValidateKemppinenQueries,
    .pack_params = PackKemppinenParams,
    .example = KemppinenExample,
    .warm_specs = KemppinenWarmSpecs,
    .sample = {"models/kemppinen/kemppinen_sample.cl", "glint_kemppinen_sample", KemppinenSampleF32,
               KemppinenSampleF64},
    .cost_factor = KemppinenCostFactor,
    .polygon_cost = KemppinenPolygonCost,
};

}  // namespace glint
