/* The binomial glint model (Kneiphof & Klein 2024, "KK24") for one query:
 * for every light,
 *   L = L_smooth * b(N_P, p) / (N_P p)                       (KK24 Eq. 16, 21)
 * with L_smooth the smooth model's radiance from that light (the request's
 * area method for polygons), b(N_P, p) / N_P the footprint's counted fraction
 * of reflecting facets (models/binomial/binomial_count.h) and p the probability that
 * one facet reflects the light towards wo:
 *   AREA (KK24): p = D_Omega_h / D_H (Eq. 12), with
 *     polygons:            D_Omega_h = LTC integral of the BRDF lobe over the
 *                          polygon x D_PR (Sec. 4, "LTC Scale"; Eq. 19),
 *     directional / point: D_Omega_h = |Omega_i| D(h) / (4 h.wi) for the cone
 *                          of half-angle gamma (Eq. 20): the directional
 *                          light's cone_half_angle_deg, asin(r / d) for a
 *                          sphere light of radius r at distance d;
 *   HEURISTIC_R (Deliot & Belcour 2023, the baseline): p = r D(h) / D(n), h
 *     towards the light's centre.
 * p is clamped to [0, 1] (KK24 Sec. 5: p > 1 falls back to the smooth model).
 * Because the same p divides the count, E[L] = L_smooth for any p <= 1: p
 * only decides how sparse and how bright the glints are. For a fixed random
 * stream the count never falls as p grows (binomial_count.h, step 3), so a
 * larger concentric light keeps every glint of a smaller one.
 *
 * D_H and D_PR come from the LTC table (tools/ltc/README.md columns 6, 7;
 * D_H is KK24 Eq. 29/30 evaluated exactly by the fitting tool).
 * Anisotropic alpha: APPROXIMATION, D_H, D_PR and the LTC lobe are looked up
 * at alpha = sqrt(alpha_x alpha_y) (isotropic tables); D(h) is anisotropic.
 * The random stream of a light is keyed by (cell, light, the half-vector's
 * slope cell of size slope_cell): facets are independent across lights, and
 * a different half-vector sees a different set of facets. */
#ifndef GLINT_BINOMIAL_EVAL_H
#define GLINT_BINOMIAL_EVAL_H

#include "kernels/area/area_lights.h"
#include "models/binomial/binomial_count.h"
#include "kernels/lights.h"
#include "models/smooth/smooth_eval.h"

/* Light kinds in the random keys. */
#define GLINT_KEY_DIRECTIONAL 1u
#define GLINT_KEY_POINT 2u
#define GLINT_KEY_POLYGON 3u

/* Random stream of light `index` of `kind` seen through half-vector h. */
GLINT_FN uint binomial_light_key(uint kind, uint index, real3 h, real slope_cell) {
  real z = fmax(h.z, R(1e-6));
  uint key = rng_hash2(kind, index);
  key = rng_absorb(key, binomial_cell_key(floor(h.x / (z * slope_cell))));
  return rng_absorb(key, binomial_cell_key(floor(h.y / (z * slope_cell))));
}

/* Solid angle 2 pi (1 - cos gamma) of a cone with sin(gamma) = s, written
 * as 2 pi s^2 / (1 + cos gamma) so small cones do not cancel. */
GLINT_FN real binomial_cap_solid_angle(real s) {
  s = clamp(s, R(0.0), R(1.0));
  return R(2.0) * GLINT_PI * s * s / (R(1.0) + sqrt(fmax(R(1.0) - s * s, R(0.0))));
}

/* KK24 Eq. 20, or the DB23 heuristic: p for a small cone around wi. */
GLINT_FN real binomial_p_cone(SmoothMaterial m, BinomialParams b, real3 wi, real3 wo,
                              real solid_angle, real d_h, real d_n) {
  real3 h = r3_normalize(r3_add(wi, wo));
  real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
  real p = b.p_mode == GLINT_P_MODE_HEURISTIC_R
               ? b.r * D / d_n
               : solid_angle * D / (d_h * R(4.0) * fmax(r3_dot(h, wi), R(1e-7)));
  return clamp(p, R(0.0), R(1.0));
}

/* One light's glint radiance from its smooth radiance: L_smooth x fraction / p. */
GLINT_FN real3 binomial_light(FootprintGrids g, BinomialParams b, real3 l_smooth, real p,
                              uint light_key) {
  real3 zero = make_real3(R(0.0), R(0.0), R(0.0));
  if (!(p > R(0.0))) return zero;
  real fraction = binomial_fraction(g, p, b.normal_threshold, light_key);
  return r3_scale(l_smooth, fraction / p);
}

typedef struct {
  real u, v;
  real footprint[4]; /* du/dx, dv/dx, du/dy, dv/dy */
  QueryInputs in;    /* wo, and the frame when spec.has_frame */
} BinomialQuery;

typedef struct {
  const GLINT_GLOBAL float *polygons; /* GLINT_POLYGON_FLOATS per light */
  uint n_polygon;
  const GLINT_GLOBAL float *ltc_table;
  int area_method;
  int area_samples;
} AreaInputs;

/* Reflected radiance towards wo (RGB) of the binomial model. `area_key` seeds
 * the stochastic area methods (area_query_key). */
