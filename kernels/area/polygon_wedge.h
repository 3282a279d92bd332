/* The clamped-cosine integral of a convex polygon clipped to two half-spaces
 * through the shading point, without building the clipped polygon: LTC's two
 * clips (kernels/area/area_ltc.h: the shading horizon, then the cosine's
 * support o.z >= 0 after M^-1) in one pass over the edges, for the lanes.
 *
 * Why: the Sutherland-Hodgman clips (polygon.h) append each output vertex to
 * a per-lane slot, a select over every slot it might occupy, twice; for a
 * quad that is ~75 slot selects of a real3 per light, more than the edge
 * integrals. Here the cost is fixed: n + 2 edge integrals and no slot.
 *
 * The identity: the edge sum of Lambert's formula (polygon.h,
 * polygon_form_factor; Arvo 1995 Eq. 4) is a sum over the boundary of the
 * region, so it can be taken over the boundary of C = P n H1 n H2 piece by
 * piece. That boundary is
 *   (a) each edge of P restricted to H1 n H2: a sub-segment [s, e] of the
 *       edge (one parameter interval per edge, intersected over the planes);
 *   (b) for each plane k, the chord P n dH_k, from the point where P's
 *       boundary leaves H_k to the point where it re-enters (the boundary of
 *       P n H_k runs along the plane between them), restricted to the other
 *       half-space.
 * The arcs are taken on the sphere of directions; a straight segment through
 * no origin projects onto a great arc, so each piece is one edge term. Both
 * planes contain the origin, so clipping a segment and projecting commute.
 * The edge term polygon_edge_integral is scale-invariant (atan2 of |a x b|
 * and a . b), so no point is normalised.
 *
 * The points are given in the space of H2 (o.z >= 0); H1 is given by its
 * signed value d1 at each vertex (any positive multiple of a linear function:
 * LTC passes the vertex's z before the transform, which is linear, so the
 * value interpolates along an edge exactly as the plane's does).
 * Lane-safe (compat.h): no branch on per-query values. */
#ifndef GLINT_POLYGON_WEDGE_H
#define GLINT_POLYGON_WEDGE_H

#include "kernels/area/atan_poly.h"
#include "kernels/area/polygon.h"
#include "kernels/area/unroll.h"
#include "kernels/compat.h"

/* polygon_edge_integral(a, b) (polygon.h) with theta by atan2_nonneg
 * (atan_poly.h): the same formula, scale-invariant in a and b, a cheaper
 * arctangent in fp32. */
GLINT_FN real wedge_edge_term(real3 a, real3 b) {
  real3 c = r3_cross(a, b);
  real s = r3_length(c);
  real theta = atan2_nonneg(s, r3_dot(a, b));
  real ratio = s > GLINT_R(1e-30) ? theta / s : GLINT_R(1.0);
  return c.z * ratio;
}

/* Where a boundary leaves (x) and re-enters (r) one half-space: a convex
 * polygon's boundary crosses a plane at most twice. */
typedef struct {
  real3 x, r;
  glint_mask has_x, has_r;
  /* A crossing at the origin: the boundary passes through the shading
   * point, so the polygon's plane contains it (see polygon_wedge_form_factor). */
  glint_mask at_origin;
} WedgeCrossings;

/* One piece s -> e of a closed boundary (in the lanes `valid`) against the
 * plane z = 0: adds the edge term of its part in z >= 0 (points on the plane
 * are inside, as polygon_clip_to_horizon_lanes keeps them) to *sum, in
 * polygon.h's orientation (polygon_form_factor_lanes adds
 * polygon_edge_integral(b, a) for an edge a -> b), and records the crossing.
 * The kept part's end on the plane and the recorded crossing are the same
 * value q, so the pieces of the clipped boundary still meet exactly. */
GLINT_FN void wedge_clip_piece(real3 s, real3 e, glint_mask valid, GLINT_PRIVATE real *sum,
                               GLINT_PRIVATE WedgeCrossings *c) {
  glint_mask s_in = s.z >= GLINT_R(0.0), e_in = e.z >= GLINT_R(0.0);
  /* Used only in the lanes that cross (s.z != e.z there). */
  real t = s.z / (s.z - e.z);
  real3 q = r3_add(s, r3_scale(r3_sub(e, s), t));
  q.z = GLINT_R(0.0); /* exactly on the plane despite rounding */
  real3 a = r3_select(q, s, s_in), b = r3_select(q, e, e_in);
  *sum += glint_select(GLINT_R(0.0), wedge_edge_term(b, a), valid & (s_in | e_in));
  glint_mask leaves = valid & s_in & (!e_in), enters = valid & (!s_in) & e_in;
  c->x = r3_select(c->x, q, leaves);
  c->r = r3_select(c->r, q, enters);
  c->has_x = c->has_x | leaves;
  c->has_r = c->has_r | enters;
  c->at_origin = c->at_origin | ((leaves | enters) & (r3_dot(q, q) == GLINT_R(0.0)));
}

/* The form factor from the edge sum, 0 in the lanes whose boundary passes
 * through the shading point or whose terms overflowed (see below). */
