/* Polygonal area lights by LTC (Heitz, Dupuy, Hill, Neubelt 2016, "Real-Time
 * Polygonal-Light Shading with Linearly Transformed Cosines", here HDHN16)
 * with our own tables (tools/ltc/, data/ltc/): the default area method, and
 * the polygon records' loading and facing test that every method shares.
 *
 * Lane-safe (compat.h): no branch on per-query values, so the smooth model's
 * LTC pass (models/smooth/smooth_area_lanes.cl) runs GLINT_LANES queries per
 * work-item; the clips keep per-lane vertex counts (polygon.h). The host and
 * the one-query kernels run the same code on scalars. */
#ifndef GLINT_AREA_LTC_H
#define GLINT_AREA_LTC_H

#include "kernels/area/ltc_lookup.h"
#include "kernels/area/polygon.h"
#include "kernels/compat.h"
#include "kernels/frame.h"
#include "kernels/layout.h"
#include "kernels/smooth_brdf.h"

/* Two clips (shading horizon, then the cosine's support after M^-1) add at
 * most one vertex each to a convex polygon. */
#define GLINT_AREA_MAX_VERTICES (GLINT_POLYGON_MAX_VERTICES + 2)

/* Vertex count of a record, and its vertices relative to the shading point p
 * in the local frame (world = local when the queries carry no frame). The
 * count is the light's, the same in every lane. */
GLINT_FN void area_polygon_load_n(const GLINT_GLOBAL float *rec, int n, int has_frame,
                                  ShadingFrame frame, real3 p, GLINT_PRIVATE real3 *v) {
  for (int i = 0; i < n; ++i) {
    const GLINT_GLOBAL float *q = rec + GLINT_POLYGON_VERTEX_OFFSET + 3 * i;
    real3 w = r3_sub(make_real3((real)q[0], (real)q[1], (real)q[2]), p);
    v[i] = has_frame ? frame_to_local(frame, w) : w;
  }
}

GLINT_FN int area_polygon_load(const GLINT_GLOBAL float *rec, int has_frame, ShadingFrame frame,
                               real3 p, GLINT_PRIVATE real3 *v) {
  int n = (int)rec[0];
  area_polygon_load_n(rec, n, has_frame, frame, p, v);
  return n;
}

/* Whether the polygon (relative to the shading point) emits towards it, per
 * lane: its right-hand (Newell) normal points at the receiver, i.e. the
 * vertices are counter-clockwise seen from the receiver (the convention of
 * polygon.h). Two-sided polygons always emit; a receiver in the polygon's
 * plane sees zero solid angle either way. */
GLINT_FN glint_mask area_polygon_facing(const GLINT_PRIVATE real3 *v, int n, int two_sided) {
  real3 nn = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  for (int i = 0; i < n; ++i) nn = r3_add(nn, r3_cross(v[i], v[(i + 1) % n]));
  /* nn . v0 = 2 * area * (signed distance of the plane along nn): negative
   * when nn points from the plane towards the origin. */
  glint_mask front = r3_dot(nn, v[0]) < GLINT_R(0.0);
  return two_sided ? (front | !front) : front;
}

/* area_polygon_facing as a weight: 1 (emits) or 0. */
GLINT_FN real area_polygon_weight(const GLINT_PRIVATE real3 *v, int n, int two_sided) {
  return glint_select(GLINT_R(0.0), GLINT_R(1.0), area_polygon_facing(v, n, two_sided));
}

/* int_P f cos_i dwi per unit radiance by LTC (HDHN16 Sec. 3-4), RGB, in two
 * steps: area_ltc_form_factor does 1-4 (the normalised lobe's integral over
 * the polygon, which the binomial glint model also needs for its reflection
 * probability, KK24 Sec. 4) and fills the table entry e; area_ltc_polygon
 * scales it (5).
 *  1. clip the polygon to the shading horizon, so that light from below the
 *     surface never contributes (the LTC leaks below the horizon at grazing
 *     views; tools/ltc/README.md "Fit quality");
 *  2. rotate into the view-aligned frame of the fit: x = projection of wo on
 *     the tangent plane, z = n (tools/ltc/README.md "Grid");
 *  3. transform by M^-1 and clip to o.z >= 0, the clamped cosine's support;
 *  4. integrate the clamped cosine with the edge formula (HDHN16 Eq. 11,
 *     polygon_form_factor): = int_P D_ltc dw (HDHN16 Eq. 3-5);
 *  5. scale by the Fresnel-weighted albedo: Schlick int f cos F = f0 * mag +
 *     (1 - f0) * moment (exact for the albedo). Conductor and dielectric:
 *     APPROXIMATION, the exact Fresnel is replaced by Schlick's through its
 *     normal-incidence value F(1) (Schlick 1994 Eq. 15); the tables hold no
 *     moment for exact Fresnel.
 * Anisotropic alpha: APPROXIMATION, the tables are isotropic and we look up
 * alpha = sqrt(alpha_x alpha_y) (the lobe of equal solid-angle footprint).
 * Branch-free: every lane runs both clips over the uniform bounds n, n + 1,
 * n + 2 (n the light's vertex count); lanes seeing the light from below the
 * horizon (or a view from below, wo.z <= 0: no transmission, as
 * smooth_reflect_cos) get 0 and a zero entry e, as the sequential early
 * returns gave. */
