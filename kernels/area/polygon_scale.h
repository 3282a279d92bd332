/* Power-of-two rescaling of a polygon's vertices (relative to the shading
 * point) into the range where the LTC pass's products neither overflow nor
 * underflow, for lights very far from (or very close to) the shading point.
 *
 * Why: LTC's integral depends only on the directions of the vertices, but
 * the facing test (area_polygon_facing: a cross product dotted with a vertex,
 * a cube of the coordinates) and the edge terms (polygon_wedge.h: cross
 * products of the transformed vertices) multiply coordinates. In fp32,
 * beyond ~1e12 the facing product overflows (to an infinity of the right
 * sign, or to NaN where two of its terms overflow with opposite signs: the
 * light is then taken as back-facing), and beyond ~1e19 the cross products
 * themselves overflow and the light gave 0 (issue 13); towards ~1e-13 the
 * products underflow into subnormals and lose their digits. Multiplying
 * every vertex by the same power of two is exact (no rounding while the
 * results stay normal), keeps every direction, and leaves the LTC result
 * bit-identical: every step of the pass is homogeneous in the vertices
 * (products, ratios, atan2 of two quantities of the same degree).
 *
 * Only lanes whose vertices are out of range are scaled, so a lane's result
 * never depends on its neighbours; the branch is uniform (glint_any). */
#ifndef GLINT_POLYGON_SCALE_H
#define GLINT_POLYGON_SCALE_H

#include "kernels/area/unroll.h"
#include "kernels/compat.h"

/* Exact powers of two (representable in fp32 and fp64). */
#define GLINT_POLYGON_SCALE_2P32 GLINT_R(4294967296.0)
#define GLINT_POLYGON_SCALE_2M32 GLINT_R(2.3283064365386962890625e-10)
#define GLINT_POLYGON_SCALE_2P60 GLINT_R(1152921504606846976.0)
#define GLINT_POLYGON_SCALE_2M60 GLINT_R(8.67361737988403547205962240695953e-19)

/* Rescales v[0 .. n) in the lanes where the sum of the squared vertex lengths
 * is outside [2^-60, 2^60] (or not finite), so that the largest coordinate
 * magnitude m lands in [2^-32, 2^32]: with it the facing product (<= ~6 n m^3)
 * and the edge terms' products stay far inside fp32's range
 * [2^-126, 2^128]. The vertices come from float records, so m <= 2^129 (in
 * fp64; in fp32 a vertex minus a position of opposite sign beyond ~1.7e38 is
 * already Inf before this point and the light gives 0) and the smallest
 * nonzero m is >= 2^-149: four steps of 2^32 each way reach the range. Lanes in range are left
 * alone (also in the branch, so that their results do not depend on their neighbours), and so is a
 * lane at the shading point (m = 0: it gives 0 anyway). */
GLINT_FN void polygon_rescale(GLINT_PRIVATE real3 *v, int n) {
  real s2 = GLINT_R(0.0);
  GLINT_UNROLL for (int i = 0; i < n; ++i) s2 += r3_dot(v[i], v[i]);
  glint_mask odd = !((s2 <= GLINT_POLYGON_SCALE_2P60) & (s2 >= GLINT_POLYGON_SCALE_2M60));
  if (!glint_any(odd)) return;
  real m = GLINT_R(0.0);
  for (int i = 0; i < n; ++i) m = fmax(m, fmax(fabs(v[i].x), fmax(fabs(v[i].y), fabs(v[i].z))));
  for (int step = 0; step < 4; ++step) {
    glint_mask big = odd & (m > GLINT_POLYGON_SCALE_2P32);
    glint_mask small = odd & (m < GLINT_POLYGON_SCALE_2M32) & (m > GLINT_R(0.0));
    real f = glint_select(glint_select(GLINT_R(1.0), GLINT_POLYGON_SCALE_2P32, small),
                          GLINT_POLYGON_SCALE_2M32, big);
    m = m * f;
    for (int i = 0; i < n; ++i) v[i] = r3_scale(v[i], f);
  }
}

#endif /* GLINT_POLYGON_SCALE_H */
