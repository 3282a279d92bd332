/* Polygonal area lights for the smooth model: the LTC approximation (Heitz,
 * Dupuy, Hill, Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly
 * Transformed Cosines", here HDHN16) with our own tables (tools/ltc/,
 * data/ltc/), and a deterministic reference quadrature of
 *   L_o(wo) = L * int_P f(wi, wo) cos(theta_i) dwi
 * over the polygon's solid angle P (clipped to the upper hemisphere).
 *
 * Shared by the OpenCL entry point models/smooth/smooth_area.cl (GLINT_LANES == 1:
 * the per-query quadrature and sample loops branch on per-query values) and the
 * host path; LTC itself (area_ltc.h) is lane-safe and also runs in the lane
 * entry models/smooth/smooth_area_lanes.cl. The LTC table is a plain float array (64 x 64 entries
 * of 8 floats, layout in tools/ltc/README.md): a `__global const float *` buffer argument on the
 * device (portable beyond PoCL's large __constant space), the checked-in data/ltc arrays (.inc
 * files) on the host. */
#ifndef GLINT_AREA_LIGHTS_H
#define GLINT_AREA_LIGHTS_H

/* Per-query branches (clipped vertex loops, sample loops, quadrature): one
 * query per work-item. The lane-safe LTC path is area_ltc.h. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES != 1
#error "kernels/area/area_lights.h needs GLINT_LANES == 1"
#endif

#include "kernels/area/area_auto.h"
#include "kernels/area/area_lecocq.h"
#include "kernels/area/area_ltc.h"
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

/* The same integral over a triangle whose vertex b is at (or near) the peak of a sharp lobe,
 * in polar coordinates about b: the angle theta at b (from the arc towards a to the arc towards
 * c) and x = 1 - cos r, r the arc from b (the solid angle is dtheta dx), up to the opposite edge
 * at x = X(theta). Both coordinates follow the lobe, which Arvo's map does not: its u1 is the
 * area swept, so the lobe's mass per unit u1 goes as 1 / X, which varies by orders of magnitude
 * across a long fan triangle; and equal radial panels resolve a lobe narrower than the first of
 * them only by chance. With 4 to 32 nodes and alpha ~0.01 a node landing on the peak with a
 * weight several lobe widths long put the sum above the directional albedo (x18 the truth at 8
 * nodes, glint_scan_area_auto; README "REFERENCE").
 *
 * Radially, x_w = `lobe` is the lobe's width as 1 - cos of an arc: GGX's D ~ 1 / (alpha^2 +
 * tan^2 theta_h)^2 with tan^2 theta_h ~ x / 2 at the mirror direction, i.e. ~ 1 / (x + x_w)^2
 * with x_w = 2 alpha^2, or with u2 = x / X and a = x_w / X ~ 1 / (u2 + a)^2. The rule runs in
 * phi, u2 = s^2, s = sqrt(a) tan phi, phi in [0, atan(1 / sqrt(a))]: du2 = 2 a tan phi sec^2 phi
 * dphi makes that lobe (sin 2 phi) / a, smooth, and the map is smooth at b (s ~ the arc from
 * b); for a >> 1 (a lobe wider than the triangle) s -> phi sqrt(a), the plain rule in s. */
GLINT_FN real3 area_reference_polar_triangle(SmoothMaterial m, real3 wo, real3 a, real3 b, real3 c,
                                             int panels, real lobe) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  if (!(spherical_triangle_solid_angle(a, b, c) > GLINT_R(1e-20))) return zero;
  real beta = spherical_vertex_angle(b, a, c);
  /* Unit tangents at b: ta towards a, tp orthogonal to it on c's side. */
  real3 ta = spherical_orthogonal_dir(b, r3_sub(a, b), a);
  real3 tc = spherical_orthogonal_dir(b, r3_sub(c, b), c);
  real3 tp = area_safe_normalize(r3_sub(tc, r3_scale(ta, r3_dot(tc, ta))), tc);
  real3 n2 = r3_cross(a, c); /* the opposite edge's great circle */
  real3 sum = zero;
  real h = GLINT_R(1.0) / (real)panels;
  for (int i = 0; i < panels; ++i) {
    for (int ki = 0; ki < 4; ++ki) {
      real theta = ((real)i + area_gl4_node(ki)) * h * beta;
      real w1 = area_gl4_weight(ki) * h * beta;
      real3 t = r3_add(r3_scale(ta, cos(theta)), r3_scale(tp, sin(theta)));
      /* The arc b cos r + t sin r meets the opposite edge where (n2.b) cos r + (n2.t) sin r = 0,
       * r in (0, pi); X = 1 - cos r = 2 sin^2(r / 2) without cancellation. */
      real nb = r3_dot(n2, b), nt = r3_dot(n2, t);
      real r_max = atan2(fabs(nb), nb >= GLINT_R(0.0) ? -nt : nt);
      real sin_half = sin(GLINT_R(0.5) * r_max); /* not `half`: an OpenCL C type */
      real big_x = GLINT_R(2.0) * sin_half * sin_half;
      if (!(big_x > GLINT_R(0.0))) continue;
      /* The warp where the lobe is narrower than a radial panel (a < 1 / panels^2: the plain
       * rule's first node, at s = 0.07 / panels, would lie in its tail); a wider lobe is
       * resolved by the plain rule, which also keeps nodes where the light's far parts and the
       * horizon are (the warp's outer nodes thin out as 1 / tan^2: GGX alpha 0.1 under a
       * hemisphere-filling light converged to 2e-4 at 64 nodes with it, 1e-7 without). */
      real a_lobe = lobe / big_x;
      int warp = lobe > GLINT_R(0.0) && a_lobe * (real)(panels * panels) < GLINT_R(1.0);
      real ra = warp ? sqrt(a_lobe) : GLINT_R(1.0); /* sqrt(a) */
      real phi_max = warp ? atan2(GLINT_R(1.0), ra) : GLINT_R(1.0);
      for (int j = 0; j < panels; ++j) {
        for (int kj = 0; kj < 4; ++kj) {
          real v = ((real)j + area_gl4_node(kj)) * h;
          real s = v, ds = GLINT_R(1.0);
          if (warp) {
            /* s = sqrt(a) tan(phi), ds/dv = phi_max (a + s^2) / sqrt(a); s <= 1 up to the
             * rounding of tan near pi/2 when a is tiny. */
            s = fmin(ra * tan(v * phi_max), GLINT_R(1.0));
            ds = phi_max * (ra + s * (s / ra));
          }
          real x = s * s * big_x; /* 1 - cos r */
          real sin_r = sqrt(fmax(x * (GLINT_R(2.0) - x), GLINT_R(0.0)));
          real3 wi = r3_add(r3_scale(b, GLINT_R(1.0) - x), r3_scale(t, sin_r));
          real w = w1 * area_gl4_weight(kj) * h * big_x * GLINT_R(2.0) * s * ds;
          sum = r3_add(sum, r3_scale(smooth_reflect_cos(m, wi, wo), w));
        }
      }
    }
  }
  return sum;
}

