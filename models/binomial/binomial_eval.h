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
 * a different half-vector sees a different set of facets.
 *
 * Lane-safe (kernels/compat.h): binomial_shade runs GLINT_LANES queries per
 * work-item in the lane kernel (binomial_lanes.cl: directional, point and
 * polygon lights by LTC) and one query on the host and in the one-query
 * kernel (binomial.cl: polygon lights by the other area methods, which branch
 * per query). */
#ifndef GLINT_BINOMIAL_EVAL_H
#define GLINT_BINOMIAL_EVAL_H

#include "kernels/area/area_ltc.h"
#include "kernels/kernel_args.h"
#include "kernels/punctual_lights.h"
#include "kernels/query.h"
#include "kernels/smooth_brdf.h"
#include "models/binomial/binomial_count.h"
#include "models/binomial/binomial_stochastic.h"
#if !defined(__OPENCL_VERSION__) || GLINT_LANES == 1
#include "kernels/area/area_lights.h"
#include "kernels/area/polygon_lights.h"
#endif

/* Light kinds in the random keys. */
#define GLINT_KEY_DIRECTIONAL 1u
#define GLINT_KEY_POINT 2u
#define GLINT_KEY_POLYGON 3u

/* Random stream of light `index` of `kind` seen through half-vector h. */
GLINT_FN glint_key binomial_light_key(uint kind, uint index, real3 h, real slope_cell) {
  real z = glint_fmax_nn(h.z, GLINT_R(1e-6));
  glint_key key = rng_hash2(kind, index);
  key = rng_absorb_key(key, binomial_cell_key(glint_floor(h.x / (z * slope_cell))));
  return rng_absorb_key(key, binomial_cell_key(glint_floor(h.y / (z * slope_cell))));
}

/* KK24 Eq. 20, or the DB23 heuristic: p for a small cone around wi. */
GLINT_FN real binomial_p_cone(SmoothMaterial m, BinomialParams b, real3 wi, real3 wo,
                              real solid_angle, real d_h, real d_n) {
  real3 h = r3_normalize(r3_add(wi, wo));
  real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
  real p =
      b.p_mode == GLINT_P_MODE_HEURISTIC_R
          ? b.r * D / d_n
          : solid_angle * D / (d_h * GLINT_R(4.0) * glint_fmax_nn(r3_dot(h, wi), GLINT_R(1e-7)));
  return glint_clamp_nn(p, GLINT_R(0.0), GLINT_R(1.0));
}

/* A request's one light whose count draw the lane kernel defers (binomial_lanes.cl,
 * GLINT_BLOCKS > 1): binomial_shade records what binomial_light and its draw computed before
 * the whole trials' count, the kernel draws the counts of several blocks with the lanes
 * regrouped by regime, and binomial_deferred_finish completes the light as binomial_light and
 * binomial_shade would have. Only for one light and one grid (STOCHASTIC: grids 1..7 hold no
 * facets), which is what the kernel asks it for. */
typedef struct {
  int deferred; /* a light was recorded (uniform); else binomial_shade's result is the block's */
  real3 l_smooth;
  real p;
  real n_facets;
  glint_mask lit;     /* binomial_light's */
  glint_mask counted; /* binomial_fraction_lanes' */
  glint_mask live;    /* binomial_shade's */
  real p_draw;        /* fmin(p, 1), BinomialProb's */
  BinomialDrawInputs draw;
} BinomialDeferred;

/* binomial_light from the whole trials' count k_whole (lanes of d->draw.has_whole), then
 * binomial_shade's sum (of this one light) and its mask: the same operations, so the same bits. */
GLINT_FN real3 binomial_deferred_finish(const GLINT_PRIVATE BinomialDeferred *d, real k_whole) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  /* binomial_fraction_lanes: 0 + the draw of grid 0 */
  real count = GLINT_R(0.0) + binomial_draw_count(d->draw, k_whole);
  real fraction = glint_select(GLINT_R(0.0), count / d->n_facets, d->counted);
  real3 term =
      r3_select(zero, r3_scale(d->l_smooth, fraction / d->p), d->lit & (fraction > GLINT_R(0.0)));
  return r3_select(zero, r3_add(zero, term), d->live);
}

/* One light's glint radiance from its smooth radiance: L_smooth x fraction / p; 0 in the
 * lanes outside `active`. With `defer` (not 0), the light is recorded there instead and 0
 * returned (BinomialDeferred). */
