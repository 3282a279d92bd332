// The Chermain et al. 2020 model's entry in the model table (server/model.h):
// its parameter block (glint.v1.ChermainParams), its table (the dictionary,
// data/chermain/), what it needs of queries, and two passes (one query per
// work-item: the footprint's cell loops): probes and directional/point lights,
// then polygon lights.
#include <algorithm>
#include <sstream>

#include "data/chermain/chermain_dictionary.h"
#include "models/chermain/chermain_params.h"
#include "server/eval_plan.h"
#include "server/host_pass.h"
#include "server/model.h"

GLINT_DECLARE_HOST_SAMPLE(ChermainSample)
GLINT_DECLARE_HOST_PASS(Chermain)
GLINT_DECLARE_HOST_PASS(ChermainPolygons)

namespace glint {
namespace {

using glint::v1::Material;

// proto/glint/v1/glint.proto ChermainParams documents the ranges.
Status ValidateChermainParams(const Material &m) {
  if (m.ndf() != glint::v1::BECKMANN) {
    return Status::InvalidArgument(
        std::string("material.ndf: ") + (m.ndf() == glint::v1::GGX ? "GGX" : "not BECKMANN") +
        "; the CHERMAIN model's dictionary converges to the Beckmann distribution (Chermain et al. "
        "2020 Sec. 4.3: GGX is not separable); expected BECKMANN");
  }
  if (!m.has_chermain()) {
    return Status::InvalidArgument(
        "material.chermain: unset; the CHERMAIN model needs at least {\"log_density\": ...}");
  }
  const auto &c = m.chermain();
  std::ostringstream o;
  if (!(c.log_density() >= 0.0f && c.log_density() <= 60.0f)) {
    o << "material.chermain.log_density: " << c.log_density()
      << "; expected ln(facets per unit uv area) in [0, 60]";
  } else if (!(c.relative_area() >= 0.0f && c.relative_area() <= 1.0f)) {
    o << "material.chermain.relative_area: " << c.relative_area()
      << "; expected a fraction in (0, 1] (0 = 1)";
  } else if (!(c.density_randomisation() >= 0.0f && c.density_randomisation() <= 10.0f)) {
    o << "material.chermain.density_randomisation: " << c.density_randomisation()
      << "; expected a standard deviation in levels in [0, 10]";
  } else if (!(c.max_anisotropy() == 0.0f ||
               (c.max_anisotropy() >= 1.0f && c.max_anisotropy() <= 16.0f))) {
    o << "material.chermain.max_anisotropy: " << c.max_anisotropy()
      << "; expected a ratio in [1, 16] (0 = 8)";
  } else if (!(c.dictionary_size() == 0 || c.dictionary_size() == 16 || c.dictionary_size() == 64 ||
               c.dictionary_size() == 192 || c.dictionary_size() == 512)) {
    o << "material.chermain.dictionary_size: " << c.dictionary_size()
      << "; expected 16, 64, 192 or 512 (0 = 192)";
  } else if (c.colors_size() % 3 != 0 || c.colors_size() > 3 * GLINT_CHERMAIN_MAX_COLORS) {
    o << "material.chermain.colors: " << c.colors_size()
      << " values; expected RGB triplets, at most " << GLINT_CHERMAIN_MAX_COLORS << " colours";
  } else {
    for (int k = 0; k < c.colors_size(); ++k) {
      if (!(c.colors(k) >= 0.0f && c.colors(k) <= 1.0f)) {
        o << "material.chermain.colors[" << k << "]: " << c.colors(k)
          << "; expected a reflectance factor in [0, 1]";
        return Status::InvalidArgument(o.str());
      }
    }
    return Status::Ok();
  }
  return Status::InvalidArgument(o.str());
}

bool HasProbesOrPunctualLights(const EvalPlan &plan) {
  // Also when nothing else runs, so a batch always gets its output written.
  return plan.spec.probe || plan.n_directional > 0 || plan.n_point > 0 || plan.n_polygon == 0;
}

bool HasPolygons(const EvalPlan &plan) {
  return plan.n_polygon > 0;
}

Status ValidateChermainQueries(const glint::v1::EvaluateRequest &, const glint::v1::QueryBatch &q,
                               uint64_t) {
  if (q.uv().empty()) {
    return Status::InvalidArgument(
        "queries.uv: empty; the CHERMAIN model needs uv (2 per query) to place its cells");
  }
  if (q.footprint().empty()) {
    return Status::InvalidArgument(
        "queries.footprint: empty; the CHERMAIN model needs the pixel footprint (du/dx, dv/dx, "
        "du/dy, dv/dy per query; all 0 = the smooth Beckmann BRDF)");
  }
  return Status::Ok();
}

void PackChermainParams(const Material &m, float *params) {
  static_assert(GLINT_CHERMAIN_FLOATS <= GLINT_MODEL_PARAM_FLOATS);
  const auto &c = m.chermain();
  params[0] = c.log_density();
  params[1] = c.relative_area() > 0.0f ? c.relative_area() : GLINT_CHERMAIN_DEFAULT_RELATIVE_AREA;
  params[2] = c.density_randomisation();
  params[3] =
      c.max_anisotropy() > 0.0f ? c.max_anisotropy() : GLINT_CHERMAIN_DEFAULT_MAX_ANISOTROPY;
  params[4] =
      c.dictionary_size() > 0 ? float(c.dictionary_size()) : GLINT_CHERMAIN_DEFAULT_DICTIONARY_SIZE;
  params[5] = float(c.colors_size() / 3);
  for (int k = 0; k < c.colors_size(); ++k) params[GLINT_CHERMAIN_COLOR_OFFSET + k] = c.colors(k);
}

const float *ChermainTable(size_t *floats) {
  *floats = chermain_data::kFloats;
  return chermain_data::dictionary();
}

void ChermainExample(Material *m, glint::v1::QueryBatch *one_query) {
  m->set_ndf(glint::v1::BECKMANN);
  m->mutable_chermain()->set_log_density(20.0f);
  m->mutable_chermain()->set_density_randomisation(2.0f);
  for (float v : {0.5f, 0.5f}) one_query->add_uv(v);
  for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) one_query->add_footprint(v);
}

std::vector<KernelSpec> ChermainWarmSpecs() {
  KernelSpec glints;  // the glint preview: a world frame and a sun
  glints.model = glint::v1::CHERMAIN;
  glints.ndf = GLINT_NDF_BECKMANN;
  glints.has_frame = true;
  glints.has_directional = true;
  return {glints};
}

}  // namespace

