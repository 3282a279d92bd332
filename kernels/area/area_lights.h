/* Polygonal area lights for the smooth model: the LTC approximation (Heitz,
 * Dupuy, Hill, Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly
 * Transformed Cosines", here HDHN16) with our own tables (tools/ltc/,
 * data/ltc/), and a deterministic reference quadrature of
 *   L_o(wo) = L * int_P f(wi, wo) cos(theta_i) dwi
 * over the polygon's solid angle P (clipped to the upper hemisphere).
 *
 * Shared by the OpenCL entry point models/smooth/smooth_area.cl (GLINT_LANES == 1:
 * clipping and the per-query quadrature branch on per-query values) and the
 * host path. The LTC table is a plain float array (64 x 64 entries of 8
 * floats, layout in tools/ltc/README.md): a `__global const float *` buffer
 * argument on the device (portable beyond PoCL's large __constant space), the
 * checked-in data/ltc arrays (.inc files) on the host. */
#ifndef GLINT_AREA_LIGHTS_H
#define GLINT_AREA_LIGHTS_H

#include "kernels/area/area_auto.h"
#include "kernels/area/area_lecocq.h"
#include "kernels/area/area_monte_carlo.h"
#include "kernels/area/ltc_lookup.h"
#include "kernels/area/polygon.h"
#include "kernels/area/spherical_triangle.h"
#include "kernels/compat.h"
#include "kernels/frame.h"
#include "kernels/layout.h"
#include "kernels/rng.h"
#include "kernels/smooth_brdf.h"

/* Polygon records and area_method values (GLINT_AREA_*): kernels/layout.h. */

/* Two clips (shading horizon, then the cosine's support after M^-1) add at
 * most one vertex each to a convex polygon. */
#define GLINT_AREA_MAX_VERTICES (GLINT_POLYGON_MAX_VERTICES + 2)

/* Vertex count of a record, and its vertices relative to the shading point p
 * in the local frame (world = local when the queries carry no frame). */
GLINT_FN int area_polygon_load(const GLINT_GLOBAL float *rec, int has_frame, ShadingFrame frame,
                               real3 p, GLINT_PRIVATE real3 *v) {
  int n = (int)rec[0];
  for (int i = 0; i < n; ++i) {
    const GLINT_GLOBAL float *q = rec + GLINT_POLYGON_VERTEX_OFFSET + 3 * i;
    real3 w = r3_sub(make_real3((real)q[0], (real)q[1], (real)q[2]), p);
    v[i] = has_frame ? frame_to_local(frame, w) : w;
  }
  return n;
}

/* 1 if the polygon (relative to the shading point) emits towards it: its
 * right-hand (Newell) normal points at the receiver, i.e. the vertices are
 * counter-clockwise seen from the receiver (the convention of polygon.h).
 * Two-sided polygons always emit; a receiver in the polygon's plane sees zero
 * solid angle either way. */