/* One piece of a split triangle, its vertex b at (or nearest to) the lobe's peak: in polar
 * coordinates about b where the lobe (x_w, as 1 - cos of its width) is narrower than a radial
 * panel of the piece (x_w panels^2 < 1 - cos of the arc from b to its farther vertex), else by
 * Arvo's map as before: for a lobe as wide as the piece the polar rule converges more slowly
 * (GGX alpha 0.66, a light 0.3 sr beside the peak: 4e-4 off at 64 nodes, Arvo's map 1e-8). */
GLINT_FN real3 area_reference_piece(SmoothMaterial m, real3 wo, real3 a, real3 b, real3 c,
                                    int panels, real x_w) {
  real far = fmax(GLINT_R(1.0) - r3_dot(a, b), GLINT_R(1.0) - r3_dot(c, b));
  if (x_w * (real)(panels * panels) < far)
    return area_reference_polar_triangle(m, wo, a, b, c, panels, x_w);
  return area_reference_triangle(m, wo, a, b, c, panels);
}

/* area_reference_triangle over (a, b, c) split at its point q nearest to `peak` (unit vectors)
 * when q is within `near` radians of it: three pieces around q inside, two from a point on an
 * edge, the vertex order rotated at a vertex; q is each piece's vertex b (area_reference_piece),
 * the lobe's width w (radians) at the peak, and sqrt(w^2 + d^2) from a point d away from it
 * (the lobe's Cauchy-like tail seen from there). */
GLINT_FN real3 area_reference_split_triangle(SmoothMaterial m, real3 wo, real3 a, real3 b, real3 c,
                                             real3 peak, real near, real width, int panels) {
  real x_w = GLINT_R(0.5) * width * width; /* 1 - cos w */
  if (spherical_triangle_contains(a, b, c, peak)) {
    real3 s = area_reference_piece(m, wo, a, peak, b, panels, x_w);
    s = r3_add(s, area_reference_piece(m, wo, b, peak, c, panels, x_w));
    return r3_add(s, area_reference_piece(m, wo, c, peak, a, panels, x_w));
  }
  SphericalNearest q = spherical_triangle_nearest(a, b, c, peak);
  if (!(q.distance < near)) return area_reference_triangle(m, wo, a, b, c, panels);
  real3 v[3] = {a, b, c};
  int e = q.edge; /* the nearest point is on edge (v[e], v[e+1]), or is vertex v[e] */
  real3 x = v[e], y = v[(e + 1) % 3], z = v[(e + 2) % 3];
  x_w += GLINT_R(0.5) * q.distance * q.distance;
  if (q.at_vertex) return area_reference_piece(m, wo, z, x, y, panels, x_w);
  return r3_add(area_reference_piece(m, wo, x, q.point, z, panels, x_w),
                area_reference_piece(m, wo, z, q.point, y, panels, x_w));
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
  /* D peaks at h = n, i.e. at wi = the mirror direction of wo. A fan triangle holding the peak,
   * or passing within a few lobe widths of it, is split at its point nearest to the peak, which
   * becomes vertex b of the pieces: Arvo's map with u2 = s^2 puts its nodes densest there
   * (uniform in the arc distance from b). A sharp lobe in a large triangle is otherwise seen by
   * a few nodes only (alpha 0.01 in a near-hemisphere light at a grazing view: 3-50% off at 1024
   * nodes). Costs up to 3x the nodes of that triangle. */
  real3 peak = make_real3(-wo.x, -wo.y, wo.z);
  real near = GLINT_R(10.0) * fmax(m.alpha_x, m.alpha_y); /* "a few lobe widths", radians */
  /* The lobe's width in wi around the peak: a tilt t of h turns wi by 2 t in the plane of
   * incidence (2 t cos theta_o across it), and GGX's D falls as 1 / (alpha^2 + t^2)^2: w = 2
   * alpha along the wider axis (the narrower one is left to the u1 nodes). */
  real width = GLINT_R(2.0) * fmax(m.alpha_x, m.alpha_y);
  real3 sum = zero;
  for (int i = 1; i + 1 < nc; ++i) {
    sum = r3_add(sum, area_reference_split_triangle(m, wo, clipped[0], clipped[i], clipped[i + 1],
                                                    peak, near, width, panels));
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
  if (method == GLINT_AREA_LTC)
    return area_ltc_shade(m, table, wo, has_frame, frame, p, polygons, n_polygon);
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
