// Stability sweep (issue 8): random requests drawn from the whole space that validation accepts,
// edges included, for every model x area method x precision x engine (OpenCL device and host
// path). Every request must pass validation (the sweep samples what clients may send) and every
// output must be finite and >= 0. Where the value is well conditioned, fp32 must also agree with
// fp64 within float epsilon times a stated condition factor.
//
// The edges drawn on purpose (DESIGN.md "Stability at the extremes"): alpha 1e-4 and 1 (and
// anisotropy up to 1e4), Fresnel parameters at both ends of their ranges, binomial density from
// the smallest positive double to 1e30 and its other knobs at their limits, lights at distances
// 1e-6 and 1e6, sphere lights enclosing the shading point, polygons touching it (a vertex at the
// shading point), with an edge through it, crossing it (in their plane) or passing within 1e-6,
// polygons in the surface's plane or straddling the horizon, grazing and below-horizon wo / wi /
// lights, unit vectors at the edge of the length tolerance, tangents almost parallel to the
// normal, zero / rank-1 / huge footprints, uv up to the float range, light magnitudes from 0 to
// the float range.
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "data/ltc/ltc_table.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/normal_map_store.h"
#include "server/validation.h"
#include "tests/support/device_engine_fixture.h"

// Last: the kernels' LTC lookup in double (compat.h defines the macro GLINT_R(x)).
namespace sweep_k {
#define GLINT_USE_DOUBLE 1
#include "kernels/area/ltc_lookup.h"
}  // namespace sweep_k

