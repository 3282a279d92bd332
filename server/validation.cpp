#include "server/validation.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "server/model_table.h"

#ifdef __SSE2__
#include <immintrin.h>
#endif

namespace glint {
namespace {

using google::protobuf::RepeatedField;

std::string Vec(const float *v, int n) {
  std::ostringstream o;
  o << '(';
  for (int i = 0; i < n; ++i) o << (i ? ", " : "") << v[i];
  o << ')';
  return o.str();
}

bool AllFinite(const float *v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

double Length3(const float *v) {
  return std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
}

// A fixed-size vector field of the material or a light: exactly n finite values.
Status CheckFixed(const RepeatedField<float> &v, int n, const std::string &field) {
  if (v.size() != n) {
    return Status::InvalidArgument(field + ": has " + std::to_string(v.size()) +
                                   " values; expected " + std::to_string(n));
  }
  if (!AllFinite(v.data(), n))
    return Status::InvalidArgument(field + ": " + Vec(v.data(), n) + " is not finite");
  return Status::Ok();
}

Status CheckRange(const RepeatedField<float> &v, int n, const std::string &field, float lo,
                  float hi, const char *expected) {
  Status s = CheckFixed(v, n, field);
  if (!s.ok()) return s;
  for (int i = 0; i < n; ++i) {
    if (!(v[i] >= lo && v[i] <= hi)) {
      return Status::InvalidArgument(field + ": " + Vec(v.data(), n) + "; expected " + expected);
    }
  }
  return Status::Ok();
}

Status CheckUnit(const float *v, const std::string &field, double tol) {
  double len = Length3(v);
  if (std::fabs(len - 1.0) > tol) {
    std::ostringstream o;
    o << field << ": " << Vec(v, 3) << " has length " << len
      << "; expected a unit vector (|length - 1| <= " << tol << ")";
    return Status::InvalidArgument(o.str());
  }
  return Status::Ok();
}

// Light magnitudes (irradiance, intensity, radiance) are accepted up to 3e38, a little below
// FLT_MAX (3.4028e38): the range the stability sweep covers (README "Stability at the
// extremes"). The refusal states both ends: a value between 3e38 and FLT_MAX is >= 0, so
// "expected >= 0" alone contradicted the value it refused (outside-client probe, session 11).
constexpr float kMaxLightMagnitude = 3e38f;
constexpr const char *kLightMagnitudeRange = "3 values in [0, 3e38]";

Status CheckNdfAndRoughness(const glint::v1::Material &m) {
  if (m.ndf() != glint::v1::GGX && m.ndf() != glint::v1::BECKMANN) {
    return Status::InvalidArgument(
        "material.ndf: " +
        (m.ndf() == 0 ? std::string("unset") : "unknown value " + std::to_string(m.ndf())) +
        "; expected GGX or BECKMANN");
  }
  // Roughness below 1e-4 is refused rather than clamped (issue 8). Such a lobe is a mirror to
  // within float precision, and the kernels break down there: the GGX peak f cos_i ~ 1 / (4 pi
  // alpha^2) exceeds the float output at alpha ~ 1e-20 (+Inf for wo = wi = n), alpha_x alpha_y
  // underflows in fp32 at ~1e-23 (NaN for a directional light, MONTE_CARLO and REFERENCE), and
  // the LTC, D_PR and D_H tables end at 1e-4 (data/ltc/ltc_table.h grid_alpha; Lecocq clamps
  // there). Compared in float: 1e-4f, the value a client sends for 1e-4, is accepted.
  for (auto [value, name] :
       {std::pair{m.alpha_x(), "material.alpha_x"}, std::pair{m.alpha_y(), "material.alpha_y"}}) {
    if (!(value >= 1e-4f && value <= 1.0f)) {
      std::ostringstream o;
      o << name << ": " << value
        << "; expected a roughness in [1e-4, 1] (smaller is a mirror the kernels do not "
           "resolve)";
      return Status::InvalidArgument(o.str());
    }
  }
  return Status::Ok();
}

Status CheckMaterial(const glint::v1::Material &m) {
  using glint::v1::Material;
  const Model *model = FindModel(m.model());
  if (!model) {
    std::string expected;
    for (const Model *known : Models())
      expected += std::string(expected.empty() ? "" : " or ") + known->name;
    return Status::InvalidArgument(
        "material.model: " +
        (glint::v1::Model_IsValid(m.model()) && m.model() != 0
             ? glint::v1::Model_Name(m.model())
             : std::string(m.model() == 0 ? "unset"
                                          : "unknown value " + std::to_string(m.model()))) +
        "; expected " + expected);
  }
  // Another model's parameter block is a mistake the client should hear about.
  const auto *reflection = m.GetReflection();
  for (const Model *other : Models()) {
    if (other == model || !other->params_field) continue;
    const auto *field = m.GetDescriptor()->FindFieldByName(other->params_field);
    if (field && reflection->HasField(m, field)) {
      return Status::InvalidArgument("material." + std::string(other->params_field) +
                                     ": set, but material.model is " + model->name + "; expected " +
                                     other->name);
    }
  }
  if (model->validate_params) {
    Status s = model->validate_params(m);
    if (!s.ok()) return s;
  }
  // A model with its own NDF (NORMAL_MAP: the map's P-NDF) ignores ndf and alpha.
  if (model->uses_ndf) {
    Status s = CheckNdfAndRoughness(m);
    if (!s.ok()) return s;
  }
  switch (m.fresnel_case()) {
    case Material::kSchlick:
      return CheckRange(m.schlick().f0(), 3, "material.schlick.f0", 0.0f, 1.0f,
                        "3 values in [0, 1]");
    case Material::kConductor: {
      Status s = CheckRange(m.conductor().eta(), 3, "material.conductor.eta", 1e-6f, 1e6f,
                            "3 values in [1e-6, 1e6]");
      if (!s.ok()) return s;
      return CheckRange(m.conductor().k(), 3, "material.conductor.k", 0.0f, 1e6f,
                        "3 values in [0, 1e6]");
    }
    case Material::kDielectric: {
      // F_dielectric (kernels/fresnel.h) is exact for any ior > 0 in both precisions
      // (tested down to the smallest float); 1e6 keeps ior^2 far from fp32 overflow.
      float ior = m.dielectric().ior();
      if (!(ior > 0.0f && ior < 1e6f)) {
        std::ostringstream o;
        o << "material.dielectric.ior: " << ior
          << "; expected a relative index of refraction in (0, 1e6)";
        return Status::InvalidArgument(o.str());
      }
      return Status::Ok();
    }
    default:
      return Status::InvalidArgument(
          "material.fresnel: unset; expected one of schlick, conductor, dielectric");
  }
}

// A polygon light: 3..16 finite vertices, planar, convex, not degenerate; radiance 3 finite
// values in [0, 3e38]. Tolerances are relative to the polygon's size (its largest vertex distance
// from the centroid, `size`): planar when every vertex is within 1e-3 * size of the plane through
// the centroid with Newell's normal; degenerate (collinear or zero area) when the area is below
// 1e-9 * size^2. Convex: every corner turns the same way about the normal (collinear corners,
// within 1e-6 relative, are allowed) and the corners turn once in total, which also refuses
// self-intersecting (star) outlines. Concave polygons are refused, not split.
Status CheckPolygon(const glint::v1::PolygonLight &p, const std::string &f) {
  const std::string fv = f + ".vertices";
  const int nf = p.vertices_size();
  if (nf % 3 != 0 || nf < 9 || nf > 48) {
    return Status::InvalidArgument(fv + ": has " + std::to_string(nf) +
                                   " values; expected 3 to 16 vertices of 3 values (x, y, z)");
  }
  const int n = nf / 3;
  if (!AllFinite(p.vertices().data(), nf))
    return Status::InvalidArgument(fv + ": a vertex is not finite");
  Status s =
      CheckRange(p.radiance(), 3, f + ".radiance", 0.0f, kMaxLightMagnitude, kLightMagnitudeRange);
  if (!s.ok()) return s;
  auto vert = [&](int i, int c) { return double(p.vertices((i % n) * 3 + c)); };
  double centroid[3] = {0, 0, 0};
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) centroid[c] += vert(i, c) / n;
  double size = 0, normal[3] = {0, 0, 0};
  for (int i = 0; i < n; ++i) {
    double a[3], b[3];
    for (int c = 0; c < 3; ++c) {
      a[c] = vert(i, c) - centroid[c];
      b[c] = vert(i + 1, c) - centroid[c];
    }
    size = std::max(size, std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]));
    normal[0] += a[1] * b[2] - a[2] * b[1];  // Newell: sum of a x b = 2 * area * unit normal
    normal[1] += a[2] * b[0] - a[0] * b[2];
    normal[2] += a[0] * b[1] - a[1] * b[0];
  }
  const double twice_area =
      std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
  if (!(size > 0) || !(twice_area > 2e-9 * size * size)) {
    return Status::InvalidArgument(fv + ": degenerate polygon (zero area or collinear vertices)");
  }
  for (double &c : normal) c /= twice_area;
  for (int i = 0; i < n; ++i) {
    double d = 0;
    for (int c = 0; c < 3; ++c) d += (vert(i, c) - centroid[c]) * normal[c];
    if (std::fabs(d) > 1e-3 * size) {
      std::ostringstream o;
      o << fv << ": not planar (vertex " << i << " is " << std::fabs(d)
        << " from the polygon's plane; tolerance 1e-3 x its size " << size << ")";
      return Status::InvalidArgument(o.str());
    }
  }
  double turning = 0;
  for (int i = 0; i < n; ++i) {
    double e0[3], e1[3];
    for (int c = 0; c < 3; ++c) {
      e0[c] = vert(i + 1, c) - vert(i, c);
      e1[c] = vert(i + 2, c) - vert(i + 1, c);
    }
    double cr[3] = {e0[1] * e1[2] - e0[2] * e1[1], e0[2] * e1[0] - e0[0] * e1[2],
                    e0[0] * e1[1] - e0[1] * e1[0]};
    double sin_part = cr[0] * normal[0] + cr[1] * normal[1] + cr[2] * normal[2];
    double cos_part = e0[0] * e1[0] + e0[1] * e1[1] + e0[2] * e1[2];
    double l0 = std::sqrt(e0[0] * e0[0] + e0[1] * e0[1] + e0[2] * e0[2]);
    double l1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    if (sin_part < -1e-6 * l0 * l1) {
      return Status::InvalidArgument(
          fv + ": not convex at vertex " + std::to_string((i + 1) % n) +
          "; concave polygons are refused (split them into convex ones)");
    }
    turning += std::atan2(sin_part, cos_part);
  }
  if (std::fabs(turning - 2 * 3.14159265358979323846) > 1e-3) {
    return Status::InvalidArgument(
        fv + ": not convex (the outline winds more than once); concave polygons are refused");
  }
  return Status::Ok();
}

