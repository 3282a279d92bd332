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

/* Lane-safe (compat.h): the clip and the form factor below have no branch on
 * per-query values, so they run GLINT_LANES queries per work-item. A polygon's
 * vertex count before clipping is the light's (uniform); after a clip each
 * lane has its own count (a glint_count), and the loops run to a uniform
 * bound with per-lane masks. On the host the same code sees scalars. */

/* Per-lane vertex counts: int on the host and in one-query kernels, the
 * integer vector of glint_mask's width in lane kernels. A true mask lane is
 * -1 on OpenCL vectors and 1 on scalars; glint_mask_count gives 1 for both. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
typedef glint_mask glint_count;
#define glint_mask_count(c) (-(c))
#define glint_count_min(a, b) min(a, (glint_count)(b))
#else
typedef int glint_count;
#define glint_mask_count(c) (c)
#define glint_count_min(a, b) ((a) < (b) ? (a) : (b))
#endif

/* Clipping a convex polygon against one plane adds at most one vertex. */
#define GLINT_POLYGON_MAX_CLIPPED (GLINT_POLYGON_MAX_VERTICES + 1)

/* Writes p to slot m of out[0 .. n_max] in the lanes where `ok` holds: the
 * per-lane append of a branch-free clip (a select per slot; slots are few). */
GLINT_FN void polygon_append(GLINT_PRIVATE real3 *out, int k_max, glint_count m, real3 p,
                             glint_mask ok) {
  for (int k = 0; k <= k_max; ++k) out[k] = r3_select(out[k], p, ok & (m == k));
}

/* Sutherland-Hodgman clip of a polygon to the half-space z >= 0, branch-free:
 * in[0 .. n_max) holds each lane's n <= n_max vertices (n_max uniform), out
 * gets n_max + 1 slots (a convex polygon gains at most one vertex per plane).
 * Returns each lane's output count (0 when wholly below). Vertices exactly on
 * the horizon are kept: they bound the integral but add nothing to it. Per
 * lane the arithmetic and the output are those of the sequential clip. */
GLINT_FN glint_count polygon_clip_to_horizon_lanes(const GLINT_PRIVATE real3 *in, glint_count n,
                                                   int n_max, GLINT_PRIVATE real3 *out) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  for (int k = 0; k <= n_max; ++k) out[k] = zero;
  glint_count m = 0;
  for (int i = 0; i < n_max; ++i) {
    glint_mask live = i < n;
    real3 a = in[i];
    /* in[(i + 1) % n] per lane */
    real3 b = i + 1 < n_max ? r3_select(in[0], in[i + 1], i + 1 < n) : in[0];
    glint_mask a_in = a.z >= GLINT_R(0.0);
    glint_mask b_in = b.z >= GLINT_R(0.0);
    glint_mask keep = live & a_in;
    /* m <= 2 i here and <= 2 i + 1 at the second append: fewer slots to select. */
    polygon_append(out, 2 * i < n_max ? 2 * i : n_max, m, a, keep);
    m += glint_mask_count(keep);
    glint_mask cross = live & (a_in != b_in);
    /* Computed in every lane; only crossing lanes (a.z != b.z) keep it. */
    real t = a.z / (a.z - b.z);
    real3 p = r3_add(a, r3_scale(r3_sub(b, a), t));
    p.z = GLINT_R(0.0); /* exactly on the horizon despite rounding */
    polygon_append(out, 2 * i + 1 < n_max ? 2 * i + 1 : n_max, m, p, cross);
    m += glint_mask_count(cross);
  }
  /* A polygon that is convex only within the validation's planarity tolerance
   * can cross the horizon more than twice near it: appends past the last slot
   * were dropped, and the count says so. */
  return glint_count_min(m, n_max + 1);
}

#if !defined(__OPENCL_VERSION__) || GLINT_LANES == 1
/* The one-query form: n vertices in, at most n + 1 out. */
GLINT_FN int polygon_clip_to_horizon(const GLINT_PRIVATE real3 *in, int n,
                                     GLINT_PRIVATE real3 *out) {
  return polygon_clip_to_horizon_lanes(in, n, n, out);
}
#endif

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
GLINT_FN real polygon_form_factor_lanes(const GLINT_PRIVATE real3 *v, glint_count n, int n_max) {
  real sum = GLINT_R(0.0);
  real3 first = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0)), a = first;
  glint_count m = 0; /* vertices with a direction */
  for (int i = 0; i < n_max; ++i) {
    real l = r3_length(v[i]);
    glint_mask ok = (i < n) & (l > GLINT_R(0.0));
    real3 b = r3_div(v[i], l);
    /* b x a rather than a x b: counter-clockwise seen from the receiver
     * (inside the sphere) is clockwise seen from outside. */
    real e = polygon_edge_integral(b, a);
    sum = glint_select(sum, sum + e, ok & (m > 0));
    first = r3_select(first, b, ok & (m == 0));
    a = r3_select(a, b, ok);
    m += glint_mask_count(ok);
  }
  glint_mask closed = m >= 3;
  sum = sum + polygon_edge_integral(first, a);
  return glint_select(GLINT_R(0.0), sum * GLINT_R(0.5) * GLINT_INV_PI, closed);
}

#if !defined(__OPENCL_VERSION__) || GLINT_LANES == 1
GLINT_FN real polygon_form_factor(const GLINT_PRIVATE real3 *v, int n) {
  return polygon_form_factor_lanes(v, n, n);
}
#endif

#endif /* GLINT_POLYGON_H */