GLINT_FN real area_polygon_weight(const GLINT_PRIVATE real3 *v, int n, int two_sided) {
  real3 nn = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  for (int i = 0; i < n; ++i) nn = r3_add(nn, r3_cross(v[i], v[(i + 1) % n]));
  /* nn . v0 = 2 * area * (signed distance of the plane along nn): negative
   * when nn points from the plane towards the origin. */
  return (two_sided || r3_dot(nn, v[0]) < GLINT_R(0.0)) ? GLINT_R(1.0) : GLINT_R(0.0);
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
 * alpha = sqrt(alpha_x alpha_y) (the lobe of equal solid-angle footprint). */
GLINT_FN real area_ltc_form_factor(const GLINT_GLOBAL float *table, real alpha, real3 wo,
                                   const GLINT_PRIVATE real3 *v, int n, GLINT_PRIVATE real *e) {
  for (int k = 0; k < GLINT_LTC_ENTRY; ++k) e[k] = GLINT_R(0.0);
  if (!(wo.z > GLINT_R(0.0))) return GLINT_R(0.0); /* as smooth_reflect_cos: no transmission */
  real3 clipped[GLINT_AREA_MAX_VERTICES];
  int nc = polygon_clip_to_horizon(v, n, clipped);
  if (nc < 3) return GLINT_R(0.0);

  real sxy = sqrt(wo.x * wo.x + wo.y * wo.y);
  /* At normal view the lobe is isotropic about n (t = 0 entries are), so any
   * tangent will do. */
  real tx = sxy > GLINT_R(1e-7) ? wo.x / sxy : GLINT_R(1.0);
  real ty = sxy > GLINT_R(1e-7) ? wo.y / sxy : GLINT_R(0.0);
  area_ltc_lookup(table, alpha, wo.z, e);

  real3 o[GLINT_AREA_MAX_VERTICES];
  for (int i = 0; i < nc; ++i) {
    real3 c = clipped[i];
    real x = c.x * tx + c.y * ty;  /* . T1 */
    real y = -c.x * ty + c.y * tx; /* . T2 = n x T1 */
    o[i] = make_real3(e[0] * x + e[1] * c.z, y, e[2] * x + e[3] * c.z);
  }
  real3 oc[GLINT_AREA_MAX_VERTICES];
  int no = polygon_clip_to_horizon(o, nc, oc);
  /* det M^-1 > 0 keeps the orientation, so the sign is the facing side; the
   * caller's weight decides whether a back face counts. */
  return fabs(polygon_form_factor(oc, no));
}

GLINT_FN real3 area_ltc_polygon(SmoothMaterial m, const GLINT_GLOBAL float *table, real3 wo,
                                const GLINT_PRIVATE real3 *v, int n) {
  real e[GLINT_LTC_ENTRY];
  real ff = area_ltc_form_factor(table, sqrt(m.alpha_x * m.alpha_y), wo, v, n, e);
  return r3_scale(area_ltc_albedo(m, e), ff);
}

/* One Gauss-Legendre panel rule: 4 nodes on [0, 1] (Abramowitz & Stegun
 * 25.4.30 mapped from [-1, 1]); composite rules use it on equal panels. */
GLINT_FN real area_gl4_node(int k) {
  const real a = GLINT_R(0.3399810435848562648), b = GLINT_R(0.8611363115940525752);
  real x = k == 0 ? -b : k == 1 ? -a : k == 2 ? a : b;
  return GLINT_R(0.5) * (x + GLINT_R(1.0));
}
GLINT_FN real area_gl4_weight(int k) {
  const real wa = GLINT_R(0.6521451548625461426), wb = GLINT_R(0.3478548451374438574);
  return GLINT_R(0.5) * ((k == 0 || k == 3) ? wb : wa);
}

GLINT_FN real3 area_safe_normalize(real3 v, real3 fallback) {
  real l = r3_length(v);
  return l > GLINT_R(1e-30) ? r3_div(v, l) : fallback;
}

/* int over the spherical triangle (a, b, c) (unit vectors) of f cos_i dwi,
 * RGB, by a tensor composite Gauss-Legendre rule (`panels` panels of 4 nodes
 * per dimension) in Arvo's area-preserving parameterisation (Arvo 1995,
 * "Stratified Sampling of Spherical Triangles", Sec. 2-3): (u1, u2) in
 * [0, 1]^2 -> direction with constant Jacobian = the triangle's solid angle.
 * Near vertex b the map goes like sqrt(u2) (z = 1 - u2 (1 - c'.b) is a
 * cosine of the arc), so u2 = s^2 makes the integrand smooth for the rule. */
GLINT_FN real3 area_reference_triangle(SmoothMaterial m, real3 wo, real3 a, real3 b, real3 c,
                                       int panels) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real area = spherical_triangle_solid_angle(a, b, c);
  if (!(area > GLINT_R(1e-20))) return zero;
  real alpha = spherical_vertex_angle(a, b, c);
  real3 sum = zero;
  real h = GLINT_R(1.0) / (real)panels;
  for (int i = 0; i < panels; ++i) {
    for (int ki = 0; ki < 4; ++ki) {
      real u1 = ((real)i + area_gl4_node(ki)) * h;
      real w1 = area_gl4_weight(ki) * h;
      ArvoArc arc = arvo_arc(a, b, c, area, alpha, u1);
      for (int j = 0; j < panels; ++j) {
        for (int kj = 0; kj < 4; ++kj) {
          real sj = ((real)j + area_gl4_node(kj)) * h;
          real w = w1 * area_gl4_weight(kj) * h * GLINT_R(2.0) * sj;
          real3 wi = arvo_point(arc, sj * sj);
          sum = r3_add(sum, r3_scale(smooth_reflect_cos(m, wi, wo), w));
        }
      }
    }
  }
  return r3_scale(sum, area);
}

/* int_P f cos_i dwi per unit radiance, RGB, by quadrature (the REFERENCE
 * method): the polygon clipped to the horizon, projected to the sphere, fan
 * triangulated (exact for a convex spherical polygon), and each triangle
 * integrated by area_reference_triangle with `samples` nodes per dimension
 * (rounded up to a multiple of 4). */
