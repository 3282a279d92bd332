/* Polygon lights for the Chermain et al. 2020 glint model (beyond the paper:
 * CSDD20 Sec. 7.6 leaves area lights to future work), one query per
 * work-item (clipping branches per query).
 *
 * APPROXIMATION (representative-point ratio): for light L with smooth
 * radiance I_s = int_L f_s cos_i L_e dw by the request's area method
 * (kernels/area/polygon_lights.h; f_s the smooth Beckmann BRDF with Smith G),
 *
 *   I_P ~= I_s * g_P(w_r) / g_s(w_r),   g = f(w_r, wo) cos_r, per RGB channel,
 *
 * g_P the glint BRDF (chermain_reflect_cos, Eq. 14) and w_r the light's
 * representative direction: the point of the light's plane hit by the mirror
 * direction of wo (the peak of the Beckmann lobe) when it lies inside the
 * polygon, else the polygon point in that plane closest to the hit point
 * (the "representative point" of Karis 2013 for sphere/tube lights); the
 * mean of the unit vertex directions when the mirror ray misses the plane.
 * Since g_P / g_s = (P22_P / P22_target) (G_V-cavity / G_Smith) at w_r (same
 * Fresnel), the glints of the whole light are those at one half-vector.
 *
 * Bound (mean value theorem): the exact I_P = int g_P L_e = R_bar I_s with
 * R_bar the g_s-weighted mean of R = g_P / g_s over the light, so
 * |I_P - approx| <= (max_L R - min_L R) I_s (plus the area method's own error
 * times R(w_r)). The range of R shrinks to 0 with the light (per query);
 * over uv E[R] ~ G_V / G_Smith, so the mean over positions is the smooth
 * integral up to the V-cavity/Smith ratio's variation over the light and the
 * dictionary's approximation (models/chermain/README.md). Measured against
 * Monte Carlo over the polygon in models/chermain/tests/chermain_test.cpp. */
#ifndef GLINT_CHERMAIN_POLYGONS_H
#define GLINT_CHERMAIN_POLYGONS_H

#include "kernels/area/area_lights.h"
#include "kernels/area/polygon_lights.h"
#include "models/chermain/chermain_eval.h"

/* The representative direction of the light's vertices v[0..n) (relative to
 * the shading point, local frame) for the view wo: see the header comment. */
GLINT_FN real3 chermain_representative_dir(const GLINT_PRIVATE real3 *v, int n, real3 wo) {
  real3 up = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  real3 c = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 nn = c;
  for (int k = 0; k < n; ++k) {
    c = r3_add(c, area_safe_normalize(v[k], up));
    nn = r3_add(nn, r3_cross(v[k], v[(k + 1) % n]));
  }
  real3 centre = area_safe_normalize(c, up);
  real3 r = make_real3(-wo.x, -wo.y, wo.z); /* mirror direction about n = z */
  real plane = r3_dot(v[0], nn);            /* the plane: x . nn = plane */
  real denom = r3_dot(r, nn);
  real t = plane / denom;
  if (!(denom != GLINT_R(0.0)) || !(t > GLINT_R(0.0)) || !isfinite(t)) return centre;
  real3 x = r3_scale(r, t);
  /* Inside: x on the inner side of every edge (the Newell normal orients them). */
  int inside = 1;
  real best_d2 = GLINT_R(0.0);
  real3 best = x;
  for (int k = 0; k < n; ++k) {
    real3 a = v[k], e = r3_sub(v[(k + 1) % n], v[k]);
    real3 ax = r3_sub(x, a);
    if (r3_dot(r3_cross(e, ax), nn) < GLINT_R(0.0)) inside = 0;
    real ee = r3_dot(e, e);
    real s =
        ee > GLINT_R(0.0) ? clamp(r3_dot(ax, e) / ee, GLINT_R(0.0), GLINT_R(1.0)) : GLINT_R(0.0);
    real3 q = r3_add(a, r3_scale(e, s));
    real3 d = r3_sub(x, q);
    real d2 = r3_dot(d, d);
    if (k == 0 || d2 < best_d2) {
      best_d2 = d2;
      best = q;
    }
  }
  real3 w = inside ? r : area_safe_normalize(best, centre);
  return w.z > GLINT_R(0.0) ? w : centre;
}

/* One channel of I_s g_P / g_s: 0 where the ratio is 0 or undefined (g_s = 0,
 * where I_s vanishes too, or inf / inf at extreme inputs), so that an
 * overflowed I_s times a zero ratio is 0, not NaN; an overflowed ratio times
 * I_s > 0 is inf, which the store saturates. */
GLINT_FN real chermain_scaled(real smooth, real glint, real smooth_at_wr) {
  real ratio = glint / smooth_at_wr;
  return ratio > GLINT_R(0.0) && smooth > GLINT_R(0.0) ? smooth * ratio : GLINT_R(0.0);
}

/* Polygon lights for query i: the APPROXIMATION of the header comment. Adds to
 * the first pass (probes, directional and point lights: chermain_query). */
GLINT_FN real3 chermain_polygons_query(EvalSpec spec, KernelInputs in, uint i) {
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  ChermainParams p = chermain_params_unpack(in.params);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  real3 wo = sp.wo;
  if (!(wo.z > GLINT_R(0.0))) return radiance;
  real fp[4];
  for (int k = 0; k < 4; ++k) fp[k] = (real)in.footprint[4 * i + k];
  ChermainFootprint f = chermain_footprint(p, (real)in.uv[2 * i], (real)in.uv[2 * i + 1], fp);
  uint seed_key = rng_hash2(in.seed_lo, in.seed_hi);
  uint area_key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                                 spec.has_frame ? in.position + 3 * i : 0);
  for (uint l = 0; l < in.n_polygon; ++l) {
    PolygonLight P = polygon_light(spec, in, sp, m, l, area_key);
    real3 ls = P.radiance;
    if (!(ls.x + ls.y + ls.z > GLINT_R(0.0))) continue;
    real3 wr = chermain_representative_dir(P.v, P.n, wo);
    real3 gp = chermain_reflect_cos(in.model_table, p, f, m, seed_key, wr, wo);
    real3 gs = smooth_reflect_cos(m, wr, wo);
    radiance = r3_add(
        radiance, make_real3(chermain_scaled(ls.x, gp.x, gs.x), chermain_scaled(ls.y, gp.y, gs.y),
                             chermain_scaled(ls.z, gp.z, gs.z)));
  }
  return radiance;
}

#endif /* GLINT_CHERMAIN_POLYGONS_H */
