// kernels/area/polygon_wedge.h (LTC's two clips and the edge sum in one pass over the edges) and
// kernels/area/atan_poly.h (its fp32 arctangent) against independent references written here:
//  - the form factor of a convex polygon clipped to z >= 0, mapped by a linear map, clipped to
//    z >= 0 again (the textbook sequential Sutherland & Hodgman 1974 clip, twice) and summed
//    by Lambert's edge formula (Arvo 1995 Eq. 4) over unit vertices with std::atan2: the
//    computation LTC did before, over random polygons that straddle one plane, both, neither,
//    touch them, and over maps whose two planes coincide (normal view, where the wedge has one
//    face). Both sides are exact up to double rounding, each of order eps64 times the sum of the
//    |edge terms| (<= (n + 2) / 2 for the n + 2 pieces of angle <= pi, times 1 / 2pi): the
//    tolerance 1e-12 is ~1000 eps64 times that sum's bound for n <= 6, far below any
//    geometric mistake (a piece missed or counted twice changes the result by a whole edge term);
//  - atan2_nonneg against std::atan2 in double over angles in (0, pi] and scales 1e-30 to 1e30:
//    fp32 within the fitted polynomial's error (1.52e-8, tools/ltc/fit_atan_poly.py) plus 8 float
//    roundings of 2^-24 (Horner's 9 steps measured <= 2.8 ulp by the fit script, the division,
//    the two reflections, the rounded pi constants); fp64 exactly std::atan2.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace k64 {
#define GLINT_USE_DOUBLE 1
#include "kernels/area/polygon_wedge.h"
}  // namespace k64
#undef GLINT_COMPAT_H
#undef GLINT_POLYGON_H
#undef GLINT_POLYGON_WEDGE_H
#undef GLINT_ATAN_POLY_H
#undef GLINT_USE_DOUBLE
#undef GLINT_R
namespace k32 {
#define GLINT_USE_DOUBLE 0
#include "kernels/area/polygon_wedge.h"
}  // namespace k32

