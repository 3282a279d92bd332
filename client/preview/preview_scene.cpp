// Preview scene generation: camera rays, analytic sphere / plane intersection, ray-differential
// footprints. All geometry is done in double and rounded to float only when written to the
// batch, so the footprint's one-pixel differences do not lose digits to cancellation.
#include "client/preview/preview_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>

namespace glint::client {
namespace {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

Vec3 operator+(Vec3 a, Vec3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
Vec3 operator-(Vec3 a, Vec3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
Vec3 operator*(double s, Vec3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
double Dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
Vec3 Cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3 Normalize(Vec3 a) {
  return (1.0 / std::sqrt(Dot(a, a))) * a;
}
Vec3 FromArray(const double (&a)[3]) {
  return {a[0], a[1], a[2]};
}

// Pinhole camera. Direction() is deliberately NOT normalised: it is affine in the pixel
// coordinates, which keeps the offset rays of the ray differentials exact.
class Camera {
 public:
  Camera(const PreviewCamera &c, int width, int height)
      : eye_(FromArray(c.eye)), width_(width), height_(height) {
    forward_ = Normalize(FromArray(c.look_at) - eye_);
    right_ = Normalize(Cross(forward_, FromArray(c.up)));
    up_ = Cross(right_, forward_);
    tan_half_v_ = std::tan(0.5 * c.vertical_fov_deg * std::numbers::pi / 180.0);
    tan_half_h_ = tan_half_v_ * static_cast<double>(width) / static_cast<double>(height);
  }

  Vec3 eye() const { return eye_; }

  // Ray direction through continuous pixel coordinates (px, py); row 0 is the top row.
  Vec3 Direction(double px, double py) const {
    const double ndc_x = 2.0 * px / width_ - 1.0;
    const double ndc_y = 1.0 - 2.0 * py / height_;
    return forward_ + (ndc_x * tan_half_h_) * right_ + (ndc_y * tan_half_v_) * up_;
  }

 private:
  Vec3 eye_, forward_, right_, up_;
  double tan_half_v_ = 0.0, tan_half_h_ = 0.0;
  int width_, height_;
};

// Everything the query needs about a hit, plus the partial derivatives of the
// parameterisation for the footprint.
struct SurfaceHit {
  Vec3 p, n, tangent;
  Vec3 dpdu, dpdv;
  double u = 0.0, v = 0.0;
};

std::optional<SurfaceHit> IntersectSphere(Vec3 o, Vec3 d) {
  d = Normalize(d);
  // |o + t d|^2 = 1 with |d| = 1: t^2 + 2 b t + c = 0.
  const double b = Dot(o, d);
  const double c = Dot(o, o) - 1.0;
  const double disc = b * b - c;
  if (!(disc >= 0.0)) return std::nullopt;
  // The camera is outside the sphere, so the nearer root is the visible one.
  const double t = -b - std::sqrt(disc);
  if (!(t > 0.0)) return std::nullopt;

  SurfaceHit h;
  // Re-project onto the sphere so |p| = 1 to rounding, whatever the cancellation in t.
  h.p = Normalize(o + t * d);
  h.n = h.p;
  const double sin_theta = std::hypot(h.p.x, h.p.y);  // accurate near the poles, unlike sin(acos)
  const double cos_theta = h.p.z;
  const double theta = std::atan2(sin_theta, cos_theta);
  const double phi = std::atan2(h.p.x, -h.p.y);
  const double two_pi = 2.0 * std::numbers::pi;
  h.u = (phi / two_pi + 0.5) * kSphereUScale;
  h.v = (1.0 - theta / std::numbers::pi) * kSphereVScale;
  const double sin_phi = std::sin(phi), cos_phi = std::cos(phi);
  // d p / d phi = sin(theta) (cos phi, sin phi, 0): its direction does not depend on theta,
  // so the tangent is well defined at the poles where the derivative itself vanishes.
  h.tangent = {cos_phi, sin_phi, 0.0};
  const double du_dphi = kSphereUScale / two_pi;
  h.dpdu = (std::max(sin_theta, kSphereMinSinTheta) / du_dphi) * h.tangent;
  // v = (1 - theta/pi) V  =>  dp/dv = -(pi/V) dp/dtheta = (pi/V) (-cos t sin p, cos t cos p, sin
  // t).
  h.dpdv = (std::numbers::pi / kSphereVScale) *
           Vec3{-cos_theta * sin_phi, cos_theta * cos_phi, sin_theta};
  return h;
}

std::optional<SurfaceHit> IntersectPlane(Vec3 o, Vec3 d) {
  // Only rays going down reach z = 0 from the camera above it.
  if (!(d.z < 0.0)) return std::nullopt;
  const double t = -o.z / d.z;
  const Vec3 p = o + t * d;
  if (!(t > 0.0) || std::abs(p.x) > kPlaneHalfSize || std::abs(p.y) > kPlaneHalfSize) {
    return std::nullopt;
  }
  SurfaceHit h;
  h.p = {p.x, p.y, 0.0};
  h.n = {0.0, 0.0, 1.0};
  h.tangent = {1.0, 0.0, 0.0};
  h.u = p.x * kPlaneUvScale;
  h.v = p.y * kPlaneUvScale;
  h.dpdu = {1.0 / kPlaneUvScale, 0.0, 0.0};
  h.dpdv = {0.0, 1.0 / kPlaneUvScale, 0.0};
  return h;
}

// Intersection of the ray eye + t * d_offset with the tangent plane at `hit`, if the ray
// reaches the plane in front of the camera.
std::optional<Vec3> HitTangentPlane(Vec3 eye, Vec3 d_offset, const SurfaceHit &hit) {
  const double plane_dist = Dot(hit.n, hit.p - eye);  // < 0: the eye is in front of the face
  const double denom = Dot(hit.n, d_offset);
  const double t = plane_dist / denom;
  if (denom < 0.0 && std::isfinite(t) && t > 0.0) return eye + t * d_offset;
  return std::nullopt;
}

// Position differential on the tangent plane for a one-pixel step of the ray direction from
// d_minus to d_plus (half a pixel either side of the centre ray d).
//
// pbrt offsets by a whole pixel to one side; centring the two offset rays on the pixel makes
// the estimate of dp/dx second-order accurate instead of first-order, which matters at low
// preview resolutions (at 160x120 the one-sided version differs from central surface
// differences by up to 3% near the sphere's top; the centred one is within 5e-4 of the true
// derivative there) and costs nothing.
//
// If either offset ray misses the tangent plane (near a silhouette it can run parallel to
// the plane or away from it), fall back to Igehy's analytic transfer of the differential,
//   dP = t dD + dt D,  dt = -t (dD . n) / (D . n),
// which is finite wherever the centre ray hits the front face.
Vec3 TangentPlaneDifferential(Vec3 eye, Vec3 d, Vec3 d_minus, Vec3 d_plus, const SurfaceHit &hit) {
  const std::optional<Vec3> p_minus = HitTangentPlane(eye, d_minus, hit);
  const std::optional<Vec3> p_plus = HitTangentPlane(eye, d_plus, hit);
  if (p_minus && p_plus) return *p_plus - *p_minus;
  const double t = Dot(hit.n, hit.p - eye) / Dot(hit.n, d);
  const Vec3 dd = d_plus - d_minus;
  const double dt = -t * Dot(dd, hit.n) / Dot(d, hit.n);
  return t * dd + dt * d;
}

// Least-squares (du, dv) with [dpdu dpdv] (du, dv)^T ~= dp, via the 2x2 normal equations;
// dp lies in the tangent plane, which dpdu and dpdv span, so the residual is rounding only.
void SolveUv(const SurfaceHit &hit, Vec3 dp, double *du, double *dv) {
  const double aa = Dot(hit.dpdu, hit.dpdu), ab = Dot(hit.dpdu, hit.dpdv);
  const double bb = Dot(hit.dpdv, hit.dpdv);
  const double ra = Dot(hit.dpdu, dp), rb = Dot(hit.dpdv, dp);
  const double det = aa * bb - ab * ab;
  if (!(det > 0.0)) {  // degenerate parameterisation: no uv filter rather than NaN
    *du = *dv = 0.0;
    return;
  }
  *du = (bb * ra - ab * rb) / det;
  *dv = (aa * rb - ab * ra) / det;
}

void Add3(google::protobuf::RepeatedField<float> *field, Vec3 a) {
  field->Add(static_cast<float>(a.x));
  field->Add(static_cast<float>(a.y));
  field->Add(static_cast<float>(a.z));
}

}  // namespace

bool ParsePreviewShape(const std::string &name, PreviewShape *shape) {
  if (name == "sphere") {
    *shape = PreviewShape::kSphere;
    return true;
  }
  if (name == "plane") {
    *shape = PreviewShape::kPlane;
    return true;
  }
  return false;
}

const PreviewCamera &PreviewCameraFor(PreviewShape shape) {
  return shape == PreviewShape::kSphere ? kSphereCamera : kPlaneCamera;
}

PreviewQueries BuildPreviewQueries(PreviewShape shape, int width, int height) {
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("BuildPreviewQueries: width and height must be positive, got " +
                                std::to_string(width) + "x" + std::to_string(height));
  }
  if (static_cast<int64_t>(width) * height > std::numeric_limits<int32_t>::max()) {
    throw std::invalid_argument("BuildPreviewQueries: " + std::to_string(width) + "x" +
                                std::to_string(height) + " pixels do not fit an int32 index");
  }
  const Camera camera(PreviewCameraFor(shape), width, height);
  const Vec3 eye = camera.eye();
  auto intersect = shape == PreviewShape::kSphere ? IntersectSphere : IntersectPlane;

  PreviewQueries out;
  out.width = width;
  out.height = height;
  glint::v1::QueryBatch &q = out.queries;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double px = x + 0.5, py = y + 0.5;
      const Vec3 d = camera.Direction(px, py);
      const std::optional<SurfaceHit> hit = intersect(eye, d);
      if (!hit) continue;

      double dudx, dvdx, dudy, dvdy;
      const Vec3 dpdx = TangentPlaneDifferential(eye, d, camera.Direction(px - 0.5, py),
                                                 camera.Direction(px + 0.5, py), *hit);
      const Vec3 dpdy = TangentPlaneDifferential(eye, d, camera.Direction(px, py - 0.5),
                                                 camera.Direction(px, py + 0.5), *hit);
      SolveUv(*hit, dpdx, &dudx, &dvdx);
      SolveUv(*hit, dpdy, &dudy, &dvdy);

      q.add_uv(static_cast<float>(hit->u));
      q.add_uv(static_cast<float>(hit->v));
      q.add_footprint(static_cast<float>(dudx));
      q.add_footprint(static_cast<float>(dvdx));
      q.add_footprint(static_cast<float>(dudy));
      q.add_footprint(static_cast<float>(dvdy));
      Add3(q.mutable_wo(), Normalize(eye - hit->p));
      Add3(q.mutable_position(), hit->p);
      Add3(q.mutable_normal(), hit->n);
      Add3(q.mutable_tangent(), hit->tangent);
      out.pixel_of_query.push_back(y * width + x);
    }
  }
  q.set_count(static_cast<uint32_t>(out.pixel_of_query.size()));
  return out;
}

}  // namespace glint::client