GLINT_FN real3 binomial_light(FootprintGrids g, BinomialParams b, real3 l_smooth, real p,
                              glint_key light_key, glint_mask active,
                              GLINT_PRIVATE BinomialDeferred *defer) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  glint_mask lit = active & (p > GLINT_R(0.0));
  if (defer) {
    /* binomial_fraction_lanes up to grid 0's draw of its whole trials */
    glint_mask counted = lit & (g.n_facets > GLINT_R(0.0)) & (p > GLINT_R(0.0));
    BinomialProb prob = binomial_prob(p);
    defer->deferred = 1;
    defer->l_smooth = l_smooth;
    defer->p = p;
    defer->n_facets = g.n_facets;
    defer->lit = lit;
    defer->counted = counted;
    defer->p_draw = prob.p;
    defer->draw = binomial_draw_inputs(g.share[0] * g.n_facets, p, prob.p,
                                       rng_absorb_key(g.cell_key[0], light_key),
                                       counted & (g.share[0] > GLINT_R(0.0)));
    return zero;
  }
  real fraction = binomial_fraction_lanes(g, p, b.normal_threshold, light_key, lit);
  /* No reflecting facet: exactly 0, also when l_smooth overflowed to +Inf (0 x Inf = NaN). */
  return r3_select(zero, r3_scale(l_smooth, fraction / p), lit & (fraction > GLINT_R(0.0)));
}

/* area_safe_normalize (area_lights.h), per lane. */
GLINT_FN real3 binomial_safe_normalize(real3 v, real3 fallback) {
  real l = r3_length(v);
  return r3_select(fallback, r3_div(v, l), l > GLINT_R(1e-30));
}

/* One polygon light's glints from its smooth radiance ls, its n vertices v (local frame,
 * relative to the shading point) and the LTC lobe's integral ff over it with the table entries
 * e6 = D_PR, e7 = D_H (KK24 Eq. 19). */
GLINT_FN real3 binomial_polygon(FootprintGrids g, BinomialParams b, SmoothMaterial m, real3 wo,
                                real d_n, const GLINT_PRIVATE real3 *v, int n, real3 ls, real ff,
                                real e6, real e7, uint l, glint_mask active,
                                GLINT_PRIVATE BinomialDeferred *defer) {
  glint_mask lit = active & (ls.x + ls.y + ls.z > GLINT_R(0.0));
  /* Centre direction: for the angular key and the heuristic's h. */
  real3 up = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  real3 c = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  for (int k = 0; k < n; ++k) c = r3_add(c, v[k]);
  real3 wc = binomial_safe_normalize(c, up);
  real3 h = binomial_safe_normalize(r3_add(wc, wo), up);
  real prob = b.p_mode == GLINT_P_MODE_HEURISTIC_R
                  ? b.r * ndf_D(m.ndf, h, m.alpha_x, m.alpha_y) / d_n
                  : ff * e6 / e7;
  prob = glint_clamp_nn(prob, GLINT_R(0.0), GLINT_R(1.0));
  return binomial_light(g, b, ls, prob, binomial_light_key(GLINT_KEY_POLYGON, l, h, b.slope_cell),
                        lit, defer);
}

/* Polygon light l by LTC (area_ltc.h), lane-safe: its smooth radiance, p and glints.
 * Called with a constant n for quads (unrolled vertex loops, as area_ltc_shade_light).
 * `entry` is the LTC table entry at (alpha, wo.z) that binomial_shade looked up for D_H, the
 * one area_ltc_form_factor would look up again, or 0 to look it up here (what binomial_shade
 * passes when the request also has punctual lights: below). */
GLINT_FN real3 binomial_polygon_ltc(FootprintGrids g, BinomialParams b, SmoothMaterial m,
                                    EvalSpec spec, KernelInputs in, ShadingPoint sp, real alpha,
                                    real d_n, uint l, int n, glint_mask live,
                                    const GLINT_PRIVATE real *entry,
                                    GLINT_PRIVATE BinomialDeferred *defer) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  const GLINT_GLOBAL float *rec = in.polygons + GLINT_POLYGON_FLOATS * l;
  real3 v[GLINT_POLYGON_MAX_VERTICES];
  area_polygon_load_n(rec, n, spec.has_frame, sp.frame, sp.p, v);
  glint_mask facing = live & area_polygon_facing(v, n, rec[1] != 0.0f);
  if (!glint_any(facing)) return zero;
  /* area_ltc_form_factor's steps, with the entry reused where given: the same entry, so the
   * same bits (area_ltc_form_factor_entry zeroes it in some lanes: a copy per light). */
  real e[GLINT_LTC_ENTRY];
  real tx, ty;
  area_ltc_view_tangent(sp.wo, &tx, &ty);
  if (entry)
    for (int k = 0; k < GLINT_LTC_ENTRY; ++k) e[k] = entry[k];
  else
    area_ltc_lookup(in.ltc_table, alpha, sp.wo.z, e);
  real ff = area_ltc_form_factor_entry(sp.wo, tx, ty, v, n, e);
  real3 ls = r3_mul(r3_scale(area_ltc_albedo(m, e), ff),
                    make_real3((real)rec[2], (real)rec[3], (real)rec[4]));
  return binomial_polygon(g, b, m, sp.wo, d_n, v, n, ls, ff, e[6], e[7], l, facing, defer);
}