namespace {

struct V3 {
  double x, y, z;
};

V3 Add(V3 a, V3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
V3 Scale(V3 a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
V3 Cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double Dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

// Sutherland & Hodgman 1974 to z >= 0: for each edge a -> b keep a if inside, then the crossing.
std::vector<V3> Clip(const std::vector<V3> &in) {
  std::vector<V3> out;
  for (size_t i = 0; i < in.size(); ++i) {
    const V3 a = in[i], b = in[(i + 1) % in.size()];
    if (a.z >= 0) out.push_back(a);
    if ((a.z >= 0) != (b.z >= 0)) {
      V3 p = Add(a, Scale(Add(b, Scale(a, -1)), a.z / (a.z - b.z)));
      p.z = 0;
      out.push_back(p);
    }
  }
  return out;
}

// Arvo 1995 Eq. 4: (1 / 2pi) sum over edges a -> b of theta(a, b) (b x a).z / |b x a| on unit
// vectors (the receiver inside the sphere sees counter-clockwise polygons as clockwise).
double FormFactor(const std::vector<V3> &v) {
  std::vector<V3> u;
  for (V3 p : v)
    if (Dot(p, p) > 0) u.push_back(Scale(p, 1 / std::sqrt(Dot(p, p))));
  if (u.size() < 3) return 0;
  double sum = 0;
  for (size_t i = 0; i < u.size(); ++i) {
    const V3 a = u[i], b = u[(i + 1) % u.size()];
    const V3 c = Cross(b, a);
    const double s = std::sqrt(Dot(c, c));
    if (s > 0) sum += c.z * std::atan2(s, Dot(a, b)) / s;
  }
  return sum / (2 * M_PI);
}

// The LTC map of area_ltc_transform: rotate by (tx, ty) about z, then [[m0, 0, m1], [0, 1, 0],
// [m2, 0, m3]] on (x, y, z).
struct Map {
  double tx, ty, m[4];
  V3 operator()(V3 c) const {
    const double x = c.x * tx + c.y * ty, y = -c.x * ty + c.y * tx;
    return {m[0] * x + m[1] * c.z, y, m[2] * x + m[3] * c.z};
  }
};

double Reference(const std::vector<V3> &v, const Map &map) {
  std::vector<V3> once = Clip(v);
  for (V3 &p : once) p = map(p);
  return FormFactor(Clip(once));
}

double Wedge(const std::vector<V3> &v, const Map &map) {
  k64::real3 o[8];
  double d1[8];
  for (size_t i = 0; i < v.size(); ++i) {
    const V3 p = map(v[i]);
    o[i] = k64::make_real3(p.x, p.y, p.z);
    d1[i] = v[i].z;
  }
  return k64::polygon_wedge_form_factor(o, d1, int(v.size()));
}

// A convex polygon of n vertices on an ellipse in a random plane near the origin, counter-clockwise
// or clockwise seen from the origin at random.
std::vector<V3> RandomPolygon(std::mt19937 &rng, int n) {
  std::uniform_real_distribution<double> u(-1, 1), r(0.1, 2);
  const V3 c = {2 * u(rng), 2 * u(rng), 2 * u(rng)};
  V3 a = {u(rng), u(rng), u(rng)}, b = {u(rng), u(rng), u(rng)};
  a = Scale(a, 1 / std::sqrt(Dot(a, a)));
  b = Add(b, Scale(a, -Dot(a, b)));
  b = Scale(b, 1 / std::sqrt(Dot(b, b)));
  const double ra = r(rng), rb = r(rng), phase = u(rng) * M_PI;
  std::vector<V3> v;
  for (int i = 0; i < n; ++i) {
    // Increasing angles with random gaps (< pi each, so the polygon stays convex).
    const double t = phase + 2 * M_PI * (i + 0.3 * u(rng)) / n;
    v.push_back(Add(c, Add(Scale(a, ra * std::cos(t)), Scale(b, rb * std::sin(t)))));
  }
  return v;
}

Map RandomMap(std::mt19937 &rng) {
  std::uniform_real_distribution<double> u(-1, 1), s(0.05, 20);
  const double phi = M_PI * u(rng);
  Map m{std::cos(phi), std::sin(phi), {s(rng), u(rng) * 5, u(rng) * 5, s(rng)}};
  if (m.m[0] * m.m[3] - m.m[1] * m.m[2] <= 0) m.m[1] = -m.m[1], m.m[2] = -m.m[2];
  if (m.m[0] * m.m[3] - m.m[1] * m.m[2] <= 0) m.m[1] = m.m[2] = 0;  // det > 0, as LTC's M^-1
  return m;
}

TEST(PolygonWedge, MatchesTwoSequentialClipsAndTheEdgeSum) {
  std::mt19937 rng(13);
  int straddle1 = 0, straddle2 = 0, below = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const int n = 3 + trial % 4;
    std::vector<V3> v = RandomPolygon(rng, n);
    Map map = RandomMap(rng);
    if (trial % 5 == 0) map.m[2] = 0;  // normal view: the planes coincide
    if (trial % 7 == 0) {              // a vertex on the horizon: the polygon translated along z
      const double z = v[trial % n].z;
      for (V3 &p : v) p.z -= z;
    }
    if (trial % 11 == 0) map.m[2] = -map.m[0] * 1e-9;  // nearly coincident planes
    const double ref = Reference(v, map), got = Wedge(v, map);
    ASSERT_NEAR(got, ref, 1e-12) << "trial " << trial << " n " << n;
    bool above = false, under = false;
    for (V3 p : v) (p.z >= 0 ? above : under) = true;
    straddle1 += above && under;
    below += !above;
    bool above2 = false, under2 = false;
    for (V3 p : Clip(v)) (map(p).z >= 0 ? above2 : under2) = true;
    straddle2 += above2 && under2;
  }
  // The sample exercises every case of the clips (counts printed for the record).
  std::printf("straddling the horizon %d, its image clipped again %d, wholly below %d of 20000\n",
              straddle1, straddle2, below);
  EXPECT_GT(straddle1, 2000);
  EXPECT_GT(straddle2, 2000);
  EXPECT_GT(below, 500);
}

// Polygons whose plane contains the shading point (an edge through it, cut there by a clip
// plane; issue 8): seen edge-on, the exact integral is 0, and it stays finite.
TEST(PolygonWedge, EdgeThroughTheShadingPointGivesZero) {
  const Map identity{1, 0, {1, 0, 0, 1}}, tilted{0.6, 0.8, {2, 0.5, -0.3, 1.5}};
  const std::vector<std::vector<V3>> polygons = {
      {{-1, -1, -1}, {1, 1, 1}, {0, 1, 1}},  // crosses the horizon at the origin
      {{-2, 0, -1}, {2, 0, 1}, {0, 3, 1.5}, {-1, 2, 0.5}}};
  for (const auto &v : polygons)
    for (const Map &m : {identity, tilted}) {
      const double got = Wedge(v, m);
      EXPECT_EQ(got, 0.0);
      EXPECT_NEAR(Reference(v, m), 0.0, 1e-12);  // the sequential clips agree
    }
}

TEST(AtanPoly, Fp32WithinTheFitsErrorAndFp64IsLibm) {
  const double bound = 1.52e-8 + 8 * std::ldexp(1.0, -24);
  double worst = 0;
  for (double scale : {1e-30, 1e-8, 1.0, 3e7, 1e30}) {
    for (int k = 1; k <= 200000; ++k) {
      const double theta = M_PI * k / 200000.0;
      const float y = float(scale * std::sin(theta)), x = float(scale * std::cos(theta));
      const double exact = std::atan2(double(y), double(x));  // of the rounded arguments
      const double got = double(k32::atan2_nonneg(y, x));
      worst = std::max(worst, std::fabs(got - exact) / exact);
      ASSERT_LE(std::fabs(got - exact), bound * exact) << "theta " << theta << " scale " << scale;
      ASSERT_EQ(k64::atan2_nonneg(double(y), double(x)), exact);
    }
  }
  EXPECT_EQ(k32::atan2_nonneg(0.0f, 0.0f), 0.0f);
  EXPECT_EQ(k32::atan2_nonneg(0.0f, -1.0f), float(M_PI));
  std::printf("atan2_nonneg fp32: worst relative error %.3g (bound %.3g)\n", worst, bound);
}

}  // namespace