Status CheckLight(const glint::v1::Light &light, const std::string &field, double tol) {
  if (light.has_directional()) {
    const auto &d = light.directional();
    const std::string f = field + ".directional";
    Status s = CheckFixed(d.direction(), 3, f + ".direction");
    if (s.ok()) s = CheckUnit(d.direction().data(), f + ".direction", tol);
    if (s.ok())
      s = CheckRange(d.irradiance(), 3, f + ".irradiance", 0.0f, kMaxLightMagnitude,
                     kLightMagnitudeRange);
    if (s.ok() && !(d.cone_half_angle_deg() >= 0.0f && d.cone_half_angle_deg() <= 90.0f)) {
      std::ostringstream o;
      o << f << ".cone_half_angle_deg: " << d.cone_half_angle_deg() << "; expected [0, 90]";
      s = Status::InvalidArgument(o.str());
    }
    return s;
  }
  if (light.has_point()) {
    const auto &p = light.point();
    const std::string f = field + ".point";
    Status s = CheckFixed(p.position(), 3, f + ".position");
    if (s.ok())
      s = CheckRange(p.intensity(), 3, f + ".intensity", 0.0f, kMaxLightMagnitude,
                     kLightMagnitudeRange);
    if (s.ok() && !(p.radius() >= 0.0f && std::isfinite(p.radius()))) {
      std::ostringstream o;
      o << f << ".radius: " << p.radius() << "; expected a finite value >= 0";
      s = Status::InvalidArgument(o.str());
    }
    return s;
  }
  if (light.has_polygon()) return CheckPolygon(light.polygon(), field + ".polygon");
  return Status::InvalidArgument(field +
                                 ": no light kind set; expected directional, point or polygon");
}

