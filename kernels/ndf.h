/* Microfacet normal distributions D(h) and their Smith masking term, written
 * in the local shading frame (+z = macro normal, +x = tangent = alpha_x axis).
 *
 * References:
 *  - Walter, Marschner, Li, Torrance 2007, "Microfacet Models for Refraction
 *    through Rough Surfaces" (GGX and Beckmann D, Smith Lambda).
 *  - Heitz 2014, "Understanding the Masking-Shadowing Function in
 *    Microfacet-Based BRDFs" (anisotropic Lambda, Eq. 86-87; height-correlated
 *    G2 = 1 / (1 + Lambda_o + Lambda_i), Eq. 99).
 */
#ifndef GLINT_NDF_H
#define GLINT_NDF_H

#include "kernels/compat.h"
#include "kernels/layout.h"

/* GGX (Trowbridge-Reitz), anisotropic. Walter et al. 2007 Eq. 33 generalised
 * to two roughnesses (Heitz 2014 Eq. 85):
 *   D(h) = 1 / (pi ax ay (hx^2/ax^2 + hy^2/ay^2 + hz^2)^2),  hz > 0. */
GLINT_FN real D_ggx_aniso(real3 h, real alpha_x, real alpha_y) {
  /* 1 / alpha is the same for every lane (uniform material): a product per lane, not a division. */
  real sx = h.x * (GLINT_R(1.0) / alpha_x);
  real sy = h.y * (GLINT_R(1.0) / alpha_y);
  real q = sx * sx + sy * sy + h.z * h.z;
  real d = GLINT_R(1.0) / (GLINT_PI * alpha_x * alpha_y * q * q);
  return glint_select(d, GLINT_R(0.0), h.z <= GLINT_R(0.0));
}

/* Beckmann, anisotropic (Heitz 2014 Eq. 84):
 *   D(h) = exp(-(tx^2 + ty^2)) / (pi ax ay hz^4),  t = slope / alpha. */
GLINT_FN real D_beckmann_aniso(real3 h, real alpha_x, real alpha_y) {
  /* t2 = tx^2 + ty^2 with the division by hz^2 last: h.y / (alpha_y h.z) is 0/0 when h.y = 0
   * and alpha_y h.z underflows (subnormal h.z), whereas hz^2 = 0 here gives t2 = +inf (a unit h
   * with hz = 0 has sx^2 + sy^2 > 0), which the cut-off below turns into D = 0. */
  real sx = h.x / alpha_x;
  real sy = h.y / alpha_y;
  real hz2 = h.z * h.z;
  real t2 = (sx * sx + sy * sy) / hz2;
  /* exp(-80) ~ 1.8e-35: beyond it D is below any float result, and hz^4 may
   * already have underflowed, which would turn 0/0 into NaN. The exponent is
   * clamped only so that dead lanes (hz <= 0, t2 > 80 or NaN) stay tame. */
  real d = exp(-fmin(t2, GLINT_R(80.0))) / (GLINT_PI * alpha_x * alpha_y * hz2 * hz2);
  return glint_select(d, GLINT_R(0.0), (h.z <= GLINT_R(0.0)) | (t2 > GLINT_R(80.0)));
}

/* Projected roughness s = sqrt(ax^2 wx^2 + ay^2 wy^2): Lambda depends on the
 * direction only through a = wz / s (Heitz 2014 Eq. 86). */
GLINT_FN real projected_roughness(real3 w, real alpha_x, real alpha_y) {
  real x = alpha_x * w.x;
  real y = alpha_y * w.y;
  return sqrt(x * x + y * y);
}

/* wz * Lambda(w) rather than Lambda itself: Lambda diverges like 1/wz at
 * grazing angles while wz * Lambda stays finite, so the visibility term below
 * has no 0 * inf.
 * GGX: Lambda = (-1 + sqrt(1 + s^2/wz^2)) / 2, hence
 *   wz Lambda = (sqrt(wz^2 + s^2) - wz) / 2 = s^2 / (2 (sqrt(wz^2 + s^2) + wz)),
 * the last form avoiding cancellation when s << wz. */
GLINT_FN real z_lambda_ggx(real3 w, real alpha_x, real alpha_y) {
  /* s^2 as a sum of squares: no square root of it to be squared again. */
  real x = alpha_x * w.x;
  real y = alpha_y * w.y;
  real s2 = x * x + y * y;
  real z = fmax(w.z, GLINT_R(0.0));
  real root = sqrt(z * z + s2);
  real denom = GLINT_R(2.0) * (root + z);
  return glint_select(GLINT_R(0.0), s2 / denom, denom > GLINT_R(0.0));
}

/* Beckmann: Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi)), a = wz/s
 * (Walter et al. 2007 Eq. 27 with the exact erf form). Multiplying by wz:
 *   wz Lambda = (s exp(-a^2) / sqrt(pi) - wz erfc(a)) / 2,
 * finite as wz -> 0 (-> s / (2 sqrt(pi))) and as s -> 0 (-> 0). */
