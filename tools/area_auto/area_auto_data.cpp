#include "tools/area_auto/area_auto_data.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <random>

#include "server/eval_plan.h"
#include "server/host_path.h"
#include "tests/support/plane_adaptive.h"

// The kernels' BRDF in double for the truth (the single source the device compiles too).
namespace kd {
#define GLINT_USE_DOUBLE 1
#include "kernels/smooth_brdf.h"
#undef GLINT_USE_DOUBLE
}  // namespace kd

namespace glint::area_auto {
namespace {

constexpr double kPi = 3.14159265358979323846;

V3 Add(V3 a, V3 b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
V3 Scale(V3 a, double s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
V3 Cross(V3 a, V3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

}  // namespace

std::vector<Config> MakeConfigs(uint64_t seed, int count, int views, int ndf) {
  // mt19937_64 and explicit transforms (not std:: distributions, whose output is
  // implementation-defined) keep the sets identical across standard libraries.
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + uint64_t(ndf));
  auto uniform = [&](double lo, double hi) {
    return lo + (hi - lo) * (double(rng() >> 11) * (1.0 / 9007199254740992.0));
  };
  std::vector<Config> out;
  for (int k = 0; k < count; ++k) {
    Config c;
    c.ndf = ndf;
    c.alpha = std::exp(uniform(std::log(0.01), 0.0));
    const int n = 3 + int(uniform(0, 4));
    const double aspect = uniform(0.3, 1.0), spin = uniform(0, 2 * kPi);
    const double distance = std::exp(uniform(std::log(0.02), std::log(30.0)));
    const double e = uniform(-10, 90) * kPi / 180, t = uniform(-45, 45) * kPi / 180;
    // Plane basis: p3 = the emitting normal (towards the origin, tilted by t about y), p1 x p2
    // = p3 so that counter-clockwise in (p1, p2) is counter-clockwise seen from the origin.
    const V3 centre = Scale({std::cos(e), 0, std::sin(e)}, distance);
    const V3 nrm = {-std::cos(e), 0, -std::sin(e)};
    const V3 p3 = {nrm[0] * std::cos(t) + nrm[2] * std::sin(t), 0,
                   -nrm[0] * std::sin(t) + nrm[2] * std::cos(t)};
    const V3 p2 = {0, 1, 0}, p1 = Cross(p2, p3);
    for (int i = 0; i < n; ++i) {
      const double a = 2 * kPi * i / n;
      const double x = 0.6 * std::cos(a), y = 0.6 * aspect * std::sin(a);
      const double sx = x * std::cos(spin) - y * std::sin(spin);
      const double sy = x * std::sin(spin) + y * std::cos(spin);
      c.polygon.push_back(Add(centre, Add(Scale(p1, sx), Scale(p2, sy))));
    }
    for (int v = 0; v < views; ++v) {
      // Every fourth view in the grazing band (the table's last view bin), its cos theta_o
      // log-uniform down to kGrazingMinCos: uniform theta_o would put 1 view in 18 there and
      // hardly any within a degree of the horizon, where REFERENCE's few nodes miss the
      // lobe's streak along the horizon and LECOCQ's sub-splitting works hardest.
      const bool grazing = v % 4 == 3;
      const double u = uniform(0, 1), ph = uniform(0, 2 * kPi);
      const double z = grazing ? std::exp(std::log(kGrazingMinCos) +
                                          u * (std::log(kGrazingMaxCos) - std::log(kGrazingMinCos)))
                               : std::cos(u * kGrazingFromDeg * kPi / 180);
      const double s = std::sqrt(std::max(0.0, 1 - z * z));
      c.wo.push_back({s * std::cos(ph), s * std::sin(ph), z});
    }
    out.push_back(std::move(c));
  }
  return out;
}

glint::v1::EvaluateRequest MakeRequest(const Config &c, glint::v1::AreaMethod method,
                                       uint32_t samples, uint64_t seed, float budget, bool fp64) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(c.ndf == 2 ? glint::v1::BECKMANN : glint::v1::GGX);
  m->set_alpha_x(float(c.alpha));
  m->set_alpha_y(float(c.alpha));
  for (int k = 0; k < 3; ++k) m->mutable_schlick()->add_f0(1.0f);
  auto *poly = r.add_lights()->mutable_polygon();
  for (const V3 &v : c.polygon)
    for (double x : v) poly->add_vertices(float(x));
  for (int k = 0; k < 3; ++k) poly->add_radiance(1.0f);
  r.set_seed(seed);
  r.set_area_method(method);
  r.set_area_samples(samples);
  r.set_max_relative_error(budget);
  r.set_precision(fp64 ? glint::v1::FP64 : glint::v1::FP32);
  auto *q = r.mutable_queries();
  for (const V3 &w : c.wo)
    for (double x : w) q->add_wo(float(x));
  q->set_count(uint32_t(c.wo.size()));
  return r;
}

std::vector<double> Truth(const Config &c) {
  using glint::test::plane::Vec;
  kd::SmoothMaterial m;
  m.ndf = c.ndf;
  m.alpha_x = m.alpha_y = double(float(c.alpha));  // the request carries alpha as a float
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a = kd::make_real3(1.0, 1.0, 1.0);
  m.fresnel.b = kd::make_real3(0.0, 0.0, 0.0);
  // The vertices and views as the request carries them (floats).
  std::vector<Vec> p;
  for (const V3 &v : c.polygon)
    p.push_back({double(float(v[0])), double(float(v[1])), double(float(v[2]))});
  auto f_cos = [&](Vec wi, Vec o) {
    return kd::smooth_reflect_cos(m, kd::make_real3(wi.x, wi.y, wi.z),
                                  kd::make_real3(o.x, o.y, o.z))
        .x;
  };
  std::vector<double> t;
  for (const V3 &w : c.wo) {
    const Vec wo = {double(float(w[0])), double(float(w[1])), double(float(w[2]))};
    t.push_back(glint::test::plane::PlaneAdaptive(f_cos, wo, p, 1e-5));
  }
  return t;
}

double RelativeError(double x, double truth) {
  if (!std::isfinite(x)) return INFINITY;
  return std::fabs(x - truth) / std::max(truth, kFloor);
}

std::vector<double> HostRed(const glint::v1::EvaluateRequest &r) {
  const EvalPlan plan = MakeEvalPlan(r, r.queries());
  std::vector<float> out(3 * size_t(r.queries().count()));
  HostEvaluate(plan, r.queries(), out.data());
  std::vector<double> red;
  for (uint32_t i = 0; i < r.queries().count(); ++i) red.push_back(out[3 * i]);
  return red;
}

}  // namespace glint::area_auto
