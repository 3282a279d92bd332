#include "server/eval_plan.h"

#include <cmath>
#include <sstream>

namespace glint {
namespace {

// Values of the GLINT_* constants in kernels/ndf.h, kernels/fresnel.h.
constexpr int kNdfGgx = 1, kNdfBeckmann = 2;
constexpr int kFresnelSchlick = 1, kFresnelConductor = 2, kFresnelDielectric = 3;
constexpr int kLightFloats = 8;  // GLINT_LIGHT_FLOATS

void Append3(const google::protobuf::RepeatedField<float> &v, std::vector<float> *out) {
  out->insert(out->end(), v.begin(), v.begin() + 3);
}

}  // namespace

std::string KernelSpec::BuildOptions() const {
  std::ostringstream o;
  o << "-DGLINT_NDF=" << ndf << " -DGLINT_FRESNEL=" << fresnel << " -DGLINT_PROBE=" << probe
    << " -DGLINT_HAS_FRAME=" << has_frame << " -DGLINT_HAS_DIRECTIONAL=" << has_directional
    << " -DGLINT_HAS_POINT=" << has_point << " -DGLINT_USE_DOUBLE=" << fp64;
  // Literals such as R(0.5) must not promote fp32 arithmetic to double.
  if (!fp64) o << " -cl-single-precision-constant";
  return o.str();
}

std::string KernelSpec::Describe() const {
  std::ostringstream o;
  o << (ndf == kNdfBeckmann ? "beckmann" : "ggx") << '/'
    << (fresnel == kFresnelConductor    ? "conductor"
        : fresnel == kFresnelDielectric ? "dielectric"
                                        : "schlick");
  if (probe) o << "/probe";
  if (has_directional) o << "/directional";
  if (has_point) o << "/point";
  if (has_frame) o << "/frame";
  o << (fp64 ? "/fp64" : "/fp32");
  return o.str();
}

EvalPlan MakeEvalPlan(const glint::v1::EvaluateRequest &settings,
                      const glint::v1::QueryBatch &queries) {
  using glint::v1::Material;
  const Material &m = settings.material();
  EvalPlan plan;
  KernelSpec &s = plan.spec;
  s.ndf = m.ndf() == glint::v1::BECKMANN ? kNdfBeckmann : kNdfGgx;
  s.probe = queries.wi_size() > 0;
  s.has_frame = queries.normal_size() > 0;
  s.fp64 = settings.precision() == glint::v1::FP64;

  plan.material[0] = m.alpha_x();
  plan.material[1] = m.alpha_y();
  switch (m.fresnel_case()) {
    case Material::kConductor:
      s.fresnel = kFresnelConductor;
      for (int c = 0; c < 3; ++c) {
        plan.material[2 + c] = m.conductor().eta(c);
        plan.material[5 + c] = m.conductor().k(c);
      }
      break;
    case Material::kDielectric:
      s.fresnel = kFresnelDielectric;
      for (int c = 0; c < 3; ++c) plan.material[2 + c] = m.dielectric().ior();
      break;
    default:
      s.fresnel = kFresnelSchlick;
      for (int c = 0; c < 3; ++c) plan.material[2 + c] = m.schlick().f0(c);
      break;
  }

  for (const auto &light : settings.lights()) {
    if (light.has_directional()) {
      const auto &d = light.directional();
      Append3(d.direction(), &plan.directional);
      Append3(d.irradiance(), &plan.directional);
      constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
      plan.directional.push_back(static_cast<float>(std::cos(d.cone_half_angle_deg() * kDegToRad)));
      plan.directional.push_back(0.0f);
      ++plan.n_directional;
    } else if (light.has_point()) {
      const auto &p = light.point();
      Append3(p.position(), &plan.point);
      Append3(p.intensity(), &plan.point);
      plan.point.push_back(p.radius());
      plan.point.push_back(0.0f);
      ++plan.n_point;
    }
  }
  static_assert(kLightFloats == 8, "light record layout of kernels/lights.h");
  s.has_directional = plan.n_directional > 0;
  s.has_point = plan.n_point > 0;
  return plan;
}

}  // namespace glint
