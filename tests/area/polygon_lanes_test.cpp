// The branch-free clip and form factor of kernels/area/polygon.h (the lane-safe forms the
// 8-lane LTC kernel runs, here on the host's scalars) against an independent sequential
// Sutherland-Hodgman written below and the edge sum of Arvo 1995 Eq. 4 on its output, over
// random convex polygons that straddle the horizon, touch it, lie wholly below or above it, and
// over the per-lane input counts of a second clip (fewer vertices than the uniform bound, the
// unused slots holding garbage). Both sides do the same arithmetic per vertex, so the counts and
// the vertices must be equal exactly and the form factors equal to a few ulps (the edge sum is
// in the same order); a slot written past a lane's count, a missed wrap-around or a
// mis-bounded select shows as a different count or vertex.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace k64 {
#define GLINT_USE_DOUBLE 1
#include "kernels/area/polygon.h"
}  // namespace k64

namespace {

using k64::real3;

// The textbook sequential clip to z >= 0 (Sutherland & Hodgman 1974): for each edge a -> b,
// keep a if inside, add the crossing point if the edge crosses the plane.
std::vector<real3> ClipSequential(const std::vector<real3> &in) {
  std::vector<real3> out;
  const size_t n = in.size();
  for (size_t i = 0; i < n; ++i) {
    const real3 a = in[i], b = in[(i + 1) % n];
    const bool a_in = a.z >= 0.0, b_in = b.z >= 0.0;
    if (a_in) out.push_back(a);
    if (a_in != b_in) {
      const double t = a.z / (a.z - b.z);
      out.push_back(k64::make_real3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, 0.0));
    }
  }
  return out;
}

// Arvo 1995 Eq. 4 over the unit vertices, skipping vertices at the origin, written out here.
double FormFactorSequential(const std::vector<real3> &v) {
  std::vector<real3> u;
  for (real3 p : v) {
    const double l = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    if (l > 0.0) u.push_back(k64::make_real3(p.x / l, p.y / l, p.z / l));
  }
  if (u.size() < 3) return 0.0;
  double sum = 0.0;
  for (size_t i = 0; i < u.size(); ++i) {
    const real3 b = u[i], a = u[(i + u.size() - 1) % u.size()];  // edge term of (b, a)
    const real3 c =
        k64::make_real3(b.y * a.z - b.z * a.y, b.z * a.x - b.x * a.z, b.x * a.y - b.y * a.x);
    const double s = std::sqrt(c.x * c.x + c.y * c.y + c.z * c.z);
    const double theta = std::atan2(s, b.x * a.x + b.y * a.y + b.z * a.z);
    sum += c.z * (s > 1e-30 ? theta / s : 1.0);
  }
  return sum * 0.5 / 3.14159265358979323846;
}

// A random convex polygon: n points on an ellipse in a random plane, centred somewhere around
// the horizon. In a third of them the plane holds a horizontal axis through a horizon point, so
// that vertex 0 lies exactly on the horizon (z = 0), the case the clip keeps without a crossing.
std::vector<real3> RandomPolygon(std::mt19937 &rng, int n) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const bool touching = u(rng) < -0.33;
  real3 c = k64::make_real3(u(rng), u(rng), 0.8 * u(rng));
  real3 e1 = k64::make_real3(u(rng), u(rng), u(rng));
  const real3 e2 = k64::make_real3(u(rng), u(rng), u(rng));
  if (touching) c.z = 0.0, e1.z = 0.0;
  std::vector<real3> p;
  for (int i = 0; i < n; ++i) {
    const double jitter = i == 0 ? 0.0 : 0.3 * (u(rng) + 1.0) / 2.0;
    const double a = 2.0 * 3.14159265358979323846 * (i + jitter) / n;
    p.push_back(k64::make_real3(c.x + e1.x * std::cos(a) + e2.x * std::sin(a),
                                c.y + e1.y * std::cos(a) + e2.y * std::sin(a),
                                c.z + e1.z * std::cos(a) + e2.z * std::sin(a)));
  }
  return p;
}

TEST(PolygonLanes, ClipMatchesSequentialSutherlandHodgman) {
  std::mt19937 rng(5);
  int straddling = 0, below = 0, on_horizon = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const int n = 3 + trial % (GLINT_POLYGON_MAX_VERTICES - 2);
    // A uniform bound above the polygon's own count, as for a lane of a second clip.
    const int n_max = n + trial % 3;
    std::vector<real3> in = RandomPolygon(rng, n);
    std::vector<real3> padded(in);
    for (int k = n; k < n_max; ++k) padded.push_back(k64::make_real3(1e30, -7.0, -3.0));
    std::vector<real3> out(size_t(n_max) + 1);
    const int m = k64::polygon_clip_to_horizon_lanes(padded.data(), n, n_max, out.data());
    const std::vector<real3> expected = ClipSequential(in);
    ASSERT_EQ(m, int(expected.size())) << "trial " << trial;
    for (int k = 0; k < m; ++k) {
      ASSERT_EQ(out[k].x, expected[k].x) << "trial " << trial << " vertex " << k;
      ASSERT_EQ(out[k].y, expected[k].y) << "trial " << trial << " vertex " << k;
      ASSERT_EQ(out[k].z, expected[k].z) << "trial " << trial << " vertex " << k;
    }
    const double ff = k64::polygon_form_factor_lanes(out.data(), m, n_max + 1);
    const double ref = FormFactorSequential(expected);
    // The same terms summed in the same order: equal up to the ulps of the final scaling.
    ASSERT_NEAR(ff, ref, 1e-14 * (1.0 + std::fabs(ref))) << "trial " << trial;
    straddling += m > 0 && m != n;
    below += m == 0;
    on_horizon += in[0].z == 0.0;
  }
  // The sample must exercise the clip: many polygons cross the horizon, some lie below it, some
  // have a vertex on it.
  EXPECT_GT(straddling, 1000);
  EXPECT_GT(below, 100);
  EXPECT_GT(on_horizon, 1000);
}

}  // namespace