/* Reflected radiance towards wo (RGB) of the binomial model for the queries q (one, or a block
 * of lanes) with their uv (u, v) and footprints. Polygon lights by LTC in lanes; the other
 * area methods only in one-query builds, keyed by `area_key` (area_query_key). */
GLINT_FN real3 binomial_shade(EvalSpec spec, KernelInputs in, QueryInputs q, real u, real v,
                              const GLINT_PRIVATE real *footprint, uint area_key,
                              GLINT_PRIVATE BinomialDeferred *defer) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 radiance = zero;
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  BinomialParams b = binomial_params_unpack(in.params);
  ShadingPoint sp = shading_point(spec, q);
  real3 wo = sp.wo;
  glint_mask live = wo.z > GLINT_R(0.0);
  if (!glint_any(live)) return radiance;
  FootprintGrids g = binomial_footprint_grids_for(b.interpolation, b.density, u, v, footprint,
                                                  in.seed_lo, in.seed_hi);
  live = live & (g.n_facets > GLINT_R(0.0));
  if (!glint_any(live)) return radiance;

  real alpha = sqrt(m.alpha_x * m.alpha_y);
  real e[GLINT_LTC_ENTRY];
  area_ltc_lookup(in.ltc_table, alpha, wo.z, e);
  real d_h = e[7];
  real d_n =
      ndf_D(m.ndf, make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0)), m.alpha_x, m.alpha_y);

  uint n_lights = punctual_light_count(spec, in);
  /* The wo-only terms of the smooth BRDF once per query, not per light (as SMOOTH's light loop,
   * models/smooth/smooth_eval.h): the same operations, so the same bits (smooth_brdf.h). */
  SmoothView view = smooth_view(m, wo);
  for (uint l = 0; l < n_lights; ++l) {
    PunctualLight light = punctual_light(spec, in, sp, l);
    real3 ls = r3_mul(smooth_reflect_cos_view(m, view, light.wi), light.irradiance);
    glint_mask lit = live & (ls.x + ls.y + ls.z > GLINT_R(0.0));
    if (!glint_any(lit)) continue;
    real prob = binomial_p_cone(m, b, light.wi, wo, light.solid_angle, d_h, d_n);
    real3 h = r3_normalize(r3_add(light.wi, wo));
    uint kind =
        light.kind == GLINT_LIGHT_KIND_DIRECTIONAL ? GLINT_KEY_DIRECTIONAL : GLINT_KEY_POINT;
    radiance =
        r3_add(radiance,
               binomial_light(g, b, ls, prob,
                              binomial_light_key(kind, light.index, h, b.slope_cell), lit, defer));
  }

  for (uint l = 0; l < in.n_polygon; ++l) {
#if !defined(__OPENCL_VERSION__) || GLINT_LANES == 1
    if (in.area_method != GLINT_AREA_LTC) {
      PolygonLight P = polygon_light(spec, in, sp, m, l, area_key);
      if (P.n == 0) continue; /* faces away: no radiance, P.ltc unset */
      radiance =
          r3_add(radiance, binomial_polygon(g, b, m, wo, d_n, P.v, P.n, P.radiance, P.form_factor,
                                            P.ltc[6], P.ltc[7], l, live, defer));
      continue;
    }
#endif
    /* The polygons reuse the entry looked up above for D_H instead of a second lookup per light
     * (16 gathers of 4 x 8 floats, the blend and the transposes per 16 lanes): ~3% of the
     * one-quad rate, at the noise floor (models/binomial/README.md "Quad throughput (session 18):
     * the query outside the draw"). Not when the request also has punctual lights (build-time
     * constants in the lane kernel): keeping the 8-vector entry live across their loop cost
     * directional + point ~4% in session 12, so those kernels look it up again here. */
    const GLINT_PRIVATE real *entry = spec.has_directional || spec.has_point ? 0 : e;
    int n = (int)in.polygons[GLINT_POLYGON_FLOATS * l];
    radiance = r3_add(
        radiance,
        n == 4 ? binomial_polygon_ltc(g, b, m, spec, in, sp, alpha, d_n, l, 4, live, entry, defer)
               : binomial_polygon_ltc(g, b, m, spec, in, sp, alpha, d_n, l, n, live, entry, defer));
  }
  if (defer) defer->live = live;
  return r3_select(zero, radiance, live);
}

#if !defined(__OPENCL_VERSION__) || GLINT_LANES == 1
/* Query i (the host pass, the one-query kernel). */
GLINT_FN real3 binomial_query(EvalSpec spec, KernelInputs in, uint i) {
  real footprint[4];
  for (int k = 0; k < 4; ++k) footprint[k] = (real)in.footprint[4 * i + k];
  uint area_key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                                 spec.has_frame ? in.position + 3 * i : 0);
  return binomial_shade(spec, in, query_load(spec, in, i), (real)in.uv[2 * i],
                        (real)in.uv[2 * i + 1], footprint, area_key, 0);
}
#endif

#endif /* GLINT_BINOMIAL_EVAL_H */