GLINT_FN real z_lambda_beckmann(real3 w, real alpha_x, real alpha_y) {
  real s = projected_roughness(w, alpha_x, alpha_y);
  real z = fmax(w.z, GLINT_R(0.0));
  real a = z / s;
  /* s <= 0: no roughness seen from w, Lambda = 0. a > 9: both terms < 1e-36
   * relative, Lambda = 0. Dead lanes evaluate at a = 0 (finite), then drop. */
  glint_mask dead = (s <= GLINT_R(0.0)) | (a > GLINT_R(9.0));
  real a_live = glint_select(a, GLINT_R(0.0), dead);
  real v = (s * exp(-a_live * a_live) / GLINT_SQRT_PI - z * erfc(a_live)) * GLINT_R(0.5);
  v = fmax(v, GLINT_R(0.0)); /* rounding may leave a tiny negative */
  return glint_select(v, GLINT_R(0.0), dead);
}

GLINT_FN real ndf_D(int ndf, real3 h, real alpha_x, real alpha_y) {
  return ndf == GLINT_NDF_BECKMANN ? D_beckmann_aniso(h, alpha_x, alpha_y)
                                   : D_ggx_aniso(h, alpha_x, alpha_y);
}

GLINT_FN real ndf_z_lambda(int ndf, real3 w, real alpha_x, real alpha_y) {
  return ndf == GLINT_NDF_BECKMANN ? z_lambda_beckmann(w, alpha_x, alpha_y)
                                   : z_lambda_ggx(w, alpha_x, alpha_y);
}

/* Height-correlated Smith visibility V = G2 / (4 cos_o cos_i) with
 * G2 = 1 / (1 + Lambda_o + Lambda_i) (Heitz 2014 Eq. 99), rewritten as
 *   V = 1 / (4 (zo zi + zi (zo Lambda_o) + zo (zi Lambda_i)))
 * so it stays finite at grazing angles. Returns 0 below either horizon. */
GLINT_FN real smith_visibility_correlated(int ndf, real3 wo, real3 wi, real alpha_x, real alpha_y) {
  real zlo = ndf_z_lambda(ndf, wo, alpha_x, alpha_y);
  real zli = ndf_z_lambda(ndf, wi, alpha_x, alpha_y);
  real denom = GLINT_R(4.0) * (wo.z * wi.z + wi.z * zlo + wo.z * zli);
  real v = glint_select(GLINT_R(0.0), GLINT_R(1.0) / denom, denom > GLINT_R(0.0));
  return glint_select(v, GLINT_R(0.0), (wo.z <= GLINT_R(0.0)) | (wi.z <= GLINT_R(0.0)));
}

/* GGX in closed form: with r = sqrt(z^2 + s^2) (s^2 = ax^2 wx^2 + ay^2 wy^2), Lambda =
 * (r / z - 1) / 2 (Heitz 2014 Eq. 86), so 1 + Lambda_o + Lambda_i = (r_o / z_o + r_i / z_i) / 2,
 * a sum of positives (no cancellation),
 *   V zi = G2 / (4 zo) = 1 / (2 (r_o + zo (r_i / zi))).
 * Two divisions instead of four. r_i / zi overflows only for subnormal zi; the result is then 0,
 * right unless zo is as small (both cosines subnormal, far below the documented cos >= 1e-7
 * range, where V zi is finite), as in the general form below. */
GLINT_FN real smith_visibility_cos_i_ggx(real3 wo, real3 wi, real alpha_x, real alpha_y) {
  glint_mask dead = (wo.z <= GLINT_R(0.0)) | (wi.z <= GLINT_R(0.0));
  real xo = alpha_x * wo.x, yo = alpha_y * wo.y;
  real xi = alpha_x * wi.x, yi = alpha_y * wi.y;
  real zo = fmax(wo.z, GLINT_R(0.0));
  real zi = glint_select(wi.z, GLINT_R(1.0), dead); /* dead lanes: no 0/0 */
  real r_o = sqrt(zo * zo + (xo * xo + yo * yo));
  real r_i = sqrt(zi * zi + (xi * xi + yi * yi));
  real denom = GLINT_R(2.0) * (r_o + zo * (r_i / zi));
  real v = glint_select(GLINT_R(0.0), GLINT_R(1.0) / denom, denom > GLINT_R(0.0));
  return glint_select(v, GLINT_R(0.0), dead);
}

GLINT_FN real ggx_view_root(real3 wo, real alpha_x, real alpha_y) {
  /* r_o = sqrt(zo^2 + s_o^2), zo = max(wo.z, 0): the part of ggx_D_visibility_cos_i that depends on
   * wo alone (a light loop computes it once per query: ggx_D_visibility_cos_i_view). */
  real xo = alpha_x * wo.x, yo = alpha_y * wo.y;
  real zo = glint_fmax_nn(wo.z, GLINT_R(0.0));
  return glint_sqrt_nn(zo * zo + (xo * xo + yo * yo));
}