GLINT_FN real area_ltc_form_factor(const GLINT_GLOBAL float *table, real alpha, real3 wo,
                                   const GLINT_PRIVATE real3 *v, int n, GLINT_PRIVATE real *e) {
  real3 clipped[GLINT_AREA_MAX_VERTICES];
  glint_count nc = polygon_clip_to_horizon_lanes(v, n, n, clipped);
  glint_mask live = (wo.z > GLINT_R(0.0)) & (nc >= 3);

  real sxy = sqrt(wo.x * wo.x + wo.y * wo.y);
  /* At normal view the lobe is isotropic about n (t = 0 entries are), so any
   * tangent will do. */
  glint_mask tilted = sxy > GLINT_R(1e-7);
  real tx = glint_select(GLINT_R(1.0), wo.x / sxy, tilted);
  real ty = glint_select(GLINT_R(0.0), wo.y / sxy, tilted);
  area_ltc_lookup(table, alpha, wo.z, e);

  real3 o[GLINT_AREA_MAX_VERTICES];
  o[0] = clipped[0]; /* overwritten below; tells the host compiler o[0] is always set */
  /* All n + 1 slots of the clip, unused ones included: the second clip reads them. */
  for (int i = 0; i < n + 1; ++i) {
    real3 c = clipped[i];
    real x = c.x * tx + c.y * ty;  /* . T1 */
    real y = -c.x * ty + c.y * tx; /* . T2 = n x T1 */
    o[i] = make_real3(e[0] * x + e[1] * c.z, y, e[2] * x + e[3] * c.z);
  }
  real3 oc[GLINT_AREA_MAX_VERTICES];
  glint_count no = polygon_clip_to_horizon_lanes(o, nc, n + 1, oc);
  for (int k = 0; k < GLINT_LTC_ENTRY; ++k) e[k] = glint_select(GLINT_R(0.0), e[k], live);
  /* det M^-1 > 0 keeps the orientation, so the sign is the facing side; the
   * caller's weight decides whether a back face counts. */
  return glint_select(GLINT_R(0.0), fabs(polygon_form_factor_lanes(oc, no, n + 2)), live);
}

GLINT_FN real3 area_ltc_polygon(SmoothMaterial m, const GLINT_GLOBAL float *table, real3 wo,
                                const GLINT_PRIVATE real3 *v, int n) {
  real e[GLINT_LTC_ENTRY];
  real ff = area_ltc_form_factor(table, sqrt(m.alpha_x * m.alpha_y), wo, v, n, e);
  return r3_scale(area_ltc_albedo(m, e), ff);
}

/* One light's contribution to area_ltc_shade (radiance in, radiance out).
 * Called with a constant n for quads, so that the compiler unrolls the vertex
 * loops and keeps the vertices in registers. */
GLINT_FN real3 area_ltc_shade_light(real3 radiance, SmoothMaterial m,
                                    const GLINT_GLOBAL float *table, real3 wo, int has_frame,
                                    ShadingFrame frame, real3 p, const GLINT_GLOBAL float *rec,
                                    int n) {
  real3 v[GLINT_POLYGON_MAX_VERTICES];
  area_polygon_load_n(rec, n, has_frame, frame, p, v);
  glint_mask facing = area_polygon_facing(v, n, rec[1] != 0.0f);
  if (!glint_any(facing)) return radiance;
  real3 L = make_real3((real)rec[2], (real)rec[3], (real)rec[4]);
  real3 g = area_ltc_polygon(m, table, wo, v, n);
  return r3_select(radiance, r3_add(radiance, r3_mul(g, L)), facing);
}

/* Reflected radiance towards wo from every polygon light (RGB) by LTC: the
 * LTC case of area_shade_keyed (area_lights.h), and the whole of the lane
 * kernel. `wo` is local; `p` the shading point in the lights' space. A light
 * that faces no lane of the work-item is skipped (a uniform branch). */
GLINT_FN real3 area_ltc_shade(SmoothMaterial m, const GLINT_GLOBAL float *table, real3 wo,
                              int has_frame, ShadingFrame frame, real3 p,
                              const GLINT_GLOBAL float *polygons, uint n_polygon) {
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  for (uint l = 0; l < n_polygon; ++l) {
    const GLINT_GLOBAL float *rec = polygons + GLINT_POLYGON_FLOATS * l;
    int n = (int)rec[0];
    radiance = n == 4 ? area_ltc_shade_light(radiance, m, table, wo, has_frame, frame, p, rec, 4)
                      : area_ltc_shade_light(radiance, m, table, wo, has_frame, frame, p, rec, n);
  }
  return radiance;
}

#endif /* GLINT_AREA_LTC_H */