GLINT_FN real3 area_reference_polygon(SmoothMaterial m, real3 wo, const GLINT_PRIVATE real3 *v,
                                      int n, int samples) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  if (!(wo.z > GLINT_R(0.0))) return zero;
  real3 clipped[GLINT_AREA_MAX_VERTICES];
  int nc = polygon_clip_to_horizon(v, n, clipped);
  if (nc < 3) return zero;
  for (int i = 0; i < nc; ++i) clipped[i] = area_safe_normalize(clipped[i], clipped[i]);
  int panels = (samples + 3) / 4;
  panels = panels < 1 ? 1 : panels;
  real3 sum = zero;
  for (int i = 1; i + 1 < nc; ++i) {
    sum =
        r3_add(sum, area_reference_triangle(m, wo, clipped[0], clipped[i], clipped[i + 1], panels));
  }
  return sum;
}

/* int_P f cos_i dwi per unit radiance (RGB) of one polygon (vertices relative
 * to the shading point, local frame) by `method`. `key` seeds the stochastic
 * methods (kernels/rng.h); the others ignore it. AUTO picks the method here
 * (area_auto.h); its `samples` is the error budget in millionths. */
GLINT_FN real3 area_polygon_integral(SmoothMaterial m, const GLINT_GLOBAL float *table, int method,
                                     int samples, real3 wo, const GLINT_PRIVATE real3 *v, int n,
                                     uint key) {
  if (method == GLINT_AREA_AUTO) {
    AreaChoice c =
        area_auto_choose(m.ndf, sqrt(m.alpha_x * m.alpha_y), wo, v, n, (float)samples * 1e-6f);
    method = c.method;
    samples = c.samples;
  }
  if (method == GLINT_AREA_REFERENCE) return area_reference_polygon(m, wo, v, n, samples);
  if (method == GLINT_AREA_MONTE_CARLO) return area_mc_polygon(m, wo, v, n, samples, key);
  if (method == GLINT_AREA_LECOCQ || method == GLINT_AREA_LECOCQ_PEARSON)
    return area_lecocq_polygon(m, table, wo, v, n, method == GLINT_AREA_LECOCQ_PEARSON);
  return area_ltc_polygon(m, table, wo, v, n);
}

/* The random-number key of one query for the stochastic area methods: the
 * request seed and the query's own inputs (wo, and the position when the
 * queries carry a frame), never its index, so that an estimate does not
 * depend on how the batch is split (DESIGN.md "Determinism"). */
GLINT_FN uint area_query_key(uint seed_lo, uint seed_hi, const GLINT_GLOBAL float *wo3,
                             const GLINT_GLOBAL float *position3) {
  uint key = rng_hash2(seed_lo, seed_hi);
  for (int k = 0; k < 3; ++k) key = rng_absorb(key, rng_float_key(wo3[k]));
  if (position3)
    for (int k = 0; k < 3; ++k) key = rng_absorb(key, rng_float_key(position3[k]));
  return key;
}

/* Reflected radiance towards wo from every polygon light (RGB), by `method`
 * (GLINT_AREA_*). `wo` is local; `p` the shading point in the lights' space
 * (world with a frame, else the origin); `key` from area_query_key. */
GLINT_FN real3 area_shade_keyed(SmoothMaterial m, const GLINT_GLOBAL float *table, int method,
                                int samples, real3 wo, int has_frame, ShadingFrame frame, real3 p,
                                const GLINT_GLOBAL float *polygons, uint n_polygon, uint key) {
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  for (uint l = 0; l < n_polygon; ++l) {
    const GLINT_GLOBAL float *rec = polygons + GLINT_POLYGON_FLOATS * l;
    real3 v[GLINT_POLYGON_MAX_VERTICES];
    int n = area_polygon_load(rec, has_frame, frame, p, v);
    real weight = area_polygon_weight(v, n, rec[1] != 0.0f);
    if (weight == GLINT_R(0.0)) continue;
    real3 L = make_real3((real)rec[2], (real)rec[3], (real)rec[4]);
    real3 g = area_polygon_integral(m, table, method, samples, wo, v, n, rng_absorb(key, l));
    radiance = r3_add(radiance, r3_mul(g, L));
  }
  return radiance;
}

/* area_shade_keyed with a fixed key (deterministic methods, tests). */
GLINT_FN real3 area_shade(SmoothMaterial m, const GLINT_GLOBAL float *table, int method,
                          int samples, real3 wo, int has_frame, ShadingFrame frame, real3 p,
                          const GLINT_GLOBAL float *polygons, uint n_polygon) {
  return area_shade_keyed(m, table, method, samples, wo, has_frame, frame, p, polygons, n_polygon,
                          0u);
}

#endif /* GLINT_AREA_LIGHTS_H */
