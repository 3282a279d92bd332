#include "server/eval_plan.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "data/ltc/ltc_table.h"
#include "server/model_table.h"

namespace glint {
namespace {

void Append3(const google::protobuf::RepeatedField<float> &v, std::vector<float> *out) {
  out->insert(out->end(), v.begin(), v.begin() + 3);
}

}  // namespace

const float *LtcTable(int ndf) {
  static_assert(sizeof(ltc_table::data::glint_ltc_ggx) == kLtcTableFloats * sizeof(float));
  return ltc_table::table(ndf == GLINT_NDF_BECKMANN ? ltc_table::Ndf::kBeckmann
                                                    : ltc_table::Ndf::kGgx);
}

std::string KernelSpec::BuildOptions() const {
  std::ostringstream o;
  o << "-DGLINT_NDF=" << ndf << " -DGLINT_FRESNEL=" << fresnel << " -DGLINT_PROBE=" << probe
    << " -DGLINT_HAS_FRAME=" << has_frame << " -DGLINT_HAS_DIRECTIONAL=" << has_directional
    << " -DGLINT_HAS_POINT=" << has_point << " -DGLINT_USE_DOUBLE=" << fp64;
  // Literals such as GLINT_R(0.5) must not promote fp32 arithmetic to double.
  if (!fp64) o << " -cl-single-precision-constant";
  if (sample_uv) o << " -DGLINT_SAMPLE_UV=1";
  if (area_only >= 0) o << " -DGLINT_AREA_ONLY=" << area_only;
  return o.str();
}

std::string KernelSpec::Describe() const {
  std::ostringstream o;
  const Model *m = FindModel(model);
  std::string name = m ? m->name : "model" + std::to_string(model);
  std::transform(name.begin(), name.end(), name.begin(),
                 [](char c) { return char(std::tolower(c)); });
  o << name << '/' << (ndf == GLINT_NDF_BECKMANN ? "beckmann" : "ggx") << '/'
    << (fresnel == GLINT_FRESNEL_CONDUCTOR    ? "conductor"
        : fresnel == GLINT_FRESNEL_DIELECTRIC ? "dielectric"
                                              : "schlick");
  if (probe) o << "/probe";
  if (has_directional) o << "/directional";
  if (has_point) o << "/point";
  if (has_polygon) o << "/polygon";
  if (has_frame) o << "/frame";
  if (sample_uv) o << "/uv";
  if (area_only >= 0) o << "/area" << area_only;
  o << (fp64 ? "/fp64" : "/fp32");
  return o.str();
}

EvalPlan MakeEvalPlan(const glint::v1::EvaluateRequest &settings,
                      const glint::v1::QueryBatch &queries) {
  using glint::v1::Material;
  const Material &m = settings.material();
  EvalPlan plan;
  KernelSpec &s = plan.spec;
  s.model = m.model();
  s.ndf = m.ndf() == glint::v1::BECKMANN ? GLINT_NDF_BECKMANN : GLINT_NDF_GGX;
  s.probe = queries.wi_size() > 0;
  s.has_frame = queries.normal_size() > 0;
  s.fp64 = settings.precision() == glint::v1::FP64;

  plan.material[0] = m.alpha_x();
  plan.material[1] = m.alpha_y();
  switch (m.fresnel_case()) {
    case Material::kConductor:
      s.fresnel = GLINT_FRESNEL_CONDUCTOR;
      for (int c = 0; c < 3; ++c) {
        plan.material[2 + c] = m.conductor().eta(c);
        plan.material[5 + c] = m.conductor().k(c);
      }
      break;
    case Material::kDielectric:
      s.fresnel = GLINT_FRESNEL_DIELECTRIC;
      for (int c = 0; c < 3; ++c) plan.material[2 + c] = m.dielectric().ior();
      break;
    default:
      s.fresnel = GLINT_FRESNEL_SCHLICK;
      for (int c = 0; c < 3; ++c) plan.material[2 + c] = m.schlick().f0(c);
      break;
  }

  for (const auto &light : settings.lights()) {
    if (light.has_directional()) {
      const auto &d = light.directional();
      Append3(d.direction(), &plan.directional);
      Append3(d.irradiance(), &plan.directional);
      constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
      // The cone's solid angle 2 pi (1 - cos gamma) = 4 pi sin^2(gamma / 2), in double: the
      // sun's 6.8e-5 sr would lose digits to 1 - cos in float.
      const double half = 0.5 * d.cone_half_angle_deg() * kDegToRad;
      plan.directional.push_back(
          static_cast<float>(4.0 * 3.14159265358979323846 * std::sin(half) * std::sin(half)));
      plan.directional.push_back(0.0f);
      ++plan.n_directional;
    } else if (light.has_point()) {
      const auto &p = light.point();
      Append3(p.position(), &plan.point);
      Append3(p.intensity(), &plan.point);
      plan.point.push_back(p.radius());
      plan.point.push_back(0.0f);
      ++plan.n_point;
    } else if (light.has_polygon()) {
      const auto &p = light.polygon();
      std::vector<float> rec(GLINT_POLYGON_FLOATS, 0.0f);
      rec[0] = float(p.vertices_size() / 3);
      rec[1] = p.two_sided() ? 1.0f : 0.0f;
      for (int c = 0; c < 3; ++c) rec[2 + c] = p.radiance(c);
      std::copy(p.vertices().begin(), p.vertices().end(),
                rec.begin() + GLINT_POLYGON_VERTEX_OFFSET);
      plan.polygon.insert(plan.polygon.end(), rec.begin(), rec.end());
      ++plan.n_polygon;
    }
  }
  s.has_polygon = plan.n_polygon > 0;
  // GLINT_AREA_* share glint.v1.AreaMethod's numbers.
  plan.area_method = settings.area_method() == glint::v1::AREA_METHOD_UNSPECIFIED
                         ? GLINT_AREA_LTC
                         : int(settings.area_method());
  plan.seed_lo = uint32_t(settings.seed() & 0xffffffffu);
  plan.seed_hi = uint32_t(settings.seed() >> 32);
  if (const Model *model = FindModel(s.model); model && model->pack_params)
    model->pack_params(m, plan.params.data());
  plan.area_samples = settings.area_samples() ? int(settings.area_samples()) : 64;
  if (const Model *model = FindModel(s.model); model && model->request_table)
    plan.request_table_material = std::make_shared<const glint::v1::Material>(m);
  if (plan.area_method == GLINT_AREA_AUTO) {
    // AUTO's budget, in millionths (kernels/area/area_auto.h), within [1, INT_MAX].
    const double ppm = std::round(double(settings.max_relative_error()) * 1e6);
    plan.area_samples = int(std::clamp(ppm, 1.0, 2147483647.0));
  }
  static_assert(GLINT_LIGHT_FLOATS == 8, "the light records above are 8 floats");
  s.has_directional = plan.n_directional > 0;
  s.has_point = plan.n_point > 0;
  return plan;
}

Status ResolveRequestTable(const glint::v1::Material &material, EvalPlan *plan) {
  const Model *model = FindModel(material.model());
  if (!model || !model->request_table) return Status::Ok();
  return model->request_table(material, &plan->request_table, &plan->request_table_key);
}

}  // namespace glint