// An optional per-query array: empty, or `per` values for each query.
Status CheckArraySize(const RepeatedField<float> &v, uint32_t count, int per, bool required,
                      const std::string &field) {
  if (v.empty() && !required) return Status::Ok();
  uint64_t want = uint64_t(count) * per;
  if (uint64_t(v.size()) != want) {
    return Status::InvalidArgument(
        field + ": has " + std::to_string(v.size()) + " values; expected " + std::to_string(per) +
        " x count = " + std::to_string(want) + (required ? "" : " (or none)"));
  }
  return Status::Ok();
}

// True when every value of `v` (`floats` of them) is finite and, for a unit array (3 floats per
// query), every vector's squared length lies inside [(1 - tol)^2, (1 + tol)^2] narrowed by the
// rounding error of computing it (below): then the exact check (in double) passes too. Without
// branches, so the loop vectorises; false means "look closer" (the exact loop decides), never
// "invalid". A NaN or infinite component makes the squared length NaN or infinite, which fails the
// comparison.
bool ClearlyValid(const float *v, uint64_t floats, bool unit, double tol) {
  bool ok = true;
  if (!unit) {
    uint64_t k = 0;
#ifdef __SSE2__
    // Four floats at a time (the compilers leave the loop below scalar).
    const __m128 zero = _mm_setzero_ps();
    __m128 good = _mm_cmpeq_ps(zero, zero);
    for (; k + 4 <= floats; k += 4) {
      const __m128 a = _mm_loadu_ps(v + k);
      good = _mm_and_ps(good, _mm_cmpeq_ps(_mm_sub_ps(a, a), zero));
    }
    ok = _mm_movemask_ps(good) == 0xf;
#endif
    for (; k < floats; ++k) ok &= (v[k] - v[k] == 0.0f);  // false for NaN, +-Inf
    return ok;
  }
  if (!(tol > 0.0 && tol < 1.0)) return false;
  // In float (twice the lanes of double): x^2 + y^2 + z^2 of floats is within a relative
  // 4 * 2^-24 < 2.4e-7 of the exact squared length (three rounded products, two rounded sums;
  // Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed., eq. 3.4-3.5), and the bounds
  // are narrowed by 1e-6 relative, which also covers rounding them to float. A square that
  // overflows to Inf or underflows fails the comparison and goes to the exact loop.
  const float lo = float((1.0 - tol) * (1.0 - tol) * (1.0 + 1e-6));
  const float hi = float((1.0 + tol) * (1.0 + tol) * (1.0 - 1e-6));
  uint64_t k = 0;
#ifdef __SSE2__
  // Four vectors (12 floats, three loads) at a time: the compilers leave the stride-3 loop below
  // scalar. Squares elementwise, then the three squares of each vector gathered into lanes and
  // summed in the scalar loop's order, (x^2 + y^2) + z^2.
  const __m128 vlo = _mm_set1_ps(lo), vhi = _mm_set1_ps(hi);
  __m128 good = _mm_castsi128_ps(_mm_set1_epi32(-1));
  for (; k + 12 <= floats; k += 12) {
    const __m128 q0 = _mm_loadu_ps(v + k), q1 = _mm_loadu_ps(v + k + 4),
                 q2 = _mm_loadu_ps(v + k + 8);
    const __m128 s0 = _mm_mul_ps(q0, q0), s1 = _mm_mul_ps(q1, q1), s2 = _mm_mul_ps(q2, q2);
    // s0 = x0 y0 z0 x1, s1 = y1 z1 x2 y2, s2 = z2 x3 y3 z3 (squared).
    const __m128 x01 = _mm_shuffle_ps(s0, s1, _MM_SHUFFLE(0, 0, 3, 0));  // x0 x1 y1 y1
    const __m128 x23 = _mm_shuffle_ps(s1, s2, _MM_SHUFFLE(0, 1, 0, 2));  // x2 y1 x3 z2
    const __m128 x = _mm_shuffle_ps(x01, x23, _MM_SHUFFLE(2, 0, 1, 0));  // x0 x1 x2 x3
    const __m128 y01 = _mm_shuffle_ps(s0, s1, _MM_SHUFFLE(0, 0, 0, 1));  // y0 x0 y1 y1
    const __m128 y23 = _mm_shuffle_ps(s1, s2, _MM_SHUFFLE(0, 2, 0, 3));  // y2 y1 y3 z2
    const __m128 y = _mm_shuffle_ps(y01, y23, _MM_SHUFFLE(2, 0, 2, 0));  // y0 y1 y2 y3
    const __m128 z01 = _mm_shuffle_ps(s0, s1, _MM_SHUFFLE(1, 1, 2, 2));  // z0 z0 z1 z1
    const __m128 z23 = _mm_shuffle_ps(s2, s2, _MM_SHUFFLE(3, 3, 0, 0));  // z2 z2 z3 z3
    const __m128 z = _mm_shuffle_ps(z01, z23, _MM_SHUFFLE(2, 0, 2, 0));  // z0 z1 z2 z3
    const __m128 sum = _mm_add_ps(_mm_add_ps(x, y), z);
    good = _mm_and_ps(good, _mm_and_ps(_mm_cmpge_ps(sum, vlo), _mm_cmple_ps(sum, vhi)));
  }
  ok = _mm_movemask_ps(good) == 0xf;
#endif
  for (; k + 2 < floats; k += 3) {
    const float s = v[k] * v[k] + v[k + 1] * v[k + 1] + v[k + 2] * v[k + 2];
    ok &= (s >= lo) & (s <= hi);
  }
  return ok;
}