GLINT_FN real wedge_finish(real sum, glint_mask at_origin) {
  /* Overflow: the terms multiply coordinates (a x b), so points beyond
   * ~1e19 (fp32) from the shading point give Inf / NaN; such a lane gets 0,
   * as the sequential form factor's overflowing normalisation gave. The
   * smooth model's LTC pass never gets there: area_ltc_shade_light rescales
   * such polygons by a power of two first (polygon_scale.h). */
  real ff = sum * GLINT_R(0.5) * GLINT_INV_PI;
  return glint_select(GLINT_R(0.0), ff, (fabs(ff) <= GLINT_R(1e30)) & (!at_origin));
}

/* Signed form factor (polygon_form_factor_lanes' value) of the polygon
 * o[0 .. n) (n uniform, convex, counter-clockwise seen from the origin)
 * clipped to H1 = {d1 >= 0} and then to H2 = {o.z >= 0}; d1[i] is H1's value
 * at o[i]. The boundary of P n H1 is walked piece by piece (each edge's part
 * in H1, then the chord along H1's plane) and each piece clipped to H2 as it
 * comes (wedge_clip_piece), then H2's chord closes the loop. Equals clipping
 * with polygon_clip_to_horizon_lanes twice and polygon_form_factor_lanes, up
 * to rounding (tests/area/polygon_wedge_test.cpp). */
GLINT_FN real polygon_wedge_form_factor(const GLINT_PRIVATE real3 *o, const GLINT_PRIVATE real *d1,
                                        int n) {
  real sum = GLINT_R(0.0);
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  glint_mask none = zero.z != zero.z;
  WedgeCrossings c1 = {zero, zero, none, none, none}, c2 = {zero, zero, none, none, none};
  /* Uniform shortcuts (branches on glint_any, compat.h), bit-identical to
   * the general pass: when no vertex of any lane is outside H1, each edge's
   * part in H1 is the whole edge (the general pass's selects pick a and b
   * exactly) and H1's chord adds +0, so the edges go straight to the H2
   * clip; when no vertex is outside H2 either, wedge_clip_piece keeps every
   * edge whole and H2's chord adds +0 too, which leaves Lambert's plain edge
   * sum, n terms instead of n + 2 with their clip arithmetic. A light wholly
   * above the shading horizon and inside the cosine's support (a softbox
   * over the surface, seen away from grazing) takes the second; adding +0
   * to the sum (never -0: it starts at +0) changes no bit. */
  glint_mask out1 = none, out2 = none;
  GLINT_UNROLL for (int i = 0; i < n; ++i) {
    out1 = out1 | (d1[i] < GLINT_R(0.0));
    out2 = out2 | (o[i].z < GLINT_R(0.0));
  }
  if (!glint_any(out1 | out2)) {
    GLINT_UNROLL for (int i = 0; i < n; ++i) sum += wedge_edge_term(o[i + 1 < n ? i + 1 : 0], o[i]);
    return wedge_finish(sum, none);
  }
  if (!glint_any(out1)) {
    GLINT_UNROLL for (int i = 0; i < n; ++i)
        wedge_clip_piece(o[i], o[i + 1 < n ? i + 1 : 0], !out1, &sum, &c2);
  } else {
    GLINT_UNROLL for (int i = 0; i < n; ++i) {
      int j = i + 1 < n ? i + 1 : 0;
      real3 a = o[i], b = o[j];
      glint_mask a_in = d1[i] >= GLINT_R(0.0), b_in = d1[j] >= GLINT_R(0.0);
      /* The edge's part in H1, s -> e; the crossing p is used only where the
       * edge crosses (d1[i] != d1[j] there). */
      real t = d1[i] / (d1[i] - d1[j]);
      real3 p = r3_add(a, r3_scale(r3_sub(b, a), t));
      real3 s = r3_select(p, a, a_in), e = r3_select(p, b, b_in);
      wedge_clip_piece(s, e, a_in | b_in, &sum, &c2);
      glint_mask leaves = a_in & (!b_in), enters = (!a_in) & b_in;
      c1.x = r3_select(c1.x, p, leaves);
      c1.r = r3_select(c1.r, p, enters);
      c1.has_x = c1.has_x | leaves;
      c1.has_r = c1.has_r | enters;
      c1.at_origin = c1.at_origin | ((leaves | enters) & (r3_dot(p, p) == GLINT_R(0.0)));
    }
    /* H1's chord, from where the boundary leaves H1 to where it re-enters. */
    wedge_clip_piece(c1.x, c1.r, c1.has_x & c1.has_r, &sum, &c2);
  }
  /* H2's chord closes the loop; it lies in H1, being a chord of P n H1. */
  glint_mask closed2 = c2.has_x & c2.has_r;
  sum += glint_select(GLINT_R(0.0), wedge_edge_term(c2.r, c2.x), closed2);
  /* An edge through the shading point, cut there by a plane: a piece ends at
   * the origin, which has no direction, and its terms no longer close the
   * loop. The polygon's plane then contains the shading point: it is seen
   * edge-on and the exact integral is 0 (polygon_form_factor_lanes skips
   * such a vertex to the same end). */
  return wedge_finish(sum, c1.at_origin | c2.at_origin);
}

#endif /* GLINT_POLYGON_WEDGE_H */
