/* Spherical-triangle geometry shared by the polygon-light integrators: the
 * solid angle of a triangle seen from the origin, and Arvo's area-preserving
 * map of the unit square onto it (Arvo 1995, "Stratified Sampling of Spherical
 * Triangles", Sec. 2-3, Fig. 2), which the REFERENCE quadrature
 * (area_lights.h) integrates over and MONTE_CARLO (area_monte_carlo.h) samples
 * with. Written for thin and small triangles: edge vectors and half squared
 * chord lengths carry the small differences without cancellation. */
#ifndef GLINT_SPHERICAL_TRIANGLE_H
#define GLINT_SPHERICAL_TRIANGLE_H

#include "kernels/compat.h"

/* a . (b x c) = a . ((b - a) x (c - a)): the edge vectors carry the small
 * differences of a thin triangle without cancellation. */
GLINT_FN real spherical_triple(real3 a, real3 b, real3 c) {
  return r3_dot(a, r3_cross(r3_sub(b, a), r3_sub(c, a)));
}

/* Solid angle of the triangle (a, b, c) seen from the origin (any lengths), by
 * Van Oosterom & Strackee 1983:
 *   tan(Omega / 2) = |a.(b x c)| / (|a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|),
 * accurate for small triangles (no angle-excess cancellation). */
GLINT_FN real spherical_triangle_solid_angle(real3 a, real3 b, real3 c) {
  real la = r3_length(a), lb = r3_length(b), lc = r3_length(c);
  real den = la * lb * lc + r3_dot(a, b) * lc + r3_dot(a, c) * lb + r3_dot(b, c) * la;
  real triple = fabs(spherical_triple(a, b, c));
  /* The origin in (or within rounding of) the triangle's plane: seen edge-on,
   * 0 (as REFERENCE and LTC give). Without this, atan2(+0, den < 0) = pi
   * when the origin lies inside the triangle, i.e. 2 pi sr. */
  real edge_on = GLINT_R(1e-6) * la * r3_length(r3_sub(b, a)) * r3_length(r3_sub(c, a));
  int edge_on_inside = (triple <= edge_on) & (den <= GLINT_R(0.0));
  return edge_on_inside ? GLINT_R(0.0) : GLINT_R(2.0) * atan2(triple, den);
}

/* Whether the unit vector p lies strictly inside the spherical triangle (a, b, c) (unit
 * vertices, either orientation, smaller than a hemisphere): on the inner side of all three
 * great circles through its edges. */
GLINT_FN int spherical_triangle_contains(real3 a, real3 b, real3 c, real3 p) {
  real orient = r3_dot(a, r3_cross(b, c));
  real s1 = r3_dot(p, r3_cross(a, b)) * orient;
  real s2 = r3_dot(p, r3_cross(b, c)) * orient;
  real s3 = r3_dot(p, r3_cross(c, a)) * orient;
  return (s1 > GLINT_R(0.0)) & (s2 > GLINT_R(0.0)) & (s3 > GLINT_R(0.0));
}

/* The point of the spherical triangle's boundary nearest to the unit vector p (p outside it):
 * on edge (v[edge], v[edge + 1]) of (a, b, c), or vertex v[edge] when at_vertex; its arc
 * distance from p. */
typedef struct {
  real3 point;
  real distance;
  int edge;
  int at_vertex;
} SphericalNearest;

GLINT_FN SphericalNearest spherical_triangle_nearest(real3 a, real3 b, real3 c, real3 p) {
  real3 v[3] = {a, b, c};
  SphericalNearest best;
  best.point = a;
  best.distance = GLINT_R(4.0);
  best.edge = 0;
  best.at_vertex = 1;
  for (int e = 0; e < 3; ++e) {
    real3 x = v[e], y = v[(e + 1) % 3];
    real dv = acos(clamp(r3_dot(p, x), GLINT_R(-1.0), GLINT_R(1.0)));
    if (dv < best.distance) {
      best.point = x;
      best.distance = dv;
      best.edge = e;
      best.at_vertex = 1;
    }
    real3 n = r3_cross(x, y);
    real ln = r3_length(n);
    if (!(ln > GLINT_R(1e-12))) continue;
    n = r3_div(n, ln);
    real3 t = r3_sub(p, r3_scale(n, r3_dot(p, n))); /* p projected on the edge's great circle */
    real lt = r3_length(t);
    if (!(lt > GLINT_R(1e-12))) continue;
    t = r3_div(t, lt);
    /* inside the arc from x to y: x -> t and t -> y both turn the way x -> y does */
    if (r3_dot(r3_cross(x, t), n) > GLINT_R(0.0) && r3_dot(r3_cross(t, y), n) > GLINT_R(0.0)) {
      real de = asin(clamp(fabs(r3_dot(p, n)), GLINT_R(0.0), GLINT_R(1.0)));
      if (r3_dot(p, t) > GLINT_R(0.0) && de < best.distance) {
        best.point = t;
        best.distance = de;
        best.edge = e;
        best.at_vertex = 0;
      }
    }
  }
  return best;
}