std::string Indexed(const char *field, uint64_t i) {
  return std::string(field) + "[" + std::to_string(i) + "]";
}

// AUTO's error budget (kernels/area/area_auto.h): required with AUTO, finite and > 0, and
// only with AUTO; AUTO picks its own sample counts, so area_samples must stay 0.
Status CheckAreaBudget(const glint::v1::EvaluateRequest &request) {
  const float budget = request.max_relative_error();
  if (request.area_method() != glint::v1::AUTO) {
    if (budget != 0.0f) {
      return Status::InvalidArgument(
          "max_relative_error: " + std::to_string(budget) +
          " is only read with area_method AUTO; set area_method AUTO or leave it 0");
    }
    return Status::Ok();
  }
  if (!std::isfinite(budget) || !(budget > 0.0f)) {
    return Status::InvalidArgument(
        "max_relative_error: " + std::to_string(budget) + (budget == 0.0f ? " (unset)" : "") +
        "; area_method AUTO needs the relative error allowed per query and light, a finite "
        "number > 0 (e.g. 0.05 for 5%)");
  }
  if (request.area_samples() != 0) {
    return Status::InvalidArgument(
        "area_samples: " + std::to_string(request.area_samples()) +
        " with area_method AUTO; AUTO picks its own sample counts from max_relative_error "
        "(leave area_samples 0)");
  }
  return Status::Ok();
}

}  // namespace

