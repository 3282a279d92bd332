/* Polygonal area lights by LTC (Heitz, Dupuy, Hill, Neubelt 2016, "Real-Time
 * Polygonal-Light Shading with Linearly Transformed Cosines", here HDHN16)
 * with our own tables (tools/ltc/, data/ltc/): the default area method, and
 * the polygon records' loading and facing test that every method shares.
 *
 * Lane-safe (compat.h): no branch on per-query values, so the smooth model's
 * LTC pass (models/smooth/smooth_area_lanes.cl) runs GLINT_LANES queries per
 * work-item; the two clips and the edge sum are one pass over the edges
 * (polygon_wedge.h), with no per-lane vertex slots. The host and the
 * one-query kernels run the same code on scalars. */
#ifndef GLINT_AREA_LTC_H
#define GLINT_AREA_LTC_H

#include "kernels/area/ltc_lookup.h"
#include "kernels/area/polygon.h"
#include "kernels/area/polygon_scale.h"
#include "kernels/area/polygon_wedge.h"
#include "kernels/area/unroll.h"
#include "kernels/compat.h"
#include "kernels/frame.h"
#include "kernels/layout.h"
#include "kernels/smooth_brdf.h"

/* Two clips (shading horizon, then the cosine's support after M^-1) add at
 * most one vertex each to a convex polygon. */
#define GLINT_AREA_MAX_VERTICES (GLINT_POLYGON_MAX_VERTICES + 2)

/* A record's first n vertices relative to the shading point p in the local
 * frame (world = local when the queries carry no frame), as they come:
 * area_polygon_load_n is the loader the methods use. */
GLINT_FN void area_polygon_load_raw(const GLINT_GLOBAL float *rec, int n, int has_frame,
                                    ShadingFrame frame, real3 p, GLINT_PRIVATE real3 *v) {
  /* Overwritten by the loop (n >= 3, validated); set first so that GCC, which
   * cannot see n >= 1 where n is not a constant, does not warn that the rare
   * path (area_polygon_load_far) reads unset vertices. */
  v[0] = p;
  GLINT_UNROLL for (int i = 0; i < n; ++i) {
    const GLINT_GLOBAL float *q = rec + GLINT_POLYGON_VERTEX_OFFSET + 3 * i;
    real3 w = r3_sub(make_real3((real)q[0], (real)q[1], (real)q[2]), p);
    v[i] = has_frame ? frame_to_local(frame, w) : w;
  }
}

/* The rare part of area_polygon_load_n, for the lanes `odd` whose vertices
 * are out of polygon_scale_odd's range. In fp32 a vertex can overflow before
 * the rescale: a vertex minus a shading point of opposite sign beyond ~1.7e38
 * (q - p > FLT_MAX), or a frame's rotation of a vector near FLT_MAX (a dot
 * product's partial sums reach sqrt(3) |w|). Those lanes are reloaded from
 * the coordinates times 2^-32 (exact: the inputs are floats, and any that
 * falls into the subnormals by it is < 2^-94, below the rounding of the
 * coordinates > 2^96 of the same vertex), so that they too keep their
 * directions, then every odd lane is rescaled. Handled rather than refused:
 * fp64 gets these lights right, and fp32 now agrees with it. */
GLINT_FN void area_polygon_load_far(const GLINT_GLOBAL float *rec, int n, int has_frame,
                                    ShadingFrame frame, real3 p, glint_mask odd,
                                    GLINT_PRIVATE real3 *v) {
  real m = polygon_scale_max(v, n);
  glint_mask overflowed = odd & !(m - m == GLINT_R(0.0));
  if (glint_any(overflowed)) {
    real3 ps = r3_scale(p, GLINT_POLYGON_SCALE_2M32);
    GLINT_UNROLL for (int i = 0; i < n; ++i) {
      const GLINT_GLOBAL float *q = rec + GLINT_POLYGON_VERTEX_OFFSET + 3 * i;
      real3 w = r3_sub(
          r3_scale(make_real3((real)q[0], (real)q[1], (real)q[2]), GLINT_POLYGON_SCALE_2M32), ps);
      v[i] = r3_select(v[i], has_frame ? frame_to_local(frame, w) : w, overflowed);
    }
  }
  polygon_rescale_lanes(v, n, odd);
}

/* Vertex count of a record, and its vertices relative to the shading point p
 * in the local frame (world = local when the queries carry no frame): the
 * polygon as every area method and model receives it. Lights far from (or
 * very near to) the shading point come scaled by a power of two, which keeps
 * their directions exactly and every method's result (polygon_scale.h). The
 * count is the light's, the same in every lane. */
