/* Power-of-two rescaling of a polygon's vertices (relative to the shading
 * point) into the range where the area methods' products neither overflow nor
 * underflow, for lights very far from (or very close to) the shading point.
 * Applied once, where every method receives the polygon (area_polygon_load_n,
 * area_ltc.h), so LTC, LECOCQ, LECOCQ_PEARSON, MONTE_CARLO, REFERENCE, AUTO
 * and the glint models' per-light paths all see the same scaled vertices.
 *
 * Why: every method's result depends only on the directions of the vertices
 * (homogeneous of degree 0 in them), but the code multiplies coordinates:
 * the facing test (area_polygon_facing: a cross product dotted with a vertex,
 * a cube), LTC's edge terms (polygon_wedge.h: cross products), the vertex
 * lengths REFERENCE, LECOCQ and the glint models normalise by (sums of
 * squares), MONTE_CARLO's spherical triangles (products of three lengths). In
 * fp32 the cubes overflow beyond ~1e12 and the squares beyond ~1e19, where
 * every method gave 0 (issue 13); towards ~1e-13 and ~1e-19 they underflow
 * into subnormals and then 0. Multiplying every vertex by the same power of
 * two is exact (no rounding while the results stay normal) and keeps every
 * direction; every later step of each method either is homogeneous (products,
 * ratios, atan2 of two quantities of one degree, comparisons with 0) or
 * normalises, so a scaled light gives the result of the unscaled one bit for
 * bit: tests/service/area_far_light_test.cpp checks that for every method.
 *
 * Only lanes whose vertices are out of range are scaled, so a lane's result
 * never depends on its neighbours; the branch is uniform (glint_any) and an
 * ordinary light pays one sum of squares and two comparisons. */
#ifndef GLINT_POLYGON_SCALE_H
#define GLINT_POLYGON_SCALE_H

#include "kernels/area/unroll.h"
#include "kernels/compat.h"

/* Exact powers of two (representable in fp32 and fp64). */
#define GLINT_POLYGON_SCALE_2P16 GLINT_R(65536.0)
#define GLINT_POLYGON_SCALE_2M16 GLINT_R(1.52587890625e-5)
#define GLINT_POLYGON_SCALE_2P32 GLINT_R(4294967296.0)
#define GLINT_POLYGON_SCALE_2M32 GLINT_R(2.3283064365386962890625e-10)
#define GLINT_POLYGON_SCALE_2P60 GLINT_R(1152921504606846976.0)
#define GLINT_POLYGON_SCALE_2M60 GLINT_R(8.67361737988403547205962240695953e-19)

/* The lanes whose vertices v[0 .. n) need polygon_rescale_lanes: the sum of
 * the squared vertex lengths is outside [2^-60, 2^60] or not finite (a vertex
 * overflowed, or the sum did). Lights between ~1e-9 and ~1e9 from the shading
 * point are never touched, so their results are those of the unscaled code
 * bit for bit. */
GLINT_FN glint_mask polygon_scale_odd(const GLINT_PRIVATE real3 *v, int n) {
  real s2 = GLINT_R(0.0);
  GLINT_UNROLL for (int i = 0; i < n; ++i) s2 += r3_dot(v[i], v[i]);
  return !((s2 <= GLINT_POLYGON_SCALE_2P60) & (s2 >= GLINT_POLYGON_SCALE_2M60));
}

/* The largest coordinate magnitude of v[0 .. n) (NaN when one is NaN:
 * fmax would drop it, so NaNs are kept explicitly). */
GLINT_FN real polygon_scale_max(const GLINT_PRIVATE real3 *v, int n) {
  real m = GLINT_R(0.0);
  for (int i = 0; i < n; ++i) {
    real c = fmax(fabs(v[i].x), fmax(fabs(v[i].y), fabs(v[i].z)));
    /* Sticky: once m is NaN it stays NaN (fmax(NaN, c) would return c). */
    glint_mask nan = (m != m) | (v[i].x != v[i].x) | (v[i].y != v[i].y) | (v[i].z != v[i].z);
    m = glint_select(fmax(m, c), m + v[i].x + v[i].y + v[i].z, nan);
  }
  return m;
}

/* Multiplies v[0 .. n) in the lanes `odd` by the power of two 2^(32 k) that
 * puts their largest coordinate magnitude m into [2^-16, 2^16]: there the
 * facing product (<= ~6 n m^3), LTC's edge products and MONTE_CARLO's
 * products of three lengths stay far inside fp32's normal range
 * [2^-126, 2^128], and every vertex length is inside [1e-8, 1e8], where
 * MONTE_CARLO's own (inexact) normalisation of long vertices
 * (mc_polygon_setup) does not trigger (it triggers only outside what this
 * loader passes unscaled at all), so a scaled light is that light at
 * distance ~1 bit for bit. The vertices come from float records, so in fp64
 * 2^-149 <= m <= 2^130 (with a frame's rotation): five steps of 2^32 each way
 * reach the range (at most four are needed downwards). Lanes with m = 0 (all
 * vertices at the shading point: 0 anyway) or m not finite (the caller has
 * reloaded those, area_polygon_load_n) are left alone. */
GLINT_FN void polygon_rescale_lanes(GLINT_PRIVATE real3 *v, int n, glint_mask odd) {
  real m = polygon_scale_max(v, n);
  for (int step = 0; step < 5; ++step) {
    glint_mask big = odd & (m > GLINT_POLYGON_SCALE_2P16) & (m - m == GLINT_R(0.0));
    glint_mask small = odd & (m < GLINT_POLYGON_SCALE_2M16) & (m > GLINT_R(0.0));
    real f = glint_select(glint_select(GLINT_R(1.0), GLINT_POLYGON_SCALE_2P32, small),
                          GLINT_POLYGON_SCALE_2M32, big);
    m = m * f;
    for (int i = 0; i < n; ++i) v[i] = r3_scale(v[i], f);
  }
}

#endif /* GLINT_POLYGON_SCALE_H */
