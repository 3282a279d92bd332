// The NORMAL_MAP model's (Yan et al. 2014) entry in the model table (server/model.h): its
// parameter block (glint.v1.NormalMapParams), its per-request table (the uploaded map, from the
// server's normal-map store), what it needs of lights and queries, and one pass (one query per
// work-item: the quadtree traversal).
#include <sstream>

#include "models/normal_map/normal_map_cost.h"
#include "models/normal_map/normal_map_params.h"
#include "server/eval_plan.h"
#include "server/host_pass.h"
#include "server/model.h"
#include "server/normal_map_store.h"

GLINT_DECLARE_HOST_PASS(NormalMap)
GLINT_DECLARE_HOST_PASS(NormalMapPolygons)
GLINT_DECLARE_HOST_SAMPLE(NormalMapSample)

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

int Subdivision(const Material &m) {
  return m.normal_map().subdivision() == 4 ? 4 : 1;
}

// proto/glint/v1/glint.proto NormalMapParams documents the ranges.
Status ValidateNormalMapParams(const Material &m) {
  if (!m.has_normal_map())
    return Status::InvalidArgument(
        "material.normal_map: unset; the NORMAL_MAP model needs at least {\"digest\": "
        "\"sha256:...\"} (glint upload prints it)");
  const auto &p = m.normal_map();
  std::ostringstream o;
  if (!IsNormalMapDigest(p.digest())) {
    o << "material.normal_map.digest: \"" << p.digest()
      << "\"; expected \"sha256:\" and 64 lowercase hex digits, as UploadNormalMap returns";
  } else if (!(p.intrinsic_roughness() == 0.0f ||
               (p.intrinsic_roughness() >= GLINT_NM_MIN_SIGMA_R &&
                p.intrinsic_roughness() <= GLINT_NM_MAX_SIGMA_R))) {
    o << "material.normal_map.intrinsic_roughness: " << p.intrinsic_roughness()
      << "; expected sigma_r in [1e-4, 0.5] (0 = 0.01)";
  } else if (!(p.cutoff_sigma() == 0.0f || (p.cutoff_sigma() >= GLINT_NM_MIN_CUTOFF &&
                                            p.cutoff_sigma() <= GLINT_NM_MAX_CUTOFF))) {
    o << "material.normal_map.cutoff_sigma: " << p.cutoff_sigma()
      << "; expected standard deviations in [2, 10] (0 = 5)";
  } else if (!(p.subdivision() == 0 || p.subdivision() == 1 || p.subdivision() == 4)) {
    o << "material.normal_map.subdivision: " << p.subdivision()
      << "; expected 1 (2 triangles per texel) or 4 (4 x 4 Catmull-Rom sub-texels), 0 = 1";
  } else {
    // The map must be here (NOT_FOUND names the digest), and subdivision 4 within the texel
    // limit. Validation runs on the gRPC handler's thread: it only checks; the request's worker
    // builds a missing subdivision-4 table (NormalMapRequestTable, seconds for a large map).
    return NormalMaps().Check(p.digest(), Subdivision(m));
  }
  return Status::InvalidArgument(o.str());
}

// Polygon lights are integrated by the P-NDF's own multiple importance sampling
// (normal_map_polygons.h), area_samples samples per technique: the other area methods are
// smooth-lobe integrators and do not apply.
Status ValidateNormalMapLight(const Material &, const glint::v1::Light &, const std::string &) {
  return Status::Ok();
}

Status ValidateNormalMapQueries(const glint::v1::EvaluateRequest &, const glint::v1::QueryBatch &q,
                                uint64_t) {
  if (q.uv().empty())
    return Status::InvalidArgument(
        "queries.uv: empty; the NORMAL_MAP model needs uv (2 per query) to place the footprint "
        "on the map");
  if (q.footprint().empty())
    return Status::InvalidArgument(
        "queries.footprint: empty; the NORMAL_MAP model needs the pixel footprint (du/dx, dv/dx, "
        "du/dy, dv/dy per query) for its Gaussian G_p");
  return Status::Ok();
}

