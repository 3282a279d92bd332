#include "server/host_path.h"

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "server/host_pass.h"
#include "server/model_table.h"

namespace glint {

namespace {

// The plan's request table (Model::request_table), resolved here from the material the plan
// kept when the caller did not (ResolveRequestTable): false when the model needs one and it
// cannot be had (the map was deleted or evicted since validation; the device path reports that
// as NOT_FOUND from RunBatch, the host path has no status to return and writes zeros).
bool HostRequestTable(const EvalPlan &plan, const Model *model,
                      std::shared_ptr<const std::vector<float>> *table) {
  *table = plan.request_table;
  if (!model->request_table || *table) return true;
  if (!plan.request_table_material) return false;
  std::string key;
  return model->request_table(*plan.request_table_material, table, &key).ok() && *table;
}

HostInputs MakeHostInputs(const EvalPlan &plan, const glint::v1::QueryBatch &q, const Model *model,
                          const std::vector<float> *request_table) {
  HostInputs in;
  in.ndf = plan.spec.ndf;
  in.fresnel = plan.spec.fresnel;
  in.probe = plan.spec.probe;
  in.has_frame = plan.spec.has_frame;
  in.has_directional = plan.spec.has_directional;
  in.has_point = plan.spec.has_point;
  in.sample_uv = plan.spec.sample_uv;
  in.n = q.count();
  in.uv = q.uv().data();
  in.footprint = q.footprint().data();
  in.wo = q.wo().data();
  in.wi = q.wi().data();
  in.position = q.position().data();
  in.normal = q.normal().data();
  in.tangent = q.tangent().data();
  in.material = plan.material.data();
  in.params = plan.params.data();
  in.directional = plan.directional.data();
  in.n_directional = plan.n_directional;
  in.point = plan.point.data();
  in.n_point = plan.n_point;
  in.polygons = plan.polygon.data();
  in.n_polygon = plan.n_polygon;
  in.ltc_table = LtcTable(plan.spec.ndf);
  size_t table_floats = 0;
  in.model_table = model->table ? model->table(&table_floats) : nullptr;
  if (request_table) in.model_table = request_table->data();
  in.area_method = plan.area_method;
  in.area_samples = plan.area_samples;
  in.seed_lo = plan.seed_lo;
  in.seed_hi = plan.seed_hi;
  return in;
}

}  // namespace

void HostEvaluate(const EvalPlan &plan, const glint::v1::QueryBatch &q, float *out_rgb) {
  const Model *model = FindModel(plan.spec.model);
  std::memset(out_rgb, 0, size_t(q.count()) * 3 * sizeof(float));
  if (!model) return;  // validation refuses unknown models before a plan exists

  std::shared_ptr<const std::vector<float>> table;
  if (!HostRequestTable(plan, model, &table)) return;
  const HostInputs in = MakeHostInputs(plan, q, model, table.get());
  bool accumulate = false;
  for (const ModelPass &pass : model->passes) {
    if (pass.needed && !pass.needed(plan)) continue;
    (plan.spec.fp64 ? pass.host_f64 : pass.host_f32)(in, out_rgb, accumulate);
    accumulate = true;
  }
}

void HostSample(const EvalPlan &plan, const glint::v1::QueryBatch &q, uint32_t samples_per_query,
                float *out) {
  const Model *model = FindModel(plan.spec.model);
  std::memset(out, 0, size_t(q.count()) * samples_per_query * kSampleFloats * sizeof(float));
  if (!model || !model->sample.kernel_file) return;  // refused by server/sample.cpp
  std::shared_ptr<const std::vector<float>> table;
  if (!HostRequestTable(plan, model, &table)) return;
  const HostInputs in = MakeHostInputs(plan, q, model, table.get());
  (plan.spec.fp64 ? model->sample.host_f64 : model->sample.host_f32)(in, samples_per_query, out);
}

}  // namespace glint