Status ValidateSettings(const glint::v1::EvaluateRequest &request, const ValidationLimits &limits) {
  if (!request.has_material()) return Status::InvalidArgument("material: unset");
  Status s = CheckMaterial(request.material());
  if (!s.ok()) return s;
  if (request.lights_size() > int(limits.max_lights)) {
    return Status::InvalidArgument("lights: " + std::to_string(request.lights_size()) +
                                   " lights; at most " + std::to_string(limits.max_lights) +
                                   " per request");
  }
  const Model *model = FindModel(request.material().model());
  for (int l = 0; l < request.lights_size(); ++l) {
    const std::string field = Indexed("lights", uint64_t(l));
    s = CheckLight(request.lights(l), field, limits.unit_tolerance);
    if (s.ok() && model->validate_light)
      s = model->validate_light(request.material(), request.lights(l), field);
    if (!s.ok()) return s;
  }
  switch (request.area_method()) {
    case glint::v1::AREA_METHOD_UNSPECIFIED:
    case glint::v1::LTC:
    case glint::v1::REFERENCE:
    case glint::v1::MONTE_CARLO:
    case glint::v1::LECOCQ:
    case glint::v1::LECOCQ_PEARSON:
    case glint::v1::AUTO:
      break;
    default:
      return Status::InvalidArgument(
          "area_method: unknown value " + std::to_string(request.area_method()) +
          "; expected LTC, LECOCQ, LECOCQ_PEARSON, MONTE_CARLO, REFERENCE or AUTO");
  }
  s = CheckAreaBudget(request);
  if (!s.ok()) return s;
  if (request.area_samples() > 1024) {
    return Status::InvalidArgument("area_samples: " + std::to_string(request.area_samples()) +
                                   "; expected at most 1024 (0 = default 64)");
  }
  switch (request.precision()) {
    case glint::v1::PRECISION_UNSPECIFIED:
    case glint::v1::FP32:
      break;
    case glint::v1::FP64:
      if (!limits.fp64_available) {
        return Status::InvalidArgument(
            "precision: FP64 requested but the device has no cl_khr_fp64; use FP32");
      }
      break;
    default:
      return Status::InvalidArgument("precision: unknown value " +
                                     std::to_string(request.precision()) +
                                     "; expected FP32 or FP64");
  }
  return Status::Ok();
}