GLINT_FN void area_polygon_load_n(const GLINT_GLOBAL float *rec, int n, int has_frame,
                                  ShadingFrame frame, real3 p, GLINT_PRIVATE real3 *v) {
  area_polygon_load_raw(rec, n, has_frame, frame, p, v);
  /* GLINT_POLYGON_SCALE_OFF: only bench/bench_polygon_scale.cpp sets it, to time
   * the methods without the check (no kernel build option does). */
#ifndef GLINT_POLYGON_SCALE_OFF
  glint_mask odd = polygon_scale_odd(v, n);
  if (glint_any(odd)) area_polygon_load_far(rec, n, has_frame, frame, p, odd, v);
#endif
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
  GLINT_UNROLL for (int i = 0; i < n; ++i) nn = r3_add(nn, r3_cross(v[i], v[(i + 1) % n]));
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
 *     polygon_form_factor): = int_P D_ltc dw (HDHN16 Eq. 3-5). Steps 1, 3
 *     and 4 are one pass, polygon_wedge_form_factor (fp32: a polynomial
 *     arctangent within 1.7e-7 of atan2, atan_poly.h);
 *  5. scale by the Fresnel-weighted albedo: Schlick int f cos F = f0 * mag +
 *     (1 - f0) * moment (exact for the albedo). Conductor and dielectric:
 *     APPROXIMATION, the exact Fresnel is replaced by Schlick's through its
 *     normal-incidence value F(1) (Schlick 1994 Eq. 15); the tables hold no
 *     moment for exact Fresnel.
 * Anisotropic alpha: APPROXIMATION, the tables are isotropic and we look up
 * alpha = sqrt(alpha_x alpha_y) (the lobe of equal solid-angle footprint).
 * Branch-free: every lane runs the n + 2 pieces of the clipped boundary (n
 * the light's vertex count); lanes seeing the light from below the horizon
 * (or a view from below, wo.z <= 0: no transmission, as smooth_reflect_cos)
 * get 0 and a zero entry e, as the sequential early returns gave. */

/* The view-aligned frame of step 2: T1 (tx, ty, 0) = the projection of wo on
 * the tangent plane, normalised; at normal view the lobe is isotropic about n
 * (t = 0 entries are), so any tangent will do. */
GLINT_FN void area_ltc_view_tangent(real3 wo, GLINT_PRIVATE real *tx, GLINT_PRIVATE real *ty) {
  real sxy = sqrt(wo.x * wo.x + wo.y * wo.y);
  glint_mask tilted = sxy > GLINT_R(1e-7);
  *tx = glint_select(GLINT_R(1.0), wo.x / sxy, tilted);
  *ty = glint_select(GLINT_R(0.0), wo.y / sxy, tilted);
}

/* Step 2-3's linear map of a local vector: rotate into the view-aligned
 * frame, then M^-1 (entry e). */
GLINT_FN real3 area_ltc_transform(const GLINT_PRIVATE real *e, real tx, real ty, real3 c) {
  real x = c.x * tx + c.y * ty;  /* . T1 */
  real y = -c.x * ty + c.y * tx; /* . T2 = n x T1 */
  return make_real3(e[0] * x + e[1] * c.z, y, e[2] * x + e[3] * c.z);
}

/* Steps 1-4 of area_ltc_form_factor for a table entry e already looked up at
 * (alpha, wo.z), and the view tangent (tx, ty) of area_ltc_view_tangent: the
 * light loop of area_ltc_shade looks them up once per query, not per light.
 * Zeroes e in the lanes that get 0 (view from below, light below the
 * horizon), as area_ltc_form_factor documents. The two clips and the edge
 * sum are one pass, polygon_wedge_form_factor (polygon_wedge.h): the linear
 * map commutes with clipping, so the horizon clip is done after it, with the
 * vertices' z before the map as the plane's values. */
GLINT_FN real area_ltc_form_factor_entry(real3 wo, real tx, real ty, const GLINT_PRIVATE real3 *v,
                                         int n, GLINT_PRIVATE real *e) {
  real3 o[GLINT_POLYGON_MAX_VERTICES];
  real d1[GLINT_POLYGON_MAX_VERTICES];
  /* Overwritten by the loop (n >= 3, validated); set first so that GCC, which
   * cannot see n >= 1 where it does not inline polygon_wedge_form_factor,
   * does not warn that the arrays may be passed unset. */
  o[0] = v[0];
  d1[0] = v[0].z;
  /* The horizon clip's vertex count (>= 3: something is above the horizon)
   * and whether a vertex is at the shading point: then the polygon's plane
   * contains it, the light is seen edge-on and the exact integral is 0
   * (polygon_form_factor_lanes skips such a vertex to the same end). */
  glint_count nc = 0;
  glint_mask at_p = v[0].z != v[0].z;
  GLINT_UNROLL for (int i = 0; i < n; ++i) {
    o[i] = area_ltc_transform(e, tx, ty, v[i]);
    d1[i] = v[i].z;
    glint_mask in = v[i].z >= GLINT_R(0.0);
    glint_mask next_in = v[i + 1 < n ? i + 1 : 0].z >= GLINT_R(0.0);
    nc += glint_mask_count(in) + glint_mask_count(in != next_in);
    at_p = at_p | (r3_dot(v[i], v[i]) == GLINT_R(0.0));
  }
  glint_mask live = (wo.z > GLINT_R(0.0)) & (nc >= 3);
  for (int k = 0; k < GLINT_LTC_ENTRY; ++k) e[k] = glint_select(GLINT_R(0.0), e[k], live);
  /* det M^-1 > 0 keeps the orientation, so the sign is the facing side; the
   * caller's weight decides whether a back face counts. */
  return glint_select(GLINT_R(0.0), fabs(polygon_wedge_form_factor(o, d1, n)), live & (!at_p));
}

/* Steps 1-4 of the comment above for one light: the view tangent, the table
 * lookup, then area_ltc_form_factor_entry. */
GLINT_FN real area_ltc_form_factor(const GLINT_GLOBAL float *table, real alpha, real3 wo,
                                   const GLINT_PRIVATE real3 *v, int n, GLINT_PRIVATE real *e) {
  real tx, ty;
  area_ltc_view_tangent(wo, &tx, &ty);
  area_ltc_lookup(table, alpha, wo.z, e);
  return area_ltc_form_factor_entry(wo, tx, ty, v, n, e);
}

GLINT_FN real3 area_ltc_polygon(SmoothMaterial m, const GLINT_GLOBAL float *table, real3 wo,
                                const GLINT_PRIVATE real3 *v, int n) {
  real e[GLINT_LTC_ENTRY];
  real ff = area_ltc_form_factor(table, sqrt(m.alpha_x * m.alpha_y), wo, v, n, e);
  return r3_scale(area_ltc_albedo(m, e), ff);
}

/* What area_ltc_shade's lights share for one query (or block of lanes): the
 * view tangent, the table entry at (alpha, wo.z) and its Fresnel-weighted
 * albedo, looked up once rather than per light. */
typedef struct {
  real tx, ty;
  real e[GLINT_LTC_ENTRY];
  real3 albedo;
} AreaLtcView;

GLINT_FN AreaLtcView area_ltc_view(SmoothMaterial m, const GLINT_GLOBAL float *table, real3 wo) {
  AreaLtcView w;
  area_ltc_view_tangent(wo, &w.tx, &w.ty);
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
  /* Lane callers pass the request's material, the same in every lane (SMOOTH's
   * LTC pass: one material per request), so alpha is taken from lane 0 once, as
   * a scalar (the same bits as the lanes' product and square root). A caller
   * with per-lane roughness (a glint model's filtered alpha) must not use this
   * function: it would shade every lane with lane 0's alpha. */
  area_ltc_lookup_uniform_alpha(table, sqrt(m.alpha_x.s0 * m.alpha_y.s0), wo.z, w.e);
#else
  area_ltc_lookup(table, sqrt(m.alpha_x * m.alpha_y), wo.z, w.e);
#endif
  w.albedo = area_ltc_albedo(m, w.e);
  return w;
}

/* One light's contribution to area_ltc_shade (radiance in, radiance out).
 * Called with a constant n for quads, so that the compiler unrolls the vertex
 * loops and keeps the vertices in registers. The lanes that get 0 from the
 * form factor get albedo * 0 = 0, as area_ltc_polygon's zeroed entry gives. */
GLINT_FN real3 area_ltc_shade_light(real3 radiance, const GLINT_PRIVATE AreaLtcView *w, real3 wo,
                                    int has_frame, ShadingFrame frame, real3 p,
                                    const GLINT_GLOBAL float *rec, int n) {
  real3 v[GLINT_POLYGON_MAX_VERTICES];
  /* Far (or very near) lights come scaled into the range of the products
   * below, exactly (polygon_scale.h). */
  area_polygon_load_n(rec, n, has_frame, frame, p, v);
  glint_mask facing = area_polygon_facing(v, n, rec[1] != 0.0f);
  if (!glint_any(facing)) return radiance;
  real3 L = make_real3((real)rec[2], (real)rec[3], (real)rec[4]);
  real e[GLINT_LTC_ENTRY];
  for (int k = 0; k < GLINT_LTC_ENTRY; ++k) e[k] = w->e[k];
  real3 g = r3_scale(w->albedo, area_ltc_form_factor_entry(wo, w->tx, w->ty, v, n, e));
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
  AreaLtcView w = area_ltc_view(m, table, wo);
  for (uint l = 0; l < n_polygon; ++l) {
    const GLINT_GLOBAL float *rec = polygons + GLINT_POLYGON_FLOATS * l;
    int n = (int)rec[0];
    radiance = n == 4 ? area_ltc_shade_light(radiance, &w, wo, has_frame, frame, p, rec, 4)
                      : area_ltc_shade_light(radiance, &w, wo, has_frame, frame, p, rec, n);
  }
  return radiance;
}

#endif /* GLINT_AREA_LTC_H */
