/* Fresnel reflectance, per RGB channel. The kind is a build-time constant on
 * the device (GLINT_FRESNEL) and a runtime value on the host. */
#ifndef GLINT_FRESNEL_H
#define GLINT_FRESNEL_H

#include "kernels/compat.h"
#include "kernels/layout.h"

/* Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering",
 * Eq. 15: F = f0 + (1 - f0)(1 - cos)^5. */
GLINT_FN real F_schlick(real f0, real cos_theta) {
  real m = clamp(GLINT_R(1.0) - cos_theta, GLINT_R(0.0), GLINT_R(1.0));
  real m2 = m * m;
  return f0 + (GLINT_R(1.0) - f0) * (m2 * m2 * m);
}

/* Exact unpolarised reflectance of a conductor with complex IOR eta + i k.
 * Born & Wolf form as written in Lazanyi & Szirmay-Kalos 2005, "Fresnel term
 * approximations for metals" (Eq. 1-2), via a^2 + b^2 = sqrt(t0^2 + 4 eta^2 k^2):
 *   Rs = (a2b2 + c^2 - 2 a c) / (a2b2 + c^2 + 2 a c)
 *   Rp = Rs (c^2 a2b2 + s^4 - 2 a c s^2) / (c^2 a2b2 + s^4 + 2 a c s^2).
 * Two square roots and one division per channel (the cost that matters: the
 * conductor runs this three times per evaluation, issue 13). */
GLINT_FN real F_conductor_cos2(real eta, real k, real c, real c2) {
  real s2 = GLINT_R(1.0) - c2;
  real t0 = eta * eta - k * k - s2;
  /* t0^2 + 4 eta^2 k^2 >= 0 as computed too (squares and a product of two squares, rounded: never
   * negative), so the root needs no bound. */
  real a2b2 = glint_sqrt_nn(t0 * t0 + GLINT_R(4.0) * eta * eta * k * k);
  /* a^2 = (a2b2 + t0) / 2 cancels when t0 < 0 and |t0| >> 2 eta k (small eta, large k: silver,
   * gold in the red), costing fp32 up to 1e-5 in F. With u = a2b2 + |t0| (a sum of
   * non-negatives: no cancellation) and w = sqrt(u / 2): a = w for t0 >= 0, and for t0 < 0
   * (then w = b, as b^2 = (a2b2 - t0) / 2 and a b = eta k) a = eta k / w. That division is
   * merged into the final one: both fractions below are multiplied through by w, with
   * T = 2 a c w = c u (t0 >= 0) or 2 c eta k (t0 < 0), so no term needs a itself. */
  real u = a2b2 + fabs(t0);
  real half_u = GLINT_R(0.5) * u;
  /* glint_sqrt_nn(half_u) is glint_select(w, 0, half_u == 0) (kernels/compat.h): the select is
   * needed only in the rescaling below, where it is applied. */
  real w = glint_sqrt_nn_nonzero(half_u);
  real T = glint_select(GLINT_R(2.0) * c * (eta * k), c * u, t0 >= GLINT_R(0.0));
  /* The fractions are now of degree 2 in w, and their terms can be as small as ~w^4 (a2b2 is
   * between w^2 and 2 w^2, and t1 t3 >= ~a2b2 as c -> 0 or 1): below w ~ 2^-32 they reach the
   * fp32 subnormals, where numerator and denominator lose different digits (1e-5 to 1e-3 of F at
   * grazing c, tests/kernels/fresnel_test.cpp). So for w < 2^-24, w and T are scaled by 2^64
   * (exact; the fractions do not change); there a <= w and a2b2 <= 2 w^2 keep t1, t3 <= ~1, so
   * nothing overflows. w = 0 means a = 0 and T = 0: any positive w gives the exact
   * F = t1 t3 / (t1 t3) = 1 there (e.g. k = 0 at the critical angle), hence ws = 1.
   * Only a block with such a lane rescales (a uniform branch): w < 2^-24 needs eta k < ~2^-48
   * (w^2 >= a2b2 / 2 >= eta k), so for every material but a near-dielectric one no lane ever
   * does. Elsewhere scale = 1, ws = w and T * 1 = T: the same bits as rescaling every block,
   * for 2 instructions per channel instead of 7 (issue 13, session 19). The test is written so
   * that half_u = 0 (w NaN by the estimate, 0 exactly elsewhere) takes the rescaling too. */
  real ws = w;
  if (glint_any(!(w >= GLINT_R(5.9604644775390625e-8)))) {           /* 2^-24 */
    real w0 = glint_select(w, GLINT_R(0.0), half_u == GLINT_R(0.0)); /* glint_sqrt_nn(half_u) */
    glint_mask tiny = w0 < GLINT_R(5.9604644775390625e-8);
    real scale = glint_select(GLINT_R(1.0), GLINT_R(18446744073709551616.0), tiny); /* 2^64 */
    ws = glint_select(w0 * scale, GLINT_R(1.0), w0 <= GLINT_R(0.0));
    T = T * scale;
  }
  real t1w = (a2b2 + c2) * ws;           /* t1 w, t1 = a2b2 + c^2 */
  real t3w = (c2 * a2b2 + s2 * s2) * ws; /* t3 w */
  /* (Rs + Rp) / 2 = Rs (1 + (t3 - t4) / (t3 + t4)) / 2 = Rs t3 / (t3 + t4), t4 = 2 a c s^2,
   * here with every term times w: one division for both polarisations and for a. t3 > 0, so
   * no cancellation is added. Range: eta, k <= 1e6 (validation) give t1, t3 <= ~2e12 and
   * w <= ~1.5e6, so numerator and denominator stay below ~1e37, inside the float range. */
  real f = (t1w - T) * t3w / ((t1w + T) * (t3w + T * s2));
  return clamp(f, GLINT_R(0.0), GLINT_R(1.0));
}