namespace {

Status CheckQueryCount(uint32_t n, const ValidationLimits &limits, bool streamed) {
  if (n == 0) return Status::InvalidArgument("queries.count: 0; expected at least one query");
  if (n > limits.max_batch) {
    return Status::InvalidArgument(
        "queries.count: " + std::to_string(n) + " exceeds the limit of " +
        std::to_string(limits.max_batch) + " queries per " +
        (streamed ? "stream chunk; send smaller chunks"
                  : "call; send the batch over EvaluateStream in chunks of at most " +
                        std::to_string(limits.max_batch)));
  }
  return Status::Ok();
}

}  // namespace

Status ValidateQueries(const glint::v1::QueryBatch &q, bool has_lights,
                       const ValidationLimits &limits, uint64_t first_query, bool streamed) {
  const uint32_t n = q.count();
  if (Status s = CheckQueryCount(n, limits, streamed); !s.ok()) return s;
  Status s = CheckArraySize(q.wo(), n, 3, true, "queries.wo");
  if (s.ok()) s = CheckArraySize(q.uv(), n, 2, false, "queries.uv");
  if (s.ok()) s = CheckArraySize(q.footprint(), n, 4, false, "queries.footprint");
  if (s.ok()) s = CheckArraySize(q.wi(), n, 3, false, "queries.wi");
  if (s.ok()) s = CheckArraySize(q.position(), n, 3, false, "queries.position");
  if (s.ok()) s = CheckArraySize(q.normal(), n, 3, false, "queries.normal");
  if (s.ok()) s = CheckArraySize(q.tangent(), n, 3, false, "queries.tangent");
  if (!s.ok()) return s;

  return ValidateQueryView(QueryView::Of(q), has_lights, limits, first_query, streamed);
}

Status ValidateQueryViewShape(const QueryView &q, bool has_lights, const ValidationLimits &limits,
                              bool streamed) {
  if (Status s = CheckQueryCount(q.count, limits, streamed); !s.ok()) return s;
  if (!q.wo) return Status::InvalidArgument("queries.wo: absent; expected 3 x count values");
  const bool frame = q.normal != nullptr;
  if (frame != (q.position != nullptr) || frame != (q.tangent != nullptr)) {
    return Status::InvalidArgument(
        "queries.position/normal/tangent: give all three arrays (a world-space frame) or none");
  }
  const bool probe = q.wi != nullptr;
  if (probe && has_lights) {
    return Status::InvalidArgument(
        "lights: a BRDF probe batch (queries.wi set) must carry no lights");
  }
  if (!probe && !has_lights) {
    return Status::InvalidArgument(
        "lights: empty; a batch without queries.wi needs at least one light");
  }
  return Status::Ok();
}