GLINT_FN real3 binomial_shade(EvalSpec spec, SmoothMaterial m, BinomialParams b, BinomialQuery q,
                              LightArrays lights, AreaInputs area, uint seed_lo, uint seed_hi,
                              uint area_key) {
  real3 radiance = make_real3(R(0.0), R(0.0), R(0.0));
  real3 wo = r3_normalize(q.in.wo);
  real3 p = make_real3(R(0.0), R(0.0), R(0.0));
  ShadingFrame frame = area_identity_frame();
  if (spec.has_frame) {
    frame = frame_from_normal_tangent(q.in.normal, q.in.tangent);
    p = q.in.position;
    wo = frame_to_local(frame, wo);
  }
  if (!(wo.z > R(0.0))) return radiance;
  FootprintGrids g = binomial_footprint_grids(b.density, q.u, q.v, q.footprint, seed_lo, seed_hi);
  if (!(g.n_facets > R(0.0))) return radiance;

  real alpha = sqrt(m.alpha_x * m.alpha_y);
  real e[GLINT_LTC_ENTRY];
  area_ltc_lookup(area.ltc_table, alpha, wo.z, e);
  real d_h = e[7];
  real d_n = ndf_D(m.ndf, make_real3(R(0.0), R(0.0), R(1.0)), m.alpha_x, m.alpha_y);

  if (spec.has_directional) {
    for (uint l = 0; l < lights.n_directional; ++l) {
      const GLINT_GLOBAL float *rec = lights.directional + GLINT_LIGHT_FLOATS * l;
      real3 wi = directional_light_dir(rec);
      if (spec.has_frame) wi = frame_to_local(frame, wi);
      real3 ls = r3_mul(smooth_reflect_cos(m, wi, wo), directional_light_irradiance(rec));
      if (!(ls.x + ls.y + ls.z > R(0.0))) continue;
      real prob = binomial_p_cone(m, b, wi, wo, (real)rec[6], d_h, d_n);
      real3 h = r3_normalize(r3_add(wi, wo));
      radiance = r3_add(
          radiance, binomial_light(g, b, ls, prob,
                                   binomial_light_key(GLINT_KEY_DIRECTIONAL, l, h, b.slope_cell)));
    }
  }
  if (spec.has_point) {
    for (uint l = 0; l < lights.n_point; ++l) {
      const GLINT_GLOBAL float *rec = lights.point + GLINT_LIGHT_FLOATS * l;
      real3 E;
      real3 wi = point_light_dir(rec, p, &E);
      if (spec.has_frame) wi = frame_to_local(frame, wi);
      real3 ls = r3_mul(smooth_reflect_cos(m, wi, wo), E);
      if (!(ls.x + ls.y + ls.z > R(0.0))) continue;
      real3 d = r3_sub(light_load3(rec, 0), p);
      real dist = r3_length(d);
      real s = dist > (real)rec[6] ? (real)rec[6] / dist : R(1.0);
      real prob = binomial_p_cone(m, b, wi, wo, binomial_cap_solid_angle(s), d_h, d_n);
      real3 h = r3_normalize(r3_add(wi, wo));
      radiance = r3_add(
          radiance,
          binomial_light(g, b, ls, prob, binomial_light_key(GLINT_KEY_POINT, l, h, b.slope_cell)));
    }
  }
  for (uint l = 0; l < area.n_polygon; ++l) {
    const GLINT_GLOBAL float *rec = area.polygons + GLINT_POLYGON_FLOATS * l;
    real3 v[GLINT_POLYGON_MAX_VERTICES];
    int n = area_polygon_load(rec, spec.has_frame, frame, p, v);
    if (area_polygon_weight(v, n, rec[1] != 0.0f) == R(0.0)) continue;
    real3 L = make_real3((real)rec[2], (real)rec[3], (real)rec[4]);
    real el[GLINT_LTC_ENTRY];
    real ff = area_ltc_form_factor(area.ltc_table, alpha, wo, v, n, el);
    real3 unit = area.area_method == GLINT_AREA_LTC
                     ? r3_scale(area_ltc_albedo(m, el), ff)
                     : area_polygon_integral(m, area.ltc_table, area.area_method, area.area_samples,
                                             wo, v, n, rng_absorb(area_key, l));
    real3 ls = r3_mul(unit, L);
    if (!(ls.x + ls.y + ls.z > R(0.0))) continue;
    /* Centre direction: for the angular key and the heuristic's h. */
    real3 c = make_real3(R(0.0), R(0.0), R(0.0));
    for (int i = 0; i < n; ++i) c = r3_add(c, v[i]);
    real3 wc = area_safe_normalize(c, make_real3(R(0.0), R(0.0), R(1.0)));
    real3 h = area_safe_normalize(r3_add(wc, wo), make_real3(R(0.0), R(0.0), R(1.0)));
    real prob = b.p_mode == GLINT_P_MODE_HEURISTIC_R
                    ? b.r * ndf_D(m.ndf, h, m.alpha_x, m.alpha_y) / d_n
                    : ff * el[6] / el[7];
    prob = clamp(prob, R(0.0), R(1.0));
    radiance = r3_add(
        radiance,
        binomial_light(g, b, ls, prob, binomial_light_key(GLINT_KEY_POLYGON, l, h, b.slope_cell)));
  }
  return radiance;
}

#endif /* GLINT_BINOMIAL_EVAL_H */
