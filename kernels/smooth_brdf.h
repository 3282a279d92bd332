/* The smooth microfacet BRDF, the reference every glint model converges to:
 *   f(wi, wo) = F(wo.h) G2(wo, wi) D(h) / (4 cos_i cos_o)
 * (Walter et al. 2007 Eq. 20; Cook & Torrance 1982), GGX or Beckmann D,
 * height-correlated Smith G2, Schlick / conductor / dielectric Fresnel. */
#ifndef GLINT_SMOOTH_BRDF_H
#define GLINT_SMOOTH_BRDF_H

#include "compat.h"
#include "fresnel.h"
#include "ndf.h"

typedef struct {
  int ndf;
  real alpha_x;
  real alpha_y;
  FresnelParams fresnel;
} SmoothMaterial;

/* Number of floats in the packed material block (host -> device):
 * [alpha_x, alpha_y, a.r, a.g, a.b, b.r, b.g, b.b]. */
#define GLINT_MATERIAL_FLOATS 8

GLINT_FN SmoothMaterial smooth_material_unpack(const GLINT_GLOBAL float *packed, int ndf,
                                               int fresnel_kind) {
  SmoothMaterial m;
  m.ndf = ndf;
  m.alpha_x = (real)packed[0];
  m.alpha_y = (real)packed[1];
  m.fresnel.kind = fresnel_kind;
  m.fresnel.a = make_real3((real)packed[2], (real)packed[3], (real)packed[4]);
  m.fresnel.b = make_real3((real)packed[5], (real)packed[6], (real)packed[7]);
  return m;
}

/* f(wi, wo) * cos(theta_i): the radiance reflected towards wo under unit
 * irradiance arriving from wi (the "BRDF probe" of the wire contract).
 * Directions are unit vectors in the local frame. Returns 0 when either is at
 * or below the horizon: a one-sided reflector has no transmission lobe. */
GLINT_FN real3 smooth_reflect_cos(SmoothMaterial m, real3 wi, real3 wo) {
  if (wi.z <= R(0.0) || wo.z <= R(0.0)) return make_real3(R(0.0), R(0.0), R(0.0));
  real3 h = wi + wo;
  real h_len = length(h);
  if (!(h_len > R(0.0))) return make_real3(R(0.0), R(0.0), R(0.0));
  h = h / h_len;
  real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
  real V = smith_visibility_correlated(m.ndf, wo, wi, m.alpha_x, m.alpha_y);
  real3 F = fresnel_eval(m.fresnel, dot(wo, h));
  return F * (D * V * wi.z);
}

#endif /* GLINT_SMOOTH_BRDF_H */