void PackNormalMapParams(const Material &m, float *params) {
  const auto &p = m.normal_map();
  params[0] = p.intrinsic_roughness() > 0.0f ? p.intrinsic_roughness() : GLINT_NM_DEFAULT_SIGMA_R;
  params[1] = p.cutoff_sigma() > 0.0f ? p.cutoff_sigma() : GLINT_NM_DEFAULT_CUTOFF;
  params[2] = float(Subdivision(m));
}

Status NormalMapRequestTable(const Material &m, std::shared_ptr<const std::vector<float>> *table,
                             std::string *key) {
  *key = m.normal_map().digest() + "/" + std::to_string(Subdivision(m));
  return NormalMaps().Table(m.normal_map().digest(), Subdivision(m), table);
}

// DeviceEngine::Warm's example: a flat 1 x 1 map, stored in the process's store like an upload.
// The model has no warm_specs: its kernel is built on the first request (then cached on disk),
// so glintd's start-up time does not grow with it.
void NormalMapExample(Material *m, glint::v1::QueryBatch *one_query) {
  DecodedNormalMap flat;
  flat.width = flat.height = 1;
  flat.xyz = {0.0f, 0.0f, 1.0f};
  glint::v1::NormalMapInfo info;
  NormalMaps().Insert("flat (built in)", flat, &info);
  m->mutable_normal_map()->set_digest(info.digest());
  for (float v : {0.5f, 0.5f}) one_query->add_uv(v);
  for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) one_query->add_footprint(v);
}

}  // namespace

extern const Model kNormalMapModel;
// Admission cost (server/request_cost.h) in smooth evaluations per evaluation when the queries
// cannot be counted (EstimateRequestCost without queries; glintd admits every path by
// query_costs, so in practice only queries without uv or footprint, which validation then
// refuses): the triangles that survive pruning cost ~1-2 us each (README "Cost"); at the ~100
// texels of a one-texel footprint at cut-off 5 that is ~2000 smooth evaluations, 4x4
// subdivision ~7x more, and the cut-off box's area grows as cutoff^2. Big footprints are
// underestimated here; query_costs (normal_map_cost.h) counts each footprint's box.
double NormalMapCostFactor(const glint::v1::Material &m) {
  const double cutoff = m.normal_map().cutoff_sigma() > 0 ? m.normal_map().cutoff_sigma() : 5.0;
  const double subdivision = m.normal_map().subdivision() == 4 ? 7.0 : 1.0;
  return 2000.0 * subdivision * (cutoff * cutoff) / 25.0;
}

const Model kNormalMapModel = {
    .id = glint::v1::NORMAL_MAP,
    .name = "NORMAL_MAP",
    .params_field = "normal_map",
    .passes = {{"models/normal_map/normal_map.cl", "glint_normal_map", 1, HasProbesOrPunctualLights,
                NormalMapF32, NormalMapF64},
               {"models/normal_map/normal_map_area.cl", "glint_normal_map_area", 1, HasPolygons,
                NormalMapPolygonsF32, NormalMapPolygonsF64}},
    .validate_params = ValidateNormalMapParams,
    .validate_light = ValidateNormalMapLight,
    .validate_queries = ValidateNormalMapQueries,
    .pack_params = PackNormalMapParams,
    .example = NormalMapExample,
    .sample = {"models/normal_map/normal_map_sample.cl", "glint_normal_map_sample",
               NormalMapSampleF32, NormalMapSampleF64},
    .uses_ndf = false,
    .request_table = NormalMapRequestTable,
    .cost_factor = NormalMapCostFactor,
    .query_costs = NormalMapQueryCosts,
    .polygon_method = NormalMapPolygonMethod,
};

}  // namespace glint