/* F_conductor_cos2 for c = cos_theta clamped to [0, 1] and c2 = c^2. */
GLINT_FN real F_conductor(real eta, real k, real cos_theta) {
  real c = clamp(cos_theta, GLINT_R(0.0), GLINT_R(1.0));
  return F_conductor_cos2(eta, k, c, c * c);
}

/* Exact unpolarised reflectance of a dielectric interface, light arriving
 * from the side with index 1 onto index `ior` (Walter et al. 2007 Eq. 22 in
 * the s/p amplitude form). ior < 1 can give total internal reflection. */
GLINT_FN real F_dielectric(real ior, real cos_theta) {
  real c = clamp(cos_theta, GLINT_R(0.0), GLINT_R(1.0));
  real sin2_i = GLINT_R(1.0) - c * c;
  real ior2 = ior * ior;
  /* Total internal reflection (F = 1) when sin^2(theta_t) = sin2_i / ior^2 >= 1, tested without
   * the division: ior^2 underflows to 0 for ior < ~1e-19 in fp32, and 0 / 0 at normal
   * incidence made F NaN (issue 8). Then every angle is TIR, which is the exact limit
   * F -> 1 as ior -> 0 (F(1) = ((1 - ior) / (1 + ior))^2). */
  glint_mask tir = sin2_i >= ior2;
  real sin2_t = sin2_i / glint_select(ior2, GLINT_R(1.0), tir);
  real cos_t = sqrt(glint_select(GLINT_R(1.0) - sin2_t, GLINT_R(0.0), tir));
  real rs = (c - ior * cos_t) / (c + ior * cos_t);
  real rp = (ior * c - cos_t) / (ior * c + cos_t);
  return glint_select(GLINT_R(0.5) * (rs * rs + rp * rp), GLINT_R(1.0), tir);
}

/* params: schlick (f0.rgb), conductor (eta.rgb, k.rgb), dielectric (ior). */
typedef struct {
  int kind;
  real3 a; /* f0 or eta, or (ior, ior, ior) */
  real3 b; /* k for conductors */
} FresnelParams;

GLINT_FN real3 fresnel_eval(FresnelParams p, real cos_theta) {
  if (p.kind == GLINT_FRESNEL_CONDUCTOR) {
    return make_real3(F_conductor(p.a.x, p.b.x, cos_theta), F_conductor(p.a.y, p.b.y, cos_theta),
                      F_conductor(p.a.z, p.b.z, cos_theta));
  }
  if (p.kind == GLINT_FRESNEL_DIELECTRIC) {
    real f = F_dielectric(p.a.x, cos_theta);
    return make_real3(f, f, f);
  }
  return make_real3(F_schlick(p.a.x, cos_theta), F_schlick(p.a.y, cos_theta),
                    F_schlick(p.a.z, cos_theta));
}

/* fresnel_eval for c = cos_theta in [0, 1] given with c2, c^2 up to a rounding (the conductor's
 * roots need c^2 only: kernels/smooth_brdf.h computes it without a root). */
GLINT_FN real3 fresnel_eval_cos2(FresnelParams p, real c, real c2) {
  if (p.kind == GLINT_FRESNEL_CONDUCTOR) {
    return make_real3(F_conductor_cos2(p.a.x, p.b.x, c, c2), F_conductor_cos2(p.a.y, p.b.y, c, c2),
                      F_conductor_cos2(p.a.z, p.b.z, c, c2));
  }
  return fresnel_eval(p, c);
}

#endif /* GLINT_FRESNEL_H */
