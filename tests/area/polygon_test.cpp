// kernels/area/polygon.h against independent references: brute-force quadrature
// of cos(theta) over the hemisphere with a ray-polygon inside test, and the
// small-light limit A cos_l cos_r / d^2.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace k64 {
#define GLINT_USE_DOUBLE 1
#include "kernels/area/polygon.h"
}  // namespace k64

namespace {

struct V3 {
  double x, y, z;
};
V3 Sub(V3 a, V3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3 Cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double Dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

double FormFactor(const std::vector<V3> &poly) {
  std::vector<k64::real3> in, out(GLINT_POLYGON_MAX_CLIPPED);
  for (V3 v : poly) in.push_back(k64::make_real3(v.x, v.y, v.z));
  int m = k64::polygon_clip_to_horizon(in.data(), int(in.size()), out.data());
  return k64::polygon_form_factor(out.data(), m);
}

// Does the ray from the origin along d hit the planar convex polygon? Returns
// +1 (front: seen counter-clockwise), -1 (back), 0 (miss).
int Hit(const std::vector<V3> &poly, V3 d) {
  V3 n = Cross(Sub(poly[1], poly[0]), Sub(poly[2], poly[0]));
  double denom = Dot(n, d);
  if (std::fabs(denom) < 1e-15) return 0;
  double t = Dot(n, poly[0]) / denom;
  if (t <= 0) return 0;
  V3 p = {d.x * t, d.y * t, d.z * t};
  int sign = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    V3 e = Sub(poly[(i + 1) % poly.size()], poly[i]);
    double s = Dot(Cross(e, Sub(p, poly[i])), n);
    int si = s > 0 ? 1 : -1;
    if (sign == 0)
      sign = si;
    else if (si != sign)
      return 0;
  }
  // The right-hand normal n points at the receiver (origin) for a front face.
  return Dot(n, poly[0]) < 0 ? 1 : -1;
}

// (1/pi) * integral over the upper hemisphere of cos(theta) * hit, midpoint
// rule in (cos^2 theta, phi): cos(theta) d(omega) = d(cos^2)/2 d(phi), so the
// cosine weight is absorbed, the integrand is the (signed) indicator, and
// (1/pi) * (1/2) * 2 pi = 1 leaves the plain mean over the grid.
double BruteForce(const std::vector<V3> &poly, int n) {
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    double c2 = (i + 0.5) / n;
    double ct = std::sqrt(c2), st = std::sqrt(1 - c2);
    for (int j = 0; j < 2 * n; ++j) {
      double phi = (j + 0.5) / (2 * n) * 2 * M_PI;
      sum += Hit(poly, {st * std::cos(phi), st * std::sin(phi), ct});
    }
  }
  return sum / (2.0 * n * n);
}

TEST(Polygon, FormFactorMatchesBruteForce) {
  // Quads facing down (towards the receiver at the origin): vertices
  // counter-clockwise seen from below.
  const std::vector<std::vector<V3>> polys = {
      {{-1, -1, 1}, {-1, 1, 1}, {1, 1, 1}, {1, -1, 1}},            // overhead
      {{0.5, -1, 0.5}, {0.5, 1, 0.5}, {2, 1, 1.5}, {2, -1, 1.5}},  // tilted, off-axis
      {{-1, -1, -0.5}, {-1, 1, -0.5}, {1, 1, 1.5}, {1, -1, 1.5}},  // partly below horizon
      {{0.2, 0.4, 2}, {0.3, 0.1, 2}, {0, 0, 2}},                   // small triangle
  };
  for (size_t k = 0; k < polys.size(); ++k) {
    double ff = FormFactor(polys[k]);
    double bf = BruteForce(polys[k], 800);
    EXPECT_NEAR(ff, bf, 2e-3 * std::fabs(bf) + 2e-4) << "polygon " << k;
    EXPECT_GT(ff, 0.0) << "polygon " << k;
  }
}

TEST(Polygon, BackFacingIsNegativeAndBelowHorizonIsZero) {
  std::vector<V3> front = {{-1, -1, 1}, {-1, 1, 1}, {1, 1, 1}, {1, -1, 1}};
  std::vector<V3> back(front.rbegin(), front.rend());
  EXPECT_NEAR(FormFactor(back), -FormFactor(front), 1e-12);
  std::vector<V3> below = {{-1, -1, -1}, {-1, 1, -1}, {1, 1, -0.1}, {1, -1, -0.1}};
  EXPECT_EQ(FormFactor(below), 0.0);
}

TEST(Polygon, SmallLightLimitAndFullHemisphere) {
  // A tiny square of area A at distance d along direction l, facing the
  // receiver: form factor -> A cos_r / (pi d^2).
  const double d = 10.0, side = 0.01, ct = 0.6, st = 0.8;
  V3 c = {st * d, 0, ct * d}, u = {0, side / 2, 0}, w = {-ct * side / 2, 0, st * side / 2};
  std::vector<V3> sq = {{c.x - u.x - w.x, c.y - u.y - w.y, c.z - u.z - w.z},
                        {c.x + u.x - w.x, c.y + u.y - w.y, c.z + u.z - w.z},
                        {c.x + u.x + w.x, c.y + u.y + w.y, c.z + u.z + w.z},
                        {c.x - u.x + w.x, c.y - u.y + w.y, c.z - u.z + w.z}};
  double ff = FormFactor(sq);
  double want = side * side * ct / (M_PI * d * d);
  EXPECT_NEAR(std::fabs(ff), want, 1e-6 * want);
  // A huge overhead square fills the hemisphere: form factor -> 1.
  const double big = 1e6;
  std::vector<V3> sky = {{-big, -big, 1}, {-big, big, 1}, {big, big, 1}, {big, -big, 1}};
  EXPECT_NEAR(FormFactor(sky), 1.0, 1e-5);
}

}  // namespace
