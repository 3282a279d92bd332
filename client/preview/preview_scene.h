// Preview scenes for lookdev: a pinhole camera looking at a unit sphere or a finite ground
// plane, turned into one glint query per covered pixel.
//
// Every query carries a world-space frame (position, normal, tangent), so the lights of a
// preview request are world space too (DESIGN.md conventions). The queries carry no `wi`:
// previews are shaded by lights, not BRDF probes.
//
// Image conventions (shared with image_io.h): pixel (x, y) is column x, row y, row 0 at the
// top; its centre is at (x + 0.5, y + 0.5) in continuous pixel coordinates. The footprint
// (du/dx, dv/dx, du/dy, dv/dy) is per pixel along +x (one column right) and +y (one row
// DOWN), which is the pixel-space Jacobian an image-space filter expects.
//
// Scene parameters (all in world units, +z up):
//
// Sphere (PreviewShape::kSphere)
//   - unit sphere at the origin;
//   - camera at kSphereCamera.eye = (0, -4, 1.2) looking at the origin, 35 deg vertical FOV:
//     the sphere's silhouette spans about 80% of the image height;
//   - uv is a lat-long map turned so that its seam (u = 0 = kSphereUScale) lies on the far
//     side (+y) of the sphere and u grows to the right in the image:
//       phi   = atan2(x, -y)              in (-pi, pi], 0 on the meridian facing the camera,
//       theta = colatitude from +z        in [0, pi],
//       u     = (phi / (2 pi) + 1/2) * kSphereUScale,
//       v     = (1 - theta / pi)  * kSphereVScale    (v grows towards the north pole +z).
//     v grows northwards (rather than with theta) so that dp/du, dp/dv, n is right-handed,
//     i.e. dp/dv points along bitangent = normal x tangent, the frame the server builds
//     (kernels/frame.h). kSphereUScale = 2 * kSphereVScale makes uv texels square on the
//     equator;
//   - tangent = dp/du normalised = (cos phi, sin phi, 0), computed from phi directly so it stays
//     unit and orthogonal to the normal at the poles too, where dp/du itself vanishes;
//   - at the poles u is singular: du/dx is bounded by clamping sin(theta) to
//     kSphereMinSinTheta, which keeps the footprint finite (and enormous, as it should be).
//
// Plane (PreviewShape::kPlane)
//   - the square |x|, |y| <= kPlaneHalfSize = 2 in the plane z = 0, normal +z, tangent +x;
//     finite so that no pixel sees the horizon;
//   - camera at kPlaneCamera.eye = (0, -6.5, 3.5) looking at (0, -0.4, 0), 30 deg vertical
//     FOV: about 30 deg elevation, so view directions range from about 22 deg (far edge) to
//     36 deg (near edge) above the surface. In a 16:9 image the whole square is visible; in a
//     square image the two near corners are cut off;
//   - uv = (x, y) * kPlaneUvScale.
//
// Footprint: ray differentials in the manner of Igehy 1999 ("Tracing ray differentials") as
// pbrt does it: offset rays one pixel apart are intersected with the tangent plane at the hit
// point, and the position difference is mapped to a uv difference by solving the
// least-squares system [dp/du dp/dv] (du, dv)^T = dp. Unlike pbrt, the two offset rays sit
// half a pixel either side of the pixel centre (x +- 0.5, resp. y +- 0.5) rather than at the
// centre and one pixel to the right/below. The centred difference is second-order accurate:
// the footprint matches the Jacobian at the pixel centre to < 5e-4 relative away from grazing
// angles and the pole even at 160x120, where the one-sided version disagreed with central
// surface differences by up to 3% (tests/preview has the numbers). Where an offset ray does
// not reach the tangent plane (at a silhouette it can run parallel to it or away from it),
// the analytic first-order differential of Igehy's transfer equation is used instead, which
// exists wherever the centre ray hits the front face (a safeguard: no sphere pixel needed it
// at 120..4000 pixels square).
#ifndef GLINT_CLIENT_PREVIEW_PREVIEW_SCENE_H
#define GLINT_CLIENT_PREVIEW_PREVIEW_SCENE_H

#include <cstdint>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"

namespace glint::client {

enum class PreviewShape { kSphere, kPlane };

// Parses "sphere" / "plane"; returns false on anything else.
bool ParsePreviewShape(const std::string &name, PreviewShape *shape);

// A pinhole camera. Public so that tests (and documentation) can rebuild the camera rays
// without going through the code they check.
struct PreviewCamera {
  double eye[3];
  double look_at[3];
  double up[3];  // world up; the camera's own up is made orthogonal to the view direction
  double vertical_fov_deg;
};

inline constexpr PreviewCamera kSphereCamera{
    {0.0, -4.0, 1.2}, {0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, 35.0};
inline constexpr double kSphereUScale = 8.0;
inline constexpr double kSphereVScale = 4.0;
inline constexpr double kSphereMinSinTheta = 1e-6;

inline constexpr PreviewCamera kPlaneCamera{
    {0.0, -6.5, 3.5}, {0.0, -0.4, 0.0}, {0.0, 0.0, 1.0}, 30.0};
inline constexpr double kPlaneHalfSize = 2.0;
inline constexpr double kPlaneUvScale = 2.0;

// The camera used for `shape`.
const PreviewCamera &PreviewCameraFor(PreviewShape shape);

struct PreviewQueries {
  int width = 0, height = 0;
  glint::v1::QueryBatch queries;        // one query per pixel that hits the shape (count set)
  std::vector<int32_t> pixel_of_query;  // row-major pixel index (y*width+x) of each query
};

// Pinhole camera looking at the shape; every query carries uv, footprint (from ray
// differentials), wo (unit, world space, from the hit point towards the camera),
// and a world-space frame: position, normal (unit), tangent (unit, orthogonal to normal,
// pointing in the direction of increasing u). Lights in the preview are world space.
// Queries are in row-major pixel order. Throws std::invalid_argument if width or height is
// not positive or width * height does not fit an int32_t.
PreviewQueries BuildPreviewQueries(PreviewShape shape, int width, int height);

}  // namespace glint::client

#endif  // GLINT_CLIENT_PREVIEW_PREVIEW_SCENE_H