namespace glint {
namespace {

using glint::v1::EvaluateRequest;
using glint::v1::QueryBatch;
using Vec3 = std::array<double, 3>;

constexpr double kPi = 3.14159265358979323846;
constexpr float kFloatMax = std::numeric_limits<float>::max();

Vec3 Add(Vec3 a, Vec3 b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
Vec3 Sub(Vec3 a, Vec3 b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
Vec3 Scale(Vec3 a, double s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
double Dot(Vec3 a, Vec3 b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
Vec3 Cross(Vec3 a, Vec3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 Normalize(Vec3 a) {
  return Scale(a, 1.0 / std::sqrt(Dot(a, a)));
}

// Kernel-specialising choices of a request (KernelSpec): on the device every distinct set is a
// separate OpenCL build (1 .. 10 s each on PoCL), so the device sweep uses a few fixed sets while
// the host path (no build) draws them freely.
struct Kinds {
  v1::Ndf ndf = v1::GGX;
  int fresnel = 0;  // 0 Schlick, 1 conductor, 2 dielectric
  bool framed = false;
  bool probe = false;
};

// The device's kernel variants: one lit smooth set (glint_smooth + glint_smooth_area), one probe
// set, one binomial set, one CHERMAIN set (Beckmann, conductor, framed) and one KEMPPINEN set (GGX,
// Schlick, framed; a quarter probes), the same in both precisions so that the fp32-vs-fp64 test
// below reuses the smooth ones: a few dozen seconds of OpenCL builds cold, then cached. Between
// them they cover both NDFs, the three Fresnel kinds and framed and unframed queries; the host
// path draws every combination.
Kinds DeviceKinds(v1::Model model, int request) {
  if (model == v1::BINOMIAL) return Kinds{v1::BECKMANN, 0, false, false};
  if (model == v1::CHERMAIN) return Kinds{v1::BECKMANN, 1, true, false};  // Beckmann only
  if (model == v1::KEMPPINEN) return Kinds{v1::GGX, 0, true, request % 4 == 3};
  if (model == v1::NORMAL_MAP) return Kinds{v1::GGX, 0, true, request % 4 == 3};
  const bool probe = request % 4 == 3;  // a quarter of the smooth requests are BRDF probes
  return probe ? Kinds{v1::BECKMANN, 1, true, true} : Kinds{v1::GGX, 2, true, false};
}

// The NORMAL_MAP model's map in the sweep: 16 x 16 bumps with normals up to 60 degrees from z,
// in the process's normal-map store (SetUpTestSuite).
std::string sweep_normal_map_digest;

class RequestSampler {
 public:
  explicit RequestSampler(uint64_t seed) : rng_(seed) {}

  double U(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng_); }
  bool Chance(double p) { return U(0.0, 1.0) < p; }
  int Int(int a, int b) { return std::uniform_int_distribution<int>(a, b)(rng_); }
  double LogU(double a, double b) { return std::exp(U(std::log(a), std::log(b))); }
  double Sign() { return Chance(0.5) ? 1.0 : -1.0; }
  // [lo, hi] with each edge drawn with probability p_edge, otherwise log-uniform.
  double LogRange(double lo, double hi, double p_edge = 0.1) {
    double x = U(0.0, 1.0);
    if (x < p_edge) return lo;
    if (x < 2 * p_edge) return hi;
    return LogU(lo, hi);
  }
  Vec3 Sphere() {
    std::normal_distribution<double> g;
    for (;;) {
      Vec3 v = {g(rng_), g(rng_), g(rng_)};
      if (Dot(v, v) > 1e-6) return Normalize(v);
    }
  }
  // A local direction: uniform, upper hemisphere, grazing (cos 0 .. 1e-2), normal, or below.
  Vec3 LocalDirection() {
    double x = U(0.0, 1.0);
    if (x < 0.3) return Sphere();
    if (x < 0.6) {
      Vec3 v = Sphere();
      v[2] = std::fabs(v[2]);
      return v;
    }
    if (x < 0.85) {
      const double z[] = {0.0, 1e-7, -1e-7, 1e-5, 1e-3, U(0.0, 1e-2)};
      double c = z[Int(0, 5)], phi = U(0.0, 2 * kPi), s = std::sqrt(1 - c * c);
      return {s * std::cos(phi), s * std::sin(phi), c};
    }
    if (x < 0.95) return {0.0, 0.0, 1.0};
    return {0.0, 0.0, -1.0};
  }
  // A unit vector as a client may send it: length within the tolerance 1e-3 (edges included).
  void AddUnit(Vec3 v, google::protobuf::RepeatedField<float> *out) {
    double x = U(0.0, 1.0);
    double s = x < 0.6   ? 1.0
               : x < 0.7 ? 1.0 + 0.999e-3
               : x < 0.8 ? 1.0 - 0.999e-3
                         : 1.0 + U(-0.999e-3, 0.999e-3);
    for (double c : v) out->Add(float(c * s));
  }
  void AddVec(Vec3 v, google::protobuf::RepeatedField<float> *out) {
    for (double c : v) out->Add(float(c));
  }
  // An RGB magnitude (irradiance, intensity, radiance): 0 .. the largest accepted, edges incl.
  void AddMagnitude(google::protobuf::RepeatedField<float> *out) {
    double x = U(0.0, 1.0);
    for (int c = 0; c < 3; ++c) {
      double m = x < 0.05 ? 0.0 : x < 0.08 ? 3e38 : Chance(0.1) ? 0.0 : LogU(1e-6, 1e6);
      out->Add(float(m));
    }
  }

  float Alpha() { return float(LogRange(1e-4, 1.0, 0.12)); }

  void Material(v1::Model model, const Kinds &k, v1::Material *m) {
    m->set_model(model);
    m->set_ndf(model == v1::CHERMAIN ? v1::BECKMANN : k.ndf);
    m->set_alpha_x(Alpha());
    m->set_alpha_y(Chance(0.3) ? m->alpha_x() : Alpha());
    if (k.fresnel == 0) {
      for (int c = 0; c < 3; ++c) {
        double x = U(0.0, 1.0);
        m->mutable_schlick()->add_f0(float(x < 0.1 ? 0.0 : x < 0.2 ? 1.0 : U(0.0, 1.0)));
      }
    } else if (k.fresnel == 1) {
      for (int c = 0; c < 3; ++c) {
        m->mutable_conductor()->add_eta(float(LogRange(1e-6, 1e6)));
        m->mutable_conductor()->add_k(float(Chance(0.15) ? 0.0 : LogRange(1e-6, 1e6)));
      }
    } else {
      m->mutable_dielectric()->set_ior(float(LogRange(kIorMin, kIorMax)));
    }
    if (model == v1::BINOMIAL) {
      auto *b = m->mutable_binomial();
      double x = U(0.0, 1.0);
      b->set_density(x < 0.05   ? std::numeric_limits<double>::denorm_min()
                     : x < 0.15 ? 1e30
                                : LogU(1e-6, 1e30));
      b->set_p_mode(Chance(0.5)   ? v1::AREA
                    : Chance(0.5) ? v1::HEURISTIC_R
                                  : v1::P_MODE_UNSPECIFIED);
      x = U(0.0, 1.0);
      b->set_r(float(x < 0.2 ? 0.0 : x < 0.25 ? 1e-45 : LogRange(1e-6, 1e6)));
      x = U(0.0, 1.0);
      b->set_normal_threshold(float(x < 0.2 ? 0.0 : x < 0.3 ? 1.0 : x < 0.4 ? 40.0 : U(1, 40)));
      x = U(0.0, 1.0);
      b->set_slope_cell(float(x < 0.2 ? 0.0 : x < 0.25 ? 1e-45 : LogRange(1e-6, 1e3)));
    }
    if (model == v1::CHERMAIN) {  // ranges of models/chermain/chermain_model.cpp
      auto *c = m->mutable_chermain();
      double x = U(0.0, 1.0);
      c->set_log_density(float(x < 0.1 ? 0.0 : x < 0.2 ? 60.0 : U(0.0, 60.0)));
      x = U(0.0, 1.0);
      c->set_relative_area(float(x < 0.2 ? 0.0 : x < 0.3 ? 1e-6 : x < 0.4 ? 1.0 : U(0.0, 1.0)));
      x = U(0.0, 1.0);
      c->set_density_randomisation(float(x < 0.2 ? 0.0 : x < 0.3 ? 10.0 : U(0.0, 10.0)));
      x = U(0.0, 1.0);
      c->set_max_anisotropy(float(x < 0.2 ? 0.0 : x < 0.3 ? 1.0 : x < 0.4 ? 16.0 : U(1.0, 16.0)));
      const uint32_t sizes[] = {0, 16, 64, 192, 512};
      c->set_dictionary_size(sizes[Int(0, 4)]);
      for (int i = 3 * Int(0, 8); i > 0; --i) c->add_colors(float(Chance(0.2) ? 0.0 : U(0.0, 1.0)));
    }
    if (model == v1::NORMAL_MAP) {  // ranges of models/normal_map/normal_map_model.cpp
      auto *p = m->mutable_normal_map();
      p->set_digest(sweep_normal_map_digest);
      double x = U(0.0, 1.0);
      p->set_intrinsic_roughness(float(x < 0.2   ? 0.0
                                       : x < 0.3 ? 1e-4
                                       : x < 0.4 ? 0.5
                                                 : LogU(1e-4, 0.5)));
      x = U(0.0, 1.0);
      p->set_cutoff_sigma(float(x < 0.2 ? 0.0 : x < 0.3 ? 2.0 : x < 0.4 ? 10.0 : U(2.0, 10.0)));
      const uint32_t subdivisions[] = {0, 1, 4};
      p->set_subdivision(subdivisions[Int(0, 2)]);
    }
    if (model == v1::KEMPPINEN) {  // ranges of models/kemppinen/kemppinen_model.cpp
      auto *p = m->mutable_kemppinen();
      double x = U(0.0, 1.0);
      p->set_density(x < 0.1 ? 1e-6 : x < 0.2 ? 1e30 : LogU(1e-6, 1e30));
      x = U(0.0, 1.0);
      p->set_microroughness(float(x < 0.2   ? 0.0
                                  : x < 0.3 ? 1e-5
                                  : x < 0.4 ? 1.0
                                            : LogU(1e-5, 1.0)));
      x = U(0.0, 1.0);
      p->set_filter_size(float(x < 0.2 ? 0.0 : x < 0.3 ? 0.1 : x < 0.4 ? 4.0 : U(0.1, 4.0)));
      const uint32_t neighbors[] = {0, 1, 4, 9, 16};
      p->set_neighbors(neighbors[Int(0, 4)]);
      x = U(0.0, 1.0);
      p->set_anisotropy(float(x < 0.2 ? 0.0 : x < 0.3 ? 0.05 : x < 0.4 ? 20.0 : LogU(0.05, 20.0)));
      for (int i = 3 * Int(0, 2); i > 0; --i) p->add_colors(float(Chance(0.2) ? 1.0 : U(0.0, 1.0)));
    }
  }

  // A convex polygon in the (x, y) plane: n vertices on an ellipse of semi-axes (1, squash),
  // squash down to 1e-3, at increasing angles whose gaps differ by at most 4x, so that no corner
  // is close enough to collinear for float rounding to make validation see it concave.
  std::vector<Vec3> Polygon2D(int n) {
    std::vector<double> gaps(static_cast<size_t>(n));
    double sum = 0;
    for (double &g : gaps) sum += (g = U(1.0, 4.0));
    double squash = Chance(0.3) ? LogU(1e-3, 1.0) : 1.0, angle = U(0.0, 2 * kPi);
    std::vector<Vec3> out;
    for (double g : gaps) {
      out.push_back({std::cos(angle), squash * std::sin(angle), 0.0});
      angle += 2 * kPi * g / sum;
    }
    return out;
  }

  void PolygonLight(v1::PolygonLight *p, Vec3 anchor) {
    const int n = Int(3, 16);
    std::vector<Vec3> poly = Polygon2D(n);
    // Plane orientation: random; in the surface's plane (normal +-z); vertical (straddles the
    // horizon).
    Vec3 normal;
    double x = U(0.0, 1.0);
    if (x < 0.6) {
      normal = Sphere();
    } else if (x < 0.8) {
      normal = {0.0, 0.0, Sign()};
    } else {
      double phi = U(0.0, 2 * kPi);
      normal = {std::cos(phi), std::sin(phi), 0.0};
    }
    Vec3 helper = std::fabs(normal[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    Vec3 e1 = Normalize(Cross(normal, helper)), e2 = Cross(normal, e1);
    // Size relative to the distance and to the anchor's coordinates: validation's planarity
    // tolerance is 1e-3 x the size, so a polygon smaller than ~1e-3 x its coordinates is not
    // representable in float (its rounded vertices are refused as not planar).
    const double dist = LogRange(1e-6, 1e6);
    const double size = std::max(dist * LogRange(1e-3, 1e3), 1e-3 * std::sqrt(Dot(anchor, anchor)));
    auto world = [&](Vec3 q) { return Add(Scale(e1, q[0] * size), Scale(e2, q[1] * size)); };
    // Placement relative to the shading point (the anchor): at a distance, or with a vertex on
    // it, an edge through it, an interior point on it (crossing), each optionally pushed off the
    // plane by up to 1e-6 (passing close).
    Vec3 offset;  // from the anchor to the polygon's local origin
    x = U(0.0, 1.0);
    if (x < 0.5) {
      offset = Scale(Sphere(), dist);
    } else {
      Vec3 on;  // the polygon point placed on the anchor
      int k = Int(0, n - 1);
      if (x < 0.65) {
        on = poly[size_t(k)];
      } else if (x < 0.8) {
        double t = Chance(0.5) ? 0.5 : U(0.0, 1.0);
        on = Add(Scale(poly[size_t(k)], 1 - t), Scale(poly[size_t((k + 1) % n)], t));
      } else {
        on = {0.0, 0.0, 0.0};
        double wsum = 0;
        for (const Vec3 &v : poly) {
          double w = U(0.0, 1.0);
          on = Add(on, Scale(v, w));
          wsum += w;
        }
        on = Scale(on, 1.0 / wsum);
      }
      offset = Scale(world(on), -1.0);
      if (Chance(0.5))
        offset = Add(offset, Scale(normal, Sign() * (Chance(0.5) ? 1e-6 : LogU(1e-9, 1e-6))));
    }
    for (const Vec3 &v : poly) AddVec(Add(anchor, Add(offset, world(v))), p->mutable_vertices());
    AddMagnitude(p->mutable_radiance());
    p->set_two_sided(Chance(0.5));
  }

  // 0 .. 2 lights of each kind (on the device 1 .. 2: the build options have every kind), placed
  // relative to the anchor (the shading point of unframed queries, near that of framed ones).
  void Lights(EvaluateRequest *r, v1::Model model, Vec3 anchor, bool device) {
    const bool sized = model == v1::BINOMIAL &&
                       r->material().binomial().p_mode() != v1::HEURISTIC_R;  // AREA: size > 0
    // Device: every light kind present (fixed build options); host: any mix.
    int n_dir = device ? Int(1, 2) : Int(0, 2);
    int n_point = device ? Int(1, 2) : Int(0, 2);
    int n_poly = device ? Int(1, 2) : Int(0, 2);
    if (n_dir + n_point + n_poly == 0) n_poly = 1;
    for (int i = 0; i < n_dir; ++i) {
      auto *d = r->add_lights()->mutable_directional();
      AddUnit(LocalDirection(), d->mutable_direction());
      AddMagnitude(d->mutable_irradiance());
      double x = U(0.0, 1.0);
      double cone = x < 0.15 ? 0.0 : x < 0.2 ? 90.0 : x < 0.25 ? 1e-6 : LogU(1e-3, 90.0);
      if (sized && cone == 0.0) cone = 0.26;
      d->set_cone_half_angle_deg(float(cone));
    }
    for (int i = 0; i < n_point; ++i) {
      auto *p = r->add_lights()->mutable_point();
      double dist = LogRange(1e-6, 1e6);
      AddVec(Add(anchor, Scale(LocalDirection(), dist)), p->mutable_position());
      AddMagnitude(p->mutable_intensity());
      double radius = Chance(0.2) ? 0.0 : dist * LogRange(1e-6, 10.0);
      if (sized && !(float(radius) > 0.0f)) radius = 0.1 * dist;
      p->set_radius(float(radius));
    }
    for (int i = 0; i < n_poly; ++i) PolygonLight(r->add_lights()->mutable_polygon(), anchor);
  }

  // `count` queries. Framed: position at the anchor (exactly: polygons placed on it touch the
  // shading point) or up to 1e3 away, normal random or perpendicular to a light (which then
  // grazes), tangent at |t.n| up to 0.998. wo (and wi) from LocalDirection in that frame; uv up
  // to the float range; footprints zero, rank 1, tiny, ordinary or huge.
  void Queries(const EvaluateRequest &r, const Kinds &k, Vec3 anchor, uint32_t count,
               QueryBatch *q) {
    q->set_count(count);
    for (uint32_t i = 0; i < count; ++i) {
      Vec3 n = {0, 0, 1}, t = {1, 0, 0}, b = {0, 1, 0};
      if (k.framed) {
        double x = U(0.0, 1.0);
        n = Sphere();
        if (x < 0.2 && r.lights_size() > 0) {
          // Perpendicular to a light's direction (from the anchor): the light grazes.
          const auto &l = r.lights(Int(0, r.lights_size() - 1));
          Vec3 towards = {0, 0, 1};
          if (l.has_directional()) {
            towards = {l.directional().direction(0), l.directional().direction(1),
                       l.directional().direction(2)};
          } else if (l.has_point()) {
            towards =
                Sub({l.point().position(0), l.point().position(1), l.point().position(2)}, anchor);
          } else {
            towards =
                Sub({l.polygon().vertices(0), l.polygon().vertices(1), l.polygon().vertices(2)},
                    anchor);
          }
          if (Dot(towards, towards) > 0) {
            towards = Normalize(towards);
            Vec3 c = Cross(towards, Sphere());
            if (Dot(c, c) > 1e-6) n = Normalize(c);
          }
        }
        Vec3 helper = Sphere();
        Vec3 perp = Normalize(Sub(helper, Scale(n, Dot(helper, n))));
        double c = Chance(0.05) ? Sign() * 0.998 : Chance(0.5) ? 0.0 : U(-0.9, 0.9);
        t = Add(Scale(n, c), Scale(perp, std::sqrt(1 - c * c)));
        Vec3 t_orth = Normalize(Sub(t, Scale(n, Dot(t, n))));
        b = Cross(n, t_orth);
        t = t_orth;
        Vec3 pos = anchor;
        if (Chance(0.5)) pos = Add(anchor, Scale(Sphere(), LogRange(1e-9, 1e3)));
        AddVec(pos, q->mutable_position());
        AddUnit(n, q->mutable_normal());
        // The tangent as sent (not orthogonalised: the server does Gram-Schmidt).
        Vec3 sent = Add(Scale(n, c), Scale(perp, std::sqrt(1 - c * c)));
        AddUnit(sent, q->mutable_tangent());
      }
      auto to_world = [&](Vec3 l) {
        return Add(Add(Scale(t, l[0]), Scale(b, l[1])), Scale(n, l[2]));
      };
      Vec3 wo = LocalDirection();
      AddUnit(to_world(wo), q->mutable_wo());
      if (k.probe) {
        double x = U(0.0, 1.0);
        Vec3 wi = LocalDirection();
        if (x < 0.15)
          wi = {-wo[0], -wo[1], wo[2]};  // the mirror direction: the lobe's peak
        else if (x < 0.2)
          wi = wo;  // back-scatter
        else if (x < 0.22)
          wi = Scale(wo, -1.0);  // wi = -wo: no half vector
        AddUnit(to_world(wi), q->mutable_wi());
      }
      // uv and footprint (needed by BINOMIAL, allowed for all).
      for (int c = 0; c < 2; ++c) {
        double x = U(0.0, 1.0);
        // KEMPPINEN accepts |uv| <= 1e7 (its validation), the others the whole float range.
        const double huge = r.material().model() == v1::KEMPPINEN ? 1e7 : kFloatMax;
        double u = x < 0.1 ? 0.0 : x < 0.15 ? 1e7 : x < 0.17 ? huge : LogU(1e-6, 1e7);
        q->add_uv(float(Sign() * u));
      }
      double x = U(0.0, 1.0);
      double f[4];
      for (double &v : f) v = Chance(0.1) ? 0.0 : Sign() * LogU(1e-12, 1.0);
      if (x < 0.1) {
        f[0] = f[1] = f[2] = f[3] = 0.0;
      } else if (x < 0.2) {  // rank 1
        double s = Sign() * LogU(1e-3, 1e3);
        f[2] = f[0] * s;
        f[3] = f[1] * s;
      } else if (x < 0.23) {  // huge
        for (double &v : f) v = Sign() * LogU(1e10, 1e30);
      } else if (x < 0.24) {
        for (double &v : f) v = Sign() * kFloatMax;
      }
      for (double v : f) q->add_footprint(float(v));
    }
  }

  // Validation's dielectric range (0, 1e6), down to the smallest (denormal) float.
  static constexpr double kIorMin = 1.4e-45, kIorMax = 9.99e5;

 private:
  std::mt19937_64 rng_;
};

Status Validate(const EvaluateRequest &settings, const QueryBatch &q) {
  Status s = ValidateSettings(settings, {});
  if (s.ok()) s = ValidateQueries(q, settings.lights_size() > 0, {});
  if (s.ok()) s = ValidateQueriesForModel(q, settings);
  return s;
}

std::string Json(const EvaluateRequest &settings, const QueryBatch &q, uint32_t query) {
  EvaluateRequest r = settings;
  QueryBatch *one = r.mutable_queries();
  one->set_count(1);
  auto copy = [&](const google::protobuf::RepeatedField<float> &from,
                  google::protobuf::RepeatedField<float> *to, int per) {
    if (from.empty()) return;
    for (int k = 0; k < per; ++k) to->Add(from[int(query) * per + k]);
  };
  copy(q.uv(), one->mutable_uv(), 2);
  copy(q.footprint(), one->mutable_footprint(), 4);
  copy(q.wo(), one->mutable_wo(), 3);
  copy(q.wi(), one->mutable_wi(), 3);
  copy(q.position(), one->mutable_position(), 3);
  copy(q.normal(), one->mutable_normal(), 3);
  copy(q.tangent(), one->mutable_tangent(), 3);
  std::string out;
  (void)google::protobuf::util::MessageToJsonString(r, &out);
  return out;
}

class StabilitySweep : public test::DeviceEngineTest {
 protected:
  static void SetUpTestSuite() {
    CreateEngine(1);
    if (HasFatalFailure()) return;
    DecodedNormalMap bumps;
    bumps.width = bumps.height = 16;
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) {
        const double sx = 0.6 * std::sin(2 * kPi * (i + 0.5 * j) / 16.0);
        const double sy = 0.6 * std::cos(2 * kPi * (2 * j - i) / 16.0);
        const double len = std::sqrt(sx * sx + sy * sy + 1.0);
        for (double c : {sx / len, sy / len, 1.0 / len}) bumps.xyz.push_back(float(c));
      }
    v1::NormalMapInfo info;
    Status s = NormalMaps().Insert("sweep bumps", bumps, &info);
    ASSERT_TRUE(s.ok()) << s.message();
    sweep_normal_map_digest = info.digest();
  }
};

struct Tally {
  int requests = 0, queries = 0, bad = 0, nonzero = 0;
  float largest = 0.0f;
};

// One model's part of the sweep. Each model is its own test (below) so that ctest -j 2 runs two
// of them at a time: the time is the OpenCL builds of the model's device variants (DeviceKinds),
// which no two models share, so the split builds nothing twice. The draws are those of the
// single test this was before: the sampler's seed is per configuration (model, area method,
// precision, engine), so every model sees the same requests as when all ran in one process.
void SweepModel(DeviceEngine *engine, v1::Model model) {
  const auto start = std::chrono::steady_clock::now();
  const int kRequests = 100;
  const uint32_t kQueries = 40;
  std::map<std::string, int> refusals;
  int draws = 0, accepted = 0;
  int printed = 0;
  // GLINT_SWEEP_DUMP=FILE: every failing query as a one-query request, one JSON per line
  // (appended: one process per model).
  const char *dump_path = std::getenv("GLINT_SWEEP_DUMP");
  std::FILE *dump = dump_path ? std::fopen(dump_path, "a") : nullptr;
  for (v1::AreaMethod method :
       {v1::LTC, v1::LECOCQ, v1::LECOCQ_PEARSON, v1::MONTE_CARLO, v1::REFERENCE})
    for (bool fp64 : {false, true})
      for (bool device : {true, false}) {
        // NORMAL_MAP integrates polygon lights by its own sampling whatever the area method
        // (models/normal_map/normal_map_polygons.h): one method covers it.
        if (model == v1::NORMAL_MAP && method != v1::LTC) continue;
        const auto config_start = std::chrono::steady_clock::now();
        RequestSampler sampler(1000003u * uint64_t(model) + 10007u * uint64_t(method) +
                               101u * fp64 + device);
        Tally tally;
        for (int req = 0; req < kRequests; ++req) {
          // Kernel-specialising choices: free on the host, fixed sets on the device.
          Kinds k;
          if (device) {
            k = DeviceKinds(model, req);
          } else {
            k.ndf = sampler.Chance(0.5) ? v1::GGX : v1::BECKMANN;
            k.fresnel = sampler.Int(0, 2);
            k.framed = sampler.Chance(0.5);
            k.probe = model != v1::BINOMIAL && sampler.Chance(0.25);
          }
          EvaluateRequest settings;
          QueryBatch q;
          for (;;) {
            settings.Clear();
            q.Clear();
            Vec3 anchor = {0, 0, 0};
            if (k.framed && sampler.Chance(0.5)) {
              anchor = Scale(sampler.Sphere(), sampler.LogRange(1e-3, 1e38));
            }
            sampler.Material(model, k, settings.mutable_material());
            if (!k.probe) sampler.Lights(&settings, model, anchor, device);
            settings.set_area_method(method);
            settings.set_area_samples(uint32_t(sampler.Int(1, 8)));
            settings.set_precision(fp64 ? v1::FP64 : v1::FP32);
            settings.set_seed(uint64_t(sampler.LogU(1.0, 1e18)));
            sampler.Queries(settings, k, anchor, kQueries, &q);
            ++draws;
            Status s = Validate(settings, q);
            if (s.ok()) break;
            if (refusals[s.message().substr(0, s.message().find(':'))]++ == 0)
              std::printf("refused: %s\n", s.message().c_str());
          }
          ++accepted;
          EvalPlan plan = MakeEvalPlan(settings, q);
          ASSERT_TRUE(ResolveRequestTable(settings.material(), &plan).ok());
          std::vector<float> out(3 * q.count(), -1.0f);
          if (device) {
            Status s = engine->Evaluate(0, plan, q, out.data());
            ASSERT_TRUE(s.ok()) << s.message();
          } else {
            HostEvaluate(plan, q, out.data());
          }
          ++tally.requests;
          for (uint32_t i = 0; i < q.count(); ++i) {
            ++tally.queries;
            bool ok = true, nonzero = false;
            for (int c = 0; c < 3; ++c) {
              float v = out[3 * i + uint32_t(c)];
              ok = ok && std::isfinite(v) && v >= 0.0f;
              nonzero = nonzero || v > 0.0f;
              if (std::isfinite(v)) tally.largest = std::max(tally.largest, v);
            }
            tally.nonzero += nonzero;
            if (!ok) {
              ++tally.bad;
              if (dump)
                std::fprintf(dump, "%s %s\n", device ? "device" : "host",
                             Json(settings, q, i).c_str());
              if (printed < 30) {
                ++printed;
                ADD_FAILURE() << plan.spec.Describe() << (device ? " device" : " host")
                              << " area_method " << v1::AreaMethod_Name(method) << " query " << i
                              << ": (" << out[3 * i] << ", " << out[3 * i + 1] << ", "
                              << out[3 * i + 2] << ")\n"
                              << Json(settings, q, i);
              }
            }
          }
        }
        std::printf(
            "%-8s %-14s %s %-6s: %d requests, %d queries, %d bad, %.0f%% nonzero, "
            "largest %g, %.1f s\n",
            v1::Model_Name(model).c_str(), v1::AreaMethod_Name(method).c_str(),
            fp64 ? "fp64" : "fp32", device ? "device" : "host", tally.requests, tally.queries,
            tally.bad, 100.0 * tally.nonzero / tally.queries, double(tally.largest),
            std::chrono::duration<double>(std::chrono::steady_clock::now() - config_start).count());
        EXPECT_EQ(tally.bad, 0);
        // A kernel that returned zeros would pass the check above: the draws must light a fair
        // share of the queries (glints are sparse: BINOMIAL lights ~5-30%, the smooth model
        // ~20-60%; the rest is below the horizon, facing away or of zero magnitude).
        EXPECT_GT(tally.nonzero, tally.queries / 50);
      }
  if (dump) std::fclose(dump);
  std::printf("%d draws, %d accepted, %d refused:\n", draws, accepted, draws - accepted);
  for (const auto &[field, n] : refusals) std::printf("  %5d  %s\n", n, field.c_str());
  // The sampler draws from what validation accepts: a refused draw (redrawn, counted) means its
  // model of the accepted space is off; a few polygons lost to float rounding are tolerable
  // (the bound holds per model since the split, as it held for all models together before).
  EXPECT_LE(draws - accepted, draws / 100);
  std::printf("%.1f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
}

TEST_F(StabilitySweep, EveryAcceptedSmoothRequestGivesFiniteNonNegativeOutput) {
  SweepModel(engine_.get(), v1::SMOOTH);
}
TEST_F(StabilitySweep, EveryAcceptedBinomialRequestGivesFiniteNonNegativeOutput) {
  SweepModel(engine_.get(), v1::BINOMIAL);
}
TEST_F(StabilitySweep, EveryAcceptedChermainRequestGivesFiniteNonNegativeOutput) {
  SweepModel(engine_.get(), v1::CHERMAIN);
}
TEST_F(StabilitySweep, EveryAcceptedKemppinenRequestGivesFiniteNonNegativeOutput) {
  SweepModel(engine_.get(), v1::KEMPPINEN);
}
TEST_F(StabilitySweep, EveryAcceptedNormalMapRequestGivesFiniteNonNegativeOutput) {
  SweepModel(engine_.get(), v1::NORMAL_MAP);
}

// ---------------------------------------------------------------------------------------------
// fp32 against fp64 where the value is well conditioned.

// A request from the well-conditioned part of the space: SMOOTH, alpha in [0.1, 1], wo, wi and
// every light at least 0.3 above the local horizon in cos (72.5 deg), a point light at 0.5 .. 5,
// a polygon of angular radius ~0.1 .. 0.5 rad facing the shading point, Fresnel parameters of
// real materials, magnitudes ~1. Lit queries have frames tilted by at most 10 deg from +z (world
// elevation >= 60 deg keeps every light at >= 70 deg locally), probes random frames. `ndf` and
// `fresnel` fix the kinds (the device's variants) or leave them to the draw (-1).
void WellConditioned(RequestSampler &d, v1::AreaMethod method, bool probe, bool fp64, int ndf,
                     int fresnel, EvaluateRequest *r, QueryBatch *q) {
  auto *m = r->mutable_material();
  m->set_model(v1::SMOOTH);
  m->set_ndf(ndf > 0 ? v1::Ndf(ndf) : d.Chance(0.5) ? v1::GGX : v1::BECKMANN);
  m->set_alpha_x(float(d.LogU(0.1, 1.0)));
  m->set_alpha_y(d.Chance(0.3) ? m->alpha_x() : float(d.LogU(0.1, 1.0)));
  if (fresnel < 0) fresnel = d.Int(0, 2);
  for (int c = 0; c < 3; ++c) {
    if (fresnel == 0) m->mutable_schlick()->add_f0(float(d.U(0.02, 1.0)));
    if (fresnel == 1) {
      m->mutable_conductor()->add_eta(float(d.U(0.1, 3.0)));
      m->mutable_conductor()->add_k(float(d.U(0.0, 5.0)));
    }
  }
  if (fresnel == 2) m->mutable_dielectric()->set_ior(float(d.U(1.2, 2.5)));
  r->set_area_method(method);
  r->set_area_samples(8);
  r->set_precision(fp64 ? v1::FP64 : v1::FP32);
  // A direction with cos >= c_min to +z.
  auto above = [&d](double c_min) {
    double c = d.U(c_min, 1.0), phi = d.U(0.0, 2 * kPi), s = std::sqrt(1 - c * c);
    return Vec3{s * std::cos(phi), s * std::sin(phi), c};
  };
  if (!probe) {
    auto *dl = r->add_lights()->mutable_directional();
    d.AddVec(above(0.5), dl->mutable_direction());
    for (int c = 0; c < 3; ++c) dl->add_irradiance(float(d.U(0.5, 2.0)));
    auto *pl = r->add_lights()->mutable_point();
    d.AddVec(Scale(above(0.5), d.U(0.5, 5.0)), pl->mutable_position());
    for (int c = 0; c < 3; ++c) pl->add_intensity(float(d.U(0.5, 2.0)));
    for (;;) {  // a polygon facing the shading point, every vertex at world cos >= 0.5
      Vec3 centre = Scale(above(0.5), d.U(0.5, 5.0));
      Vec3 n = Normalize(Scale(centre, -1.0));
      Vec3 helper = std::fabs(n[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      Vec3 e1 = Normalize(Cross(helper, n)), e2 = Cross(n, e1);
      const double radius = std::sqrt(Dot(centre, centre)) * d.U(0.1, 0.5);
      bool ok = true;
      google::protobuf::RepeatedField<float> vertices;
      for (const Vec3 &v : d.Polygon2D(d.Int(3, 8))) {
        Vec3 w = Add(centre, Add(Scale(e1, radius * v[0]), Scale(e2, radius * v[1])));
        ok = ok && w[2] >= 0.5 * std::sqrt(Dot(w, w));
        d.AddVec(w, &vertices);
      }
      if (!ok) continue;
      auto *pg = r->add_lights()->mutable_polygon();
      *pg->mutable_vertices() = vertices;
      for (int c = 0; c < 3; ++c) pg->add_radiance(float(d.U(0.5, 2.0)));
      break;
    }
  }
  const uint32_t count = 200;
  q->set_count(count);
  for (uint32_t i = 0; i < count; ++i) {
    Vec3 n = probe ? d.Sphere() : above(std::cos(10.0 * kPi / 180.0));
    Vec3 h = d.Sphere();
    Vec3 t = Normalize(Sub(h, Scale(n, Dot(h, n))));
    Vec3 b = Cross(n, t);
    d.AddVec({0.0, 0.0, 0.0}, q->mutable_position());
    d.AddVec(n, q->mutable_normal());
    d.AddVec(t, q->mutable_tangent());
    auto world = [&](Vec3 l) { return Add(Add(Scale(t, l[0]), Scale(b, l[1])), Scale(n, l[2])); };
    Vec3 wo = above(0.3);
    d.AddVec(world(wo), q->mutable_wo());
    if (probe) {
      // Half of the probes near the mirror direction, where the lobe is largest.
      Vec3 wi = d.Chance(0.5) ? above(0.3) : Vec3{-wo[0], -wo[1], wo[2]};
      d.AddVec(world(wi), q->mutable_wi());
    }
  }
}

// Every geometric input (alpha, Fresnel parameters, light directions, positions and vertices,
// query directions and frames) times 1 + rel * U(-1, 1): a finite-difference probe of the
// output's condition number.
void Perturb(RequestSampler &d, double rel, EvaluateRequest *r, QueryBatch *q) {
  auto jitter = [&](google::protobuf::RepeatedField<float> *v, float hi) {
    for (int i = 0; i < v->size(); ++i)
      v->Set(i, std::min(float(v->Get(i) * (1.0 + rel * d.U(-1.0, 1.0))), hi));
  };
  const float any = kFloatMax;
  auto *m = r->mutable_material();
  m->set_alpha_x(std::min(float(m->alpha_x() * (1.0 + rel * d.U(-1.0, 1.0))), 1.0f));
  m->set_alpha_y(std::min(float(m->alpha_y() * (1.0 + rel * d.U(-1.0, 1.0))), 1.0f));
  if (m->has_schlick()) jitter(m->mutable_schlick()->mutable_f0(), 1.0f);
  if (m->has_conductor()) {
    jitter(m->mutable_conductor()->mutable_eta(), any);
    jitter(m->mutable_conductor()->mutable_k(), any);
  }
  if (m->has_dielectric())
    m->mutable_dielectric()->set_ior(float(m->dielectric().ior() * (1.0 + rel * d.U(-1.0, 1.0))));
  for (auto &l : *r->mutable_lights()) {
    if (l.has_directional()) jitter(l.mutable_directional()->mutable_direction(), any);
    if (l.has_point()) jitter(l.mutable_point()->mutable_position(), any);
    if (l.has_polygon()) jitter(l.mutable_polygon()->mutable_vertices(), any);
  }
  for (auto *v : {q->mutable_wo(), q->mutable_wi(), q->mutable_normal(), q->mutable_tangent()})
    jitter(v, any);
}

// The LTC term of the tolerance below for query i: u 32 (n + 2) max_rgb(L albedo(wo)).
double LtcAbsolute(const EvaluateRequest &r, const QueryBatch &q, size_t i) {
  constexpr double u = 5.9604644775390625e-8;
  const v1::Material &m = r.material();
  double f0[3];
  for (int c = 0; c < 3; ++c) {
    if (m.has_schlick()) {
      f0[c] = m.schlick().f0(c);
    } else if (m.has_conductor()) {
      const double eta = m.conductor().eta(c), k = m.conductor().k(c);
      f0[c] = ((eta - 1) * (eta - 1) + k * k) / ((eta + 1) * (eta + 1) + k * k);
    } else {
      const double n = m.dielectric().ior();
      f0[c] = (n - 1) * (n - 1) / ((n + 1) * (n + 1));
    }
  }
  const Vec3 wo = {q.wo(int(3 * i)), q.wo(int(3 * i + 1)), q.wo(int(3 * i + 2))};
  const Vec3 n = {q.normal(int(3 * i)), q.normal(int(3 * i + 1)), q.normal(int(3 * i + 2))};
  const double cos_o = Dot(Normalize(wo), Normalize(n));
  double v[GLINT_LTC_ENTRY];
  sweep_k::area_ltc_lookup(
      ltc_table::table(m.ndf() == v1::BECKMANN ? ltc_table::Ndf::kBeckmann : ltc_table::Ndf::kGgx),
      std::sqrt(double(m.alpha_x()) * m.alpha_y()), cos_o, v);
  const ltc_table::Entry e{{v[0], v[1], v[2], v[3]}, v[4], v[5], v[6], v[7]};
  double sum = 0;
  for (const auto &l : r.lights()) {
    if (!l.has_polygon()) continue;
    double largest = 0;
    for (int c = 0; c < 3; ++c)
      largest = std::max(largest, l.polygon().radiance(c) * ltc_table::fresnel_albedo(e, f0[c]));
    sum += u * 32.0 * (l.polygon().vertices_size() / 3 + 2) * largest;
  }
  return sum;
}

// fp32 against fp64 on the same inputs, OpenCL device and host path, for the deterministic
// smooth evaluations without discrete decisions: BRDF probes and lit queries with a directional,
// a point and a polygon light under LTC. Tolerance per query and channel:
//   |f32 - f64| <= u (64 + 40 kappa) f64,   u = 2^-24 (fp32 unit roundoff),
// kappa = the output's condition number with respect to relative perturbations of the inputs,
// estimated in fp64 on the host by finite differences (3 random perturbations of relative size
// 2^-20 of every input, largest |df / f| / 2^-20). 40 u bounds the relative input error that the
// fp32 arithmetic itself introduces into the directions the lobe sees: ~2 u per normalisation,
// ~3 u absolute per frame change, i.e. <= 10 u relative at cos >= 0.3, doubled by the half
// vector of two such directions, and a factor 2 because a random finite-difference direction
// may see less than the worst-case sensitivity. 64 u covers the rest of the chain (D, Lambda,
// Fresnel: a few dozen roundings of magnitude <= u each). The LTC form factor adds an absolute
// term that kappa cannot see: it is a sum of edge terms (angle x unit normal's z, HDHN16 Eq. 11)
// that cancel when the lobe misses the light, so their independent roundings do not shrink with
// the result. Each term's rounding: its two unit vertices o = M^-1 c / |M^-1 c| carry <= 2 u
// cond(M^-1) + 2 u of direction error, cond(M^-1) <= 22 in both tables for alpha >= 0.09 and
// cos(theta_o) >= 0.25 (computed from data/ltc/*.inc), a term moves by <= 2 per unit of vertex
// direction, plus <= ~13 u in the cross product, atan2 and theta / sin(theta) for edges below
// ~1 rad: <= 200 u per term, / (2 pi) in the form factor: 32 u per clipped edge (n + 2 at most),
// times the radiance and the albedo that scales the form factor (area_ltc_polygon):
//   + u 32 (n + 2) max_rgb(L albedo)   for the polygon light,
// the albedo from the table (data/ltc/ltc_table.h) with f0 = F(normal incidence).
// Not compared: LECOCQ (its contour sums cancel by design, 1 - x^(N+1) with large N, so fp32
// loses digits that kappa does not see), MONTE_CARLO (a sample may fall on the other side of a
// polygon edge or triangle choice in fp32: discrete, not a rounding error), REFERENCE (its Arvo
// map computes 1 - cos of short arcs, relative error ~u / arc^2, ~1e-3 measured here; the Monte
// Carlo copy of the map avoids it), BINOMIAL (discrete counts).
TEST_F(StabilitySweep, Fp32AgreesWithFp64WhereWellConditioned) {
  constexpr double u = 5.9604644775390625e-8;
  constexpr double kStep = 1.0 / (1 << 20);
  RequestSampler d(77);
  for (bool device : {true, false})
    for (bool probe : {true, false}) {
      int checked = 0;
      double worst_ratio = 0, worst_rel = 0;
      std::vector<double> kappas, rel_tols;
      for (int req = 0; req < 20; ++req) {
        // Device: its compiled variants (DeviceKinds); host: any NDF and Fresnel kind.
        const Kinds dk = DeviceKinds(v1::SMOOTH, probe ? 3 : 0);
        const int ndf = device ? int(dk.ndf) : -1, fresnel = device ? dk.fresnel : -1;
        EvaluateRequest r32, r64;
        QueryBatch q, q64;
        RequestSampler same = d;  // the same draws for both precisions
        WellConditioned(d, v1::LTC, probe, false, ndf, fresnel, &r32, &q);
        WellConditioned(same, v1::LTC, probe, true, ndf, fresnel, &r64, &q64);
        ASSERT_EQ(q.SerializeAsString(), q64.SerializeAsString());
        Status s = Validate(r32, q);
        ASSERT_TRUE(s.ok()) << s.message();
        std::vector<float> f32(3 * q.count()), f64(3 * q.count()), ref(3 * q.count());
        EvalPlan p32 = MakeEvalPlan(r32, q), p64 = MakeEvalPlan(r64, q);
        if (device) {
          ASSERT_TRUE(engine_->Evaluate(0, p32, q, f32.data()).ok());
          ASSERT_TRUE(engine_->Evaluate(0, p64, q, f64.data()).ok());
        } else {
          HostEvaluate(p32, q, f32.data());
          HostEvaluate(p64, q, f64.data());
        }
        // kappa per value, from the host fp64 path.
        HostEvaluate(p64, q, ref.data());
        std::vector<double> kappa(ref.size(), 0.0);
        for (int k = 0; k < 3; ++k) {
          EvaluateRequest rp = r64;
          QueryBatch qp = q;
          Perturb(d, kStep, &rp, &qp);
          ASSERT_TRUE(Validate(rp, qp).ok());
          std::vector<float> fp(ref.size());
          HostEvaluate(MakeEvalPlan(rp, qp), qp, fp.data());
          for (size_t i = 0; i < ref.size(); ++i) {
            if (ref[i] > 0.0f)
              kappa[i] = std::max(kappa[i], std::fabs(double(fp[i]) - ref[i]) / ref[i] / kStep);
          }
        }
        for (size_t i = 0; i < f32.size(); ++i) {
          if (!(f64[i] > 0.0f)) {
            EXPECT_LE(f32[i], 1e-30f) << (device ? "device" : "host") << " value " << i;
            continue;
          }
          const double err = std::fabs(double(f32[i]) - double(f64[i]));
          const double tol =
              u * (64.0 + 40.0 * kappa[i]) * double(f64[i]) + LtcAbsolute(r32, q, i / 3) + 1e-30;
          EXPECT_LE(err, tol) << (device ? "device " : "host ") << (probe ? "probe" : "LTC")
                              << " kappa " << kappa[i] << " f32 " << f32[i] << " f64 " << f64[i]
                              << "\n"
                              << Json(r32, q, uint32_t(i / 3));
          ++checked;
          rel_tols.push_back(tol / double(f64[i]));
          kappas.push_back(kappa[i]);
          worst_ratio = std::max(worst_ratio, err / tol);
          worst_rel = std::max(worst_rel, err / double(f64[i]));
        }
      }
      std::sort(kappas.begin(), kappas.end());
      std::sort(rel_tols.begin(), rel_tols.end());
      const double median_tol = rel_tols[rel_tols.size() / 2];
      std::printf(
          "%-6s %-5s: %d values, kappa median %.3g max %.3g, relative tolerance median %.2g "
          "p90 %.2g, worst |f32 - f64| / f64 = %.3g (%.0f u), worst error / tolerance %.3f\n",
          device ? "device" : "host", probe ? "probe" : "LTC", checked, kappas[kappas.size() / 2],
          kappas.back(), median_tol, rel_tols[rel_tols.size() * 9 / 10], worst_rel, worst_rel / u,
          worst_ratio);
      // The comparison must have teeth: half of the values are held to 1e-3 or better.
      EXPECT_GT(checked, 10000);
      EXPECT_LE(median_tol, 1e-3);
    }
}

// ---------------------------------------------------------------------------------------------
// Regressions: the inputs of issue 8, each of which validation accepted and a kernel turned into
// NaN or +Inf. Device (its compiled variants) and host, fp32 and fp64.

class StabilityRegression : public StabilitySweep {
 protected:
  // Runs r (with its own queries) on the device (unless `host_only`: a kernel variant the device
  // sweep does not build) and the host in both precisions; calls check(out, device, fp64) with
  // the RGB output.
  template <typename Check>
  void RunEverywhere(EvaluateRequest r, Check check, bool host_only = false) {
    for (bool fp64 : {false, true}) {
      r.set_precision(fp64 ? v1::FP64 : v1::FP32);
      Status s = Validate(r, r.queries());
      ASSERT_TRUE(s.ok()) << s.message();
      EvalPlan plan = MakeEvalPlan(r, r.queries());
      for (bool device : {true, false}) {
        if (device && host_only) continue;
        std::vector<float> out(3 * r.queries().count(), -1.0f);
        if (device) {
          s = engine_->Evaluate(0, plan, r.queries(), out.data());
          ASSERT_TRUE(s.ok()) << s.message();
        } else {
          HostEvaluate(plan, r.queries(), out.data());
        }
        check(out, device, fp64);
      }
    }
  }
};

// One query per wo, with the identity frame (the device's lit and probe variants are framed).
void IdentityFrameQueries(const std::vector<Vec3> &wo, QueryBatch *q) {
  q->set_count(uint32_t(wo.size()));
  for (const Vec3 &w : wo) {
    for (double c : w) q->add_wo(float(c));
    for (float c : {0.0f, 0.0f, 0.0f}) q->add_position(c);
    for (float c : {0.0f, 0.0f, 1.0f}) q->add_normal(c);
    for (float c : {1.0f, 0.0f, 0.0f}) q->add_tangent(c);
  }
}

// A directional and a point light of zero magnitude: they add exactly 0 but give a polygon
// request the build options of the device's lit variant (DeviceKinds), so no extra build.
void AddInertDeltaLights(EvaluateRequest *r) {
  auto *d = r->add_lights()->mutable_directional();
  for (float v : {0.0f, 0.0f, 1.0f}) d->add_direction(v);
  for (float v : {0.0f, 0.0f, 0.0f}) d->add_irradiance(v);
  auto *p = r->add_lights()->mutable_point();
  for (float v : {0.0f, 0.0f, 1.0f}) p->add_position(v);
  for (float v : {0.0f, 0.0f, 0.0f}) p->add_intensity(v);
}

std::string Where(bool device, bool fp64) {
  return std::string(device ? "device " : "host ") + (fp64 ? "fp64" : "fp32");
}

// A polygon whose plane contains the shading point subtends zero solid angle: issue 8's triangle
// with a vertex at the shading point (LTC gave NaN: that vertex has no direction), a triangle
// with an edge through it (the horizon clip creates a vertex there, also NaN in LTC), and one in
// the surface's own plane with an edge through it (antipodal edge ends, no arc between them).
// Every method must give a finite value >= 0 and at most the albedo (L = 1).
// In the first two the remaining vertices lie on one great circle and the exact integral is 0:
// REFERENCE and MONTE_CARLO, which integrate in solid angle, give exactly 0 and LTC 0 up to the
// rounding of its edge sum. In the third, the arc between the antipodal ends is undefined, so any
// value between 0 (in the plane) and the limit from above (a half-plane over the surface, LTC's
// reading) is right. LECOCQ drops the vertex at the shading point as LTC does (0 for the first
// triangle), but maps the rest to half-vector space piece by piece, where an arc along a great
// circle keeps a sliver of area: bounded, not 0.
TEST_F(StabilityRegression, PolygonThroughTheShadingPoint) {
  const std::vector<std::vector<float>> polygons = {
      {0, 0, 0, 1, 0, 1, 0, 1, 1},     // issue 8: a vertex at the shading point
      {-1, -1, -1, 1, 1, 1, 0, 1, 1},  // an edge through it, crossing the horizon
      {-1, 0, 0, 1, 0, 0, 0, 1, 0}};   // in the surface's plane, an edge through it
  for (size_t k = 0; k < polygons.size(); ++k)
    for (v1::AreaMethod method :
         {v1::LTC, v1::LECOCQ, v1::LECOCQ_PEARSON, v1::MONTE_CARLO, v1::REFERENCE})
      for (bool two_sided : {false, true}) {
        EvaluateRequest r;
        auto *m = r.mutable_material();
        m->set_model(v1::SMOOTH);
        m->set_ndf(v1::GGX);  // the device's lit variant: GGX, dielectric, framed
        m->set_alpha_x(0.3f);
        m->set_alpha_y(0.3f);
        m->mutable_dielectric()->set_ior(1.5f);
        auto *p = r.add_lights()->mutable_polygon();
        for (float v : polygons[k]) p->add_vertices(v);
        for (float v : {1.0f, 1.0f, 1.0f}) p->add_radiance(v);
        p->set_two_sided(two_sided);
        AddInertDeltaLights(&r);
        r.set_area_method(method);
        r.set_area_samples(16);
        IdentityFrameQueries({{0, 0, 1}, {0.6, 0, 0.8}, {0, -0.6, 0.8}, {0.3, 0.3, 0.9055}},
                             r.mutable_queries());
        RunEverywhere(r, [&](const std::vector<float> &out, bool device, bool fp64) {
          for (size_t i = 0; i < out.size(); ++i) {
            const std::string what = Where(device, fp64) + " " + v1::AreaMethod_Name(method) +
                                     (two_sided ? " two-sided" : " one-sided") + " polygon " +
                                     std::to_string(k) + " value " + std::to_string(i);
            ASSERT_TRUE(std::isfinite(out[i]) && out[i] >= 0.0f) << what << ": " << out[i];
            EXPECT_LE(out[i], 1.0f) << what;
            if (method == v1::REFERENCE || method == v1::MONTE_CARLO) {
              EXPECT_EQ(out[i], 0.0f) << what;
            } else if (method == v1::LTC && k < 2) {
              // The arcs along the great circle cancel up to the rounding of the edge sum:
              // <= 32 eps per clipped edge (see the fp32-vs-fp64 test), albedo <= 1, L = 1.
              const double eps = fp64 ? 0x1p-53 : 0x1p-24;
              EXPECT_LE(out[i], 32 * eps * (3 + 2)) << what;
            } else if (k == 0) {
              // LECOCQ: two vertices are left, no region (the vertex at the shading point used
              // to be replaced by the normal, which integrated a triangle up to the zenith).
              EXPECT_EQ(out[i], 0.0f) << what;
            }
          }
        });
      }
}

// Issue 8: alpha 1e-20 with wo = wi = n gave +Inf (fp32 and fp64), 1e-23 NaN with a directional
// light, 1e-25 .. 1e-38 NaN in probes; MONTE_CARLO and REFERENCE NaN at alpha <= 1e-20. Such
// roughness is now refused (tests/service/validation_test.cpp); at the floor, 1e-4, the peak is
// finite and equals its closed form: at wo = wi = n, h = n, D(n) = 1 / (pi alpha^2) for GGX and
// Beckmann (Heitz 2014 Eq. 84-85), Lambda(n) = 0 so G2 = 1, F = F(1), and
//   f cos_i = F(1) D(n) G2 / (4 cos_o) = F(1) / (4 pi alpha^2)  (~8e6 F(1) at alpha 1e-4).
// The float alpha 1e-4f is what the kernels see; the closed form uses it too. Tolerance: fp32
// evaluates D, G2 and F at h = n exactly (no direction rounding at the pole) up to ~10 roundings,
// 16 u; fp64 results are rounded to float once, 1 u.
TEST_F(StabilityRegression, RoughnessFloorPeakMatchesClosedForm) {
  const float alpha = 1e-4f;
  for (v1::Ndf ndf : {v1::GGX, v1::BECKMANN}) {
    EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(v1::SMOOTH);
    m->set_ndf(ndf);
    m->set_alpha_x(alpha);
    m->set_alpha_y(alpha);
    // Probes: the device's probe variant (Beckmann, conductor) for Beckmann; GGX runs on the
    // host only (a GGX conductor probe kernel would be another build).
    const double eta = 0.2, k = 3.9;
    for (int c = 0; c < 3; ++c) {
      m->mutable_conductor()->add_eta(float(eta));
      m->mutable_conductor()->add_k(float(k));
    }
    const double f1 = ((eta - 1) * (eta - 1) + k * k) / ((eta + 1) * (eta + 1) + k * k);
    const double expected = f1 / (4 * kPi * double(alpha) * double(alpha));
    IdentityFrameQueries({{0, 0, 1}}, r.mutable_queries());
    for (float v : {0.0f, 0.0f, 1.0f}) r.mutable_queries()->add_wi(v);
    RunEverywhere(
        r,
        [&](const std::vector<float> &out, bool device, bool fp64) {
          for (float v : out) {
            ASSERT_TRUE(std::isfinite(v)) << Where(device, fp64);
            EXPECT_NEAR(v, expected, (fp64 ? 1 : 16) * 0x1p-24 * expected)
                << Where(device, fp64) << " " << v1::Ndf_Name(ndf);
          }
        },
        ndf == v1::GGX);
  }
  // MONTE_CARLO and REFERENCE at the floor, the light around the mirror direction of a tilted
  // view: finite and >= 0 (their NaN was at alpha <= 1e-20).
  for (v1::AreaMethod method : {v1::MONTE_CARLO, v1::REFERENCE}) {
    EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(v1::SMOOTH);
    m->set_ndf(v1::GGX);
    m->set_alpha_x(alpha);
    m->set_alpha_y(alpha);
    m->mutable_dielectric()->set_ior(1.5f);
    auto *p = r.add_lights()->mutable_polygon();
    for (float v : {-0.5f, -0.5f, 2.0f, 0.5f, -0.5f, 2.0f, 0.5f, 0.5f, 2.0f, -0.5f, 0.5f, 2.0f})
      p->add_vertices(v);
    for (float v : {1.0f, 1.0f, 1.0f}) p->add_radiance(v);
    AddInertDeltaLights(&r);
    r.set_area_method(method);
    r.set_area_samples(64);
    IdentityFrameQueries({{0, 0, 1}, {0.1, 0, 0.995}, {0, 0.6, 0.8}}, r.mutable_queries());
    RunEverywhere(r, [&](const std::vector<float> &out, bool device, bool fp64) {
      for (float v : out)
        EXPECT_TRUE(std::isfinite(v) && v >= 0.0f)
            << Where(device, fp64) << " " << v1::AreaMethod_Name(method) << ": " << v;
    });
  }
}

// Issue 8: dielectric ior 1e-30 gave NaN under LTC and LECOCQ in fp32 (F_dielectric divided by
// ior^2, which underflows to 0: 0/0 at normal incidence). The exact limit ior -> 0 is F = 1 at
// every angle (((1 - ior) / (1 + ior))^2 -> 1 at normal incidence, total internal reflection
// elsewhere), so every method must give what it gives for a Schlick material with f0 = 1, whose
// F is 1 identically; the reference runs on the host (Schlick is not one of the device's
// compiled variants). Host: the same arithmetic on F = 1, 4 u. Device against host: the
// tolerances of engine_test's DeviceMatchesHostPathWithPolygonLights (libm differences).
TEST_F(StabilityRegression, TinyDielectricIorIsTotalReflection) {
  for (v1::AreaMethod method :
       {v1::LTC, v1::LECOCQ, v1::LECOCQ_PEARSON, v1::MONTE_CARLO, v1::REFERENCE}) {
    EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(v1::SMOOTH);
    m->set_ndf(v1::GGX);
    m->set_alpha_x(0.3f);
    m->set_alpha_y(0.3f);
    m->mutable_dielectric()->set_ior(1e-30f);
    auto *p = r.add_lights()->mutable_polygon();
    for (float v : {-1.0f, -1.0f, 2.0f, 1.0f, -1.0f, 2.0f, 1.0f, 1.0f, 2.0f, -1.0f, 1.0f, 2.0f})
      p->add_vertices(v);
    for (float v : {1.0f, 0.5f, 0.25f}) p->add_radiance(v);
    p->set_two_sided(true);
    AddInertDeltaLights(&r);
    r.set_area_method(method);
    r.set_area_samples(8);
    IdentityFrameQueries({{0, 0, 1}, {0, 0.6, 0.8}, {0.8, 0, 0.6}, {0.3, -0.2, 0.933}},
                         r.mutable_queries());
    EvaluateRequest schlick = r;
    for (int c = 0; c < 3; ++c) schlick.mutable_material()->mutable_schlick()->add_f0(1.0f);
    RunEverywhere(r, [&](const std::vector<float> &out, bool device, bool fp64) {
      schlick.set_precision(fp64 ? v1::FP64 : v1::FP32);
      std::vector<float> expected(out.size());
      HostEvaluate(MakeEvalPlan(schlick, schlick.queries()), schlick.queries(), expected.data());
      const bool lecocq = method == v1::LECOCQ || method == v1::LECOCQ_PEARSON;
      const double rel = !device ? 4 * 0x1p-24 : fp64 ? 4e-6 : lecocq ? 1e-2 : 1e-3;
      for (size_t i = 0; i < out.size(); ++i) {
        ASSERT_TRUE(std::isfinite(out[i])) << Where(device, fp64);
        EXPECT_GT(expected[i], 0.0f);
        EXPECT_NEAR(out[i], expected[i], rel * expected[i])
            << Where(device, fp64) << " " << v1::AreaMethod_Name(method) << " value " << i;
      }
    });
  }
  // BRDF probes (host: the device's probe variant is a conductor): F = 1 as for Schlick f0 = 1.
  for (bool fp64 : {false, true}) {
    EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(v1::SMOOTH);
    m->set_ndf(v1::GGX);
    m->set_alpha_x(0.3f);
    m->set_alpha_y(0.3f);
    m->mutable_dielectric()->set_ior(1e-30f);
    r.set_precision(fp64 ? v1::FP64 : v1::FP32);
    IdentityFrameQueries({{0, 0, 1}, {0, 0.6, 0.8}, {0.8, 0, 0.6}}, r.mutable_queries());
    for (float v : {0.0f, 0.0f, 1.0f, 0.0f, -0.6f, 0.8f, 0.0f, 0.8f, 0.6f})
      r.mutable_queries()->add_wi(v);
    EvaluateRequest schlick = r;
    for (int c = 0; c < 3; ++c) schlick.mutable_material()->mutable_schlick()->add_f0(1.0f);
    std::vector<float> out(9), expected(9);
    HostEvaluate(MakeEvalPlan(r, r.queries()), r.queries(), out.data());
    HostEvaluate(MakeEvalPlan(schlick, schlick.queries()), schlick.queries(), expected.data());
    for (size_t i = 0; i < out.size(); ++i)
      EXPECT_NEAR(out[i], expected[i], 4 * 0x1p-24 * expected[i]) << (fp64 ? "fp64" : "fp32");
  }
}

// A point light's irradiance I / d^2 overflowed fp32 (I = 3e38 at d = 1e-3), and a light behind
// the surface then gave 0 x Inf = NaN; in front, the radiance was +Inf in both precisions (fp64
// overflowed the float output). Now I / d^2 saturates at the largest real (kernels/lights.h) and
// the output at FLT_MAX (GLINT_SATURATE_FLOAT, kernels/kernel_args.h): behind, exactly 0; in
// front, fp64 saturates at FLT_MAX, and fp32 sees an irradiance of FLT_MAX, i.e. gives what
// intensity FLT_MAX d^2 gives.
TEST_F(StabilityRegression, HugePointLightSaturatesInsteadOfNaN) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::SMOOTH);
  m->set_ndf(v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.3f);
  m->mutable_dielectric()->set_ior(1.5f);
  auto *d = r.add_lights()->mutable_directional();  // the device's lit variant has both kinds
  for (float v : {0.0f, 0.0f, 1.0f}) d->add_direction(v);
  for (float v : {0.0f, 0.0f, 0.0f}) d->add_irradiance(v);
  for (float z : {-1e-3f, 1e-3f}) {  // behind, then in front of the surface
    EvaluateRequest lit = r;
    auto *p = lit.add_lights()->mutable_point();
    for (float v : {0.0f, 0.0f, z}) p->add_position(v);
    for (float v : {3e38f, 3e38f, 3e38f}) p->add_intensity(v);
    IdentityFrameQueries({{0, 0, 1}, {0, 0.6, 0.8}}, lit.mutable_queries());
    EvaluateRequest at_max = lit;  // the fp32 reading: irradiance FLT_MAX
    for (int c = 0; c < 3; ++c)
      at_max.mutable_lights(1)->mutable_point()->set_intensity(c, kFloatMax * 1e-6f);
    at_max.set_precision(v1::FP32);
    std::vector<float> fp32_expected(6);
    HostEvaluate(MakeEvalPlan(at_max, at_max.queries()), at_max.queries(), fp32_expected.data());
    RunEverywhere(lit, [&](const std::vector<float> &out, bool device, bool fp64) {
      for (size_t i = 0; i < out.size(); ++i) {
        if (z < 0) {
          EXPECT_EQ(out[i], 0.0f) << Where(device, fp64);
        } else if (fp64) {
          EXPECT_EQ(out[i], kFloatMax) << Where(device, fp64);
        } else {
          ASSERT_TRUE(std::isfinite(out[i]) && out[i] > 0.0f) << Where(device, fp64);
          EXPECT_NEAR(out[i], fp32_expected[i], 1e-5 * fp32_expected[i]) << Where(device, fp64);
        }
      }
    });
  }
}

// The binomial model scales each light's smooth radiance by count / (N_P p); with that radiance
// overflowed and a count of 0, 0 x Inf was NaN. Here the light's irradiance is FLT_MAX (fp32,
// saturated) or 3e44 (fp64) and the lobe's peak f cos ~ 29 (alpha 0.05), so the radiance is +Inf
// in fp32. About half of the footprints (N_P = 0.5 facets, p = 1 for this huge sphere light)
// hold no reflecting facet and must give exactly 0, the others saturate.
TEST_F(StabilityRegression, BinomialWithoutFacetsUnderAHugeLightIsZero) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::BINOMIAL);
  m->set_ndf(v1::BECKMANN);  // the device's binomial variant: Beckmann, Schlick, unframed
  m->set_alpha_x(0.05f);
  m->set_alpha_y(0.05f);
  for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(0.9f);
  m->mutable_binomial()->set_density(0.5e6);
  auto *d = r.add_lights()->mutable_directional();
  for (float v : {0.0f, 0.0f, 1.0f}) d->add_direction(v);
  for (float v : {0.0f, 0.0f, 0.0f}) d->add_irradiance(v);
  d->set_cone_half_angle_deg(1.0f);
  auto *p = r.add_lights()->mutable_point();
  for (float v : {0.0f, 0.0f, 1e-3f}) p->add_position(v);
  for (float v : {3e38f, 3e38f, 3e38f}) p->add_intensity(v);
  p->set_radius(2e-3f);  // encloses the shading point: the cone is the whole hemisphere
  r.set_seed(12345);
  auto *q = r.mutable_queries();
  const uint32_t n = 400;
  q->set_count(n);
  for (uint32_t i = 0; i < n; ++i) {
    for (float v : {0.0f, 0.0f, 1.0f}) q->add_wo(v);
    q->add_uv(float(i) * 0.37f);
    q->add_uv(float(i % 7) * 0.51f);
    for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) q->add_footprint(v);  // N_P = 0.5e6 x 1e-6
  }
  RunEverywhere(r, [&](const std::vector<float> &out, bool device, bool fp64) {
    int zero = 0, saturated = 0;
    for (float v : out) {
      ASSERT_TRUE(std::isfinite(v) && v >= 0.0f) << Where(device, fp64) << ": " << v;
      zero += v == 0.0f;
      saturated += v == std::numeric_limits<float>::max();
    }
    EXPECT_EQ(zero + saturated, int(out.size())) << Where(device, fp64);
    EXPECT_GT(zero, int(out.size()) / 4) << Where(device, fp64);
    EXPECT_GT(saturated, int(out.size()) / 4) << Where(device, fp64);
  });
}

}  // namespace
}  // namespace glint