Status ValidateQueryView(const QueryView &q, bool has_lights, const ValidationLimits &limits,
                         uint64_t first_query, bool streamed) {
  if (Status s = ValidateQueryViewShape(q, has_lights, limits, streamed); !s.ok()) return s;
  const uint32_t n = q.count;
  const bool frame = q.normal != nullptr;

  const double tol = limits.unit_tolerance;
  struct Array {
    const float *v;  // null: absent
    int per;
    const char *name;
    bool unit;
  };
  const Array arrays[] = {{q.wo, 3, "queries.wo", true},
                          {q.wi, 3, "queries.wi", true},
                          {q.uv, 2, "queries.uv", false},
                          {q.footprint, 4, "queries.footprint", false},
                          {q.position, 3, "queries.position", false},
                          {q.normal, 3, "queries.normal", true},
                          {q.tangent, 3, "queries.tangent", true}};
  // Fast acceptance (issue 12): a batch without a frame whose arrays are all ClearlyValid needs
  // no per-query loop; any other batch goes through the exact loop, which also names the first
  // bad query. Large batches are scanned in query ranges on several threads (a pure read; the
  // verdict is the AND of the ranges', so it does not depend on the split).
  if (!frame) {
    auto clear_range = [&](uint32_t begin, uint32_t end) {
      bool clear = true;
      for (const Array &a : arrays)
        if (a.v)
          clear = clear && ClearlyValid(a.v + uint64_t(begin) * a.per,
                                        uint64_t(end - begin) * a.per, a.unit, tol);
      return clear;
    };
    constexpr uint32_t kPerThread = 1u << 17;  // below this a thread costs more than it saves
    const uint32_t threads =
        std::clamp<uint32_t>(n / kPerThread, 1, std::max(1u, std::thread::hardware_concurrency()));
    bool clear = true;
    if (threads == 1) {
      clear = clear_range(0, n);
    } else {
      std::vector<char> verdict(threads, 0);
      std::vector<std::thread> pool;
      auto bounds = [&](uint32_t t) { return uint32_t(uint64_t(n) * t / threads); };
      for (uint32_t t = 1; t < threads; ++t)
        pool.emplace_back([&, t] { verdict[t] = clear_range(bounds(t), bounds(t + 1)); });
      verdict[0] = clear_range(0, bounds(1));
      for (std::thread &th : pool) th.join();
      for (char v : verdict) clear = clear && v;
    }
    if (clear) return Status::Ok();
  }
  // Query-major order so the reported index is the first bad query overall.
  for (uint32_t i = 0; i < n; ++i) {
    for (const Array &a : arrays) {
      if (!a.v) continue;
      const float *v = a.v + uint64_t(i) * a.per;
      if (!AllFinite(v, a.per)) {
        return Status::InvalidArgument(Indexed(a.name, first_query + i) + ": " + Vec(v, a.per) +
                                       " is not finite");
      }
      // The field name is built only for a query that fails: building it for every query took
      // most of the time of a 1M-probe request (issue 12, bench_transport).
      if (a.unit && std::fabs(Length3(v) - 1.0) > tol)
        return CheckUnit(v, Indexed(a.name, first_query + i), tol);
    }
    if (frame) {
      const float *nv = q.normal + 3 * uint64_t(i);
      const float *tv = q.tangent + 3 * uint64_t(i);
      double c = (double(nv[0]) * tv[0] + double(nv[1]) * tv[1] + double(nv[2]) * tv[2]) /
                 (Length3(nv) * Length3(tv));
      if (std::fabs(c) > limits.max_tangent_normal_cos) {
        std::ostringstream o;
        o << Indexed("queries.tangent", first_query + i) << ": " << Vec(tv, 3)
          << " is parallel to the normal " << Vec(nv, 3) << " (|cos| = " << std::fabs(c)
          << "); expected a tangent with |cos| <= " << limits.max_tangent_normal_cos;
        return Status::InvalidArgument(o.str());
      }
    }
  }
  return Status::Ok();
}

Status ValidateQueriesForModel(const glint::v1::QueryBatch &q,
                               const glint::v1::EvaluateRequest &settings, uint64_t first_query) {
  const Model *model = FindModel(settings.material().model());
  if (!model || !model->validate_queries) return Status::Ok();
  return model->validate_queries(settings, q, first_query);
}

}  // namespace glint

namespace glint {

Status ValidateLaterChunkSettings(const glint::v1::EvaluateRequest &r) {
  std::string field, value;
  if (r.lights_size() > 0) {
    field = "lights";
    value = std::to_string(r.lights_size()) + " lights";
  } else if (r.precision() != glint::v1::PRECISION_UNSPECIFIED) {
    field = "precision";
    value = "precision " + std::to_string(int(r.precision()));
  } else if (r.seed() != 0) {
    field = "seed";
    value = "seed " + std::to_string(r.seed());
  } else if (r.area_method() != glint::v1::AREA_METHOD_UNSPECIFIED) {
    field = "area_method";
    value = "area_method " + std::to_string(int(r.area_method()));
  } else if (r.area_samples() != 0) {
    field = "area_samples";
    value = "area_samples " + std::to_string(r.area_samples());
  } else if (r.max_relative_error() != 0.0f) {
    field = "max_relative_error";
    value = "max_relative_error " + std::to_string(r.max_relative_error());
  } else {
    return Status::Ok();
  }
  return Status::InvalidArgument(
      "request." + field + ": " + value +
      " in a chunk without a material; later chunks reuse the first chunk's settings and "
      "carry only queries (send a material to replace material, lights, precision, seed, "
      "area_method, area_samples and max_relative_error together)");
}

}  // namespace glint