/* D(h) V cos_i for GGX in one division, the product smooth_reflect_cos needs. With q and r_o, r_i
 * as in D_ggx_aniso and smith_visibility_cos_i_ggx above,
 *   D V zi = zi / (pi ax ay q^2 * 2 (r_o zi + zo r_i)),
 * one division where the two functions take three (the kernel's divider, shared by every division
 * and square root of a 16-lane block, is its busiest unit: issue 13). Range (documented cosines
 * >= 1e-7, alpha in [1e-4, 1]): for a unit h, 1 <= q <= 1e8, and 2 zo zi <= r_o zi + zo r_i <= 2,
 * so the denominator stays in [6e-22, 2e17], far inside fp32: no overflow or subnormal where the
 * separate factors had none. For a subnormal zi the separate form gave 0 (r_i / zi overflowed);
 * this one the finite limit. h must have h.z > 0 and wo, wi be above the horizon: callers drop
 * other lanes (the result there is finite or 0, never used).
 * Here with zo = max(wo.z, 0) and r_o = ggx_view_root(wo) given (ggx_D_visibility_cos_i below
 * computes them; a light loop once per query, models/smooth/smooth_eval.h).*/
GLINT_FN real ggx_D_visibility_cos_i_view(real3 h, real zo, real r_o, real3 wi, real alpha_x,
                                          real alpha_y) {
  real sx = h.x * (GLINT_R(1.0) / alpha_x);
  real sy = h.y * (GLINT_R(1.0) / alpha_y);
  real q = sx * sx + sy * sy + h.z * h.z;
  real xi = alpha_x * wi.x, yi = alpha_y * wi.y;
  real zi = glint_fmax_nn(wi.z, GLINT_R(0.0));
  real r_i = glint_sqrt_nn(zi * zi + (xi * xi + yi * yi));
  real denom = GLINT_R(2.0) * GLINT_PI * alpha_x * alpha_y * q * q * (r_o * zi + zo * r_i);
  return glint_select(GLINT_R(0.0), zi / denom, denom > GLINT_R(0.0));
}

/* The same operations in the same order as before the split, so the same bits. */
GLINT_FN real ggx_D_visibility_cos_i(real3 h, real3 wo, real3 wi, real alpha_x, real alpha_y) {
  return ggx_D_visibility_cos_i_view(h, glint_fmax_nn(wo.z, GLINT_R(0.0)),
                                     ggx_view_root(wo, alpha_x, alpha_y), wi, alpha_x, alpha_y);
}

/* V cos_i = G2 / (4 cos_o), the factor smooth_reflect_cos needs. V itself overflows in fp32
 * when both cosines are tiny (denominator < 1 / FLT_MAX: cos ~1e-36 at alpha 1e-4) although
 * V cos_i stays moderate, so divide V's denominator by zi first:
 *   V zi = 1 / (4 (zo + zo Lambda_o + zo Lambda_i)) = 1 / (4 (zo + zlo + zo (zli / zi))).
 * zli / zi overflows only for subnormal zi; the result is then 0, right unless zo is subnormal
 * too (outside the documented cos >= 1e-7 range). GGX takes the closed form above. */
GLINT_FN real smith_visibility_cos_i_view(int ndf, real3 wo, real zlo, real3 wi, real alpha_x,
                                          real alpha_y) {
  /* zlo = ndf_z_lambda(ndf, wo): given, so that a light loop computes it once per query. */
  if (ndf != GLINT_NDF_BECKMANN) return smith_visibility_cos_i_ggx(wo, wi, alpha_x, alpha_y);
  real zli = ndf_z_lambda(ndf, wi, alpha_x, alpha_y);
  glint_mask dead = (wo.z <= GLINT_R(0.0)) | (wi.z <= GLINT_R(0.0));
  real zi = glint_select(wi.z, GLINT_R(1.0), dead); /* dead lanes: no 0/0 */
  real denom = GLINT_R(4.0) * (wo.z + zlo + wo.z * (zli / zi));
  real v = glint_select(GLINT_R(0.0), GLINT_R(1.0) / denom, denom > GLINT_R(0.0));
  return glint_select(v, GLINT_R(0.0), dead);
}

GLINT_FN real smith_visibility_cos_i(int ndf, real3 wo, real3 wi, real alpha_x, real alpha_y) {
  if (ndf != GLINT_NDF_BECKMANN) return smith_visibility_cos_i_ggx(wo, wi, alpha_x, alpha_y);
  return smith_visibility_cos_i_view(ndf, wo, ndf_z_lambda(ndf, wo, alpha_x, alpha_y), wi, alpha_x,
                                     alpha_y);
}

#endif /* GLINT_NDF_H */