/* Unit vector along the part of u orthogonal to the unit vector a, where
 * d = u - a is given (for u close to a, d carries the small difference without
 * the cancellation of u - (u.a) a); `fallback` when that part vanishes. */
GLINT_FN real3 spherical_orthogonal_dir(real3 a, real3 d, real3 fallback) {
  real3 t = r3_sub(d, r3_scale(a, r3_dot(d, a)));
  real l = r3_length(t);
  return l > GLINT_R(1e-30) ? r3_div(t, l) : fallback;
}

/* Angle at unit vertex a of the spherical triangle (a, b, c): between the
 * tangents towards b and c (atan2 form, accurate for thin triangles). */
GLINT_FN real spherical_vertex_angle(real3 a, real3 b, real3 c) {
  real3 ba = r3_sub(b, a), ca = r3_sub(c, a);
  real3 tb = r3_sub(ba, r3_scale(a, r3_dot(a, ba)));
  real3 tc = r3_sub(ca, r3_scale(a, r3_dot(a, ca)));
  return atan2(r3_length(r3_cross(tb, tc)), r3_dot(tb, tc));
}

/* The arc of Arvo's map for a given u1: from b to the point c' on arc ac that
 * cuts off the sub-triangle (a, b, c') of solid angle u1 * Omega. A quadrature
 * computes it once per u1 node and reuses it for every u2 node. */
typedef struct {
  real3 b;           /* start of the arc */
  real3 axis;        /* unit tangent at b towards c' */
  real one_minus_cb; /* 1 - c'.b, from |c' - b|^2 / 2 (accurate when c' is near b) */
} ArvoArc;

/* a, b, c unit vectors; omega the triangle's solid angle, alpha its angle at
 * a (spherical_vertex_angle); u1 in [0, 1]. Arvo 1995 Fig. 2, steps s, t, u,
 * v, q (q = cos of the arc a c'). */
GLINT_FN ArvoArc arvo_arc(real3 a, real3 b, real3 c, real omega, real alpha, real u1) {
  real sin_alpha = sin(alpha), cos_alpha = cos(alpha);
  real cos_c = r3_dot(a, b);
  real s = sin(u1 * omega - alpha), t = cos(u1 * omega - alpha);
  real u = t - cos_alpha;
  real vv = s + sin_alpha * cos_c;
  real den = (vv * s + u * t) * sin_alpha;
  real q = den != GLINT_R(0.0) ? ((vv * t - u * s) * cos_alpha - vv) / den : GLINT_R(1.0);
  q = clamp(q, GLINT_R(-1.0), GLINT_R(1.0));
  real3 c_perp = spherical_orthogonal_dir(a, r3_sub(c, a), b);
  real3 cp =
      r3_add(r3_scale(a, q), r3_scale(c_perp, sqrt(fmax(GLINT_R(1.0) - q * q, GLINT_R(0.0)))));
  real3 d = r3_sub(cp, b);
  ArvoArc arc;
  arc.b = b;
  arc.one_minus_cb = fmin(GLINT_R(0.5) * r3_dot(d, d), GLINT_R(2.0));
  arc.axis = spherical_orthogonal_dir(b, d, cp);
  return arc;
}

/* The point of the arc with 1 - z = u2 (1 - c'.b), z the cosine of the arc
 * from b: uniform in solid angle for u2 uniform (Arvo 1995 Sec. 3). */
GLINT_FN real3 arvo_point(ArvoArc arc, real u2) {
  real omz = u2 * arc.one_minus_cb; /* 1 - z */
  real sin_arc = sqrt(fmax(omz * (GLINT_R(2.0) - omz), GLINT_R(0.0)));
  return r3_add(r3_scale(arc.b, GLINT_R(1.0) - omz), r3_scale(arc.axis, sin_arc));
}

#endif /* GLINT_SPHERICAL_TRIANGLE_H */
