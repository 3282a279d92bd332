/* Spherical-polygon geometry for polygonal area lights: clipping to the
 * upper hemisphere and the exact integral of the clamped cosine over the
 * polygon's solid angle (Lambert 1760; the "irradiance from a polygon" edge
 * sum as written in Arvo 1995, "Applications of Irradiance Tensors to the
 * Simulation of Non-Lambertian Phenomena", Eq. 4, and used by Heitz et al.
 * 2016, LTC, Eq. 11).
 *
 * Vertices are positions relative to the shading point (any length). A
 * polygon faces the receiver when its vertices are seen counter-clockwise
 * from the receiver, i.e. its right-hand normal points at the receiver. */
#ifndef GLINT_POLYGON_H
#define GLINT_POLYGON_H

#include "kernels/compat.h"
#include "kernels/layout.h"

/* Clipping branches on per-vertex values, so polygon kernels run one query
 * per work-item (see compat.h on GLINT_LANES). */
#if defined(__OPENCL_VERSION__) && GLINT_LANES != 1
#error "kernels/area/polygon.h needs GLINT_LANES == 1"
#endif

/* Clipping a convex polygon against one plane adds at most one vertex. */
#define GLINT_POLYGON_MAX_CLIPPED (GLINT_POLYGON_MAX_VERTICES + 1)

/* Sutherland-Hodgman clip of a polygon (n vertices) to the half-space z >= 0.
 * Returns the number of output vertices (0 when wholly below). Vertices exactly
 * on the horizon are kept: they bound the integral but add nothing to it. */
GLINT_FN int polygon_clip_to_horizon(const GLINT_PRIVATE real3 *in, int n,
                                     GLINT_PRIVATE real3 *out) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    real3 a = in[i];
    real3 b = in[(i + 1) % n];
    int a_in = a.z >= GLINT_R(0.0);
    int b_in = b.z >= GLINT_R(0.0);
    if (a_in) out[m++] = a;
    if (a_in != b_in) {
      real t = a.z / (a.z - b.z);
      real3 p = r3_add(a, r3_scale(r3_sub(b, a), t));
      p.z = GLINT_R(0.0); /* exactly on the horizon despite rounding */
      out[m++] = p;
    }
  }
  return m;
}

/* One edge's contribution to the cosine integral, for unit vectors a, b:
 *   theta(a, b) * normalize(a x b) . z, theta = angle between a and b,
 * computed as atan2(|a x b|, a . b) * (a x b).z / |a x b|, which stays
 * accurate for short edges (theta / sin(theta) -> 1) where acos loses digits. */
GLINT_FN real polygon_edge_integral(real3 a, real3 b) {
  real3 c = r3_cross(a, b);
  real s = r3_length(c);
  real theta = atan2(s, r3_dot(a, b));
  real ratio = s > GLINT_R(1e-30) ? theta / s : GLINT_R(1.0);
  return c.z * ratio;
}

/* Signed integral of cos(theta) over the solid angle of the polygon (in the
 * local frame, +z = normal), divided by pi: the form factor. Positive when the
 * polygon faces the receiver, negative when it is seen from behind. The
 * polygon must already be clipped to z >= 0.
 * A vertex at the shading point (a polygon touching the receiver, or the
 * horizon clip of an edge through it) has no direction: normalising it gave
 * 0/0 = NaN (issue 8). It is skipped, i.e. its two edges are replaced by the
 * great arc between its neighbours. Such a polygon's plane contains the
 * shading point, so the exact integral is 0 (it is seen edge-on), and the
 * remaining vertices all lie on one great circle, where the arcs cancel. */
GLINT_FN real polygon_form_factor(const GLINT_PRIVATE real3 *v, int n) {
  real sum = GLINT_R(0.0);
  real3 first = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0)), a = first;
  int m = 0; /* vertices with a direction */
  for (int i = 0; i < n; ++i) {
    real l = r3_length(v[i]);
    if (!(l > GLINT_R(0.0))) continue;
    real3 b = r3_div(v[i], l);
    /* b x a rather than a x b: counter-clockwise seen from the receiver
     * (inside the sphere) is clockwise seen from outside. */
    if (m > 0)
      sum += polygon_edge_integral(b, a);
    else
      first = b;
    a = b;
    ++m;
  }
  if (m < 3) return GLINT_R(0.0);
  sum += polygon_edge_integral(first, a);
  return sum * GLINT_R(0.5) * GLINT_INV_PI;
}

#endif /* GLINT_POLYGON_H */