extern const Model kChermainModel;
// Admission cost per evaluation relative to the smooth model (server/request_cost.h): the cells
// of the footprint visited per light grow with the maximum anisotropy gamma (Sec. 5.3: at most
// 4 pi gamma + 4 sqrt(gamma) + 5 per level); bench_request_cost measured ~430 units per light at
// the default gamma 8 (107 us per query for 4 point lights, PoCL CPU).
double ChermainCostFactor(const glint::v1::Material &m) {
  const float gamma = m.chermain().max_anisotropy() > 0.0f ? m.chermain().max_anisotropy()
                                                           : GLINT_CHERMAIN_DEFAULT_MAX_ANISOTROPY;
  return 430.0 * std::max(1.0, double(gamma) / 8.0);
}

const Model kChermainModel = {
    .id = glint::v1::CHERMAIN,
    .name = "CHERMAIN",
    .params_field = "chermain",
    .passes = {{"models/chermain/chermain.cl", "glint_chermain", 1, HasProbesOrPunctualLights,
                ChermainF32, ChermainF64},
               // Polygon lights (beyond the paper): chermain_polygons.h states the approximation.
               {"models/chermain/chermain_area.cl", "glint_chermain_area", 1, HasPolygons,
                ChermainPolygonsF32, ChermainPolygonsF64}},
    .validate_params = ValidateChermainParams,
    .validate_light = nullptr,
    .validate_queries = ValidateChermainQueries,
    .table = ChermainTable,
    .pack_params = PackChermainParams,
    .example = ChermainExample,
    .warm_specs = ChermainWarmSpecs,
    .sample = {"models/chermain/chermain_sample.cl", "glint_chermain_sample", ChermainSampleF32,
               ChermainSampleF64},
    .cost_factor = ChermainCostFactor,
};

}  // namespace glint
