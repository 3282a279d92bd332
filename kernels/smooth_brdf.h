/* The smooth microfacet BRDF, the reference every glint model converges to:
 *   f(wi, wo) = F(wo.h) G2(wo, wi) D(h) / (4 cos_i cos_o)
 * (Walter et al. 2007 Eq. 20; Cook & Torrance 1982), GGX or Beckmann D,
 * height-correlated Smith G2, Schlick / conductor / dielectric Fresnel. */
#ifndef GLINT_SMOOTH_BRDF_H
#define GLINT_SMOOTH_BRDF_H

#include "kernels/compat.h"
#include "kernels/fresnel.h"
#include "kernels/ndf.h"

typedef struct {
  int ndf;
  real alpha_x;
  real alpha_y;
  FresnelParams fresnel;
} SmoothMaterial;

/* The packed material block: kernels/layout.h (GLINT_MATERIAL_FLOATS). */

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

#ifdef __OPENCL_VERSION__
/* The same block passed by value (kernels/kernel_args.h `material_values`): the same floats, so
 * the same material as smooth_material_unpack of the buffer. */
GLINT_FN SmoothMaterial smooth_material_from_values(float8 packed, int ndf, int fresnel_kind) {
  SmoothMaterial m;
  m.ndf = ndf;
  m.alpha_x = (real)packed.s0;
  m.alpha_y = (real)packed.s1;
  m.fresnel.kind = fresnel_kind;
  m.fresnel.a = make_real3((real)packed.s2, (real)packed.s3, (real)packed.s4);
  m.fresnel.b = make_real3((real)packed.s5, (real)packed.s6, (real)packed.s7);
  return m;
}
#endif

/* smooth_reflect_cos with its unit half-vector h and D(h), for callers that
 * reuse them (the glint models' D_star = D S: models/kemppinen/kemppinen_eval.h
 * would otherwise normalise h and evaluate D a second time per light). In
 * lanes where `fc` is 0 because a direction is at or below the horizon (dead
 * lanes), h is wi + wo unnormalised (finite, 0 when wi = -wo) and D is ndf_D
 * of that h, which need NOT be finite: with wi on the horizon and wo grazing,
 * h is a tiny near-vertical vector, GGX's q^2 underflows (fp32) and D is
 * +Inf. fc itself is selected to 0 in those lanes, every operation is per
 * lane, and callers select the lanes away (kemppinen_reflect_at by its `live`
 * mask), so a dead lane's D never reaches a live result; a caller that uses D
 * must not combine lanes before dropping the dead ones.
 * Directions are unit vectors in the local frame (see smooth_reflect_cos). */
typedef struct {
  real3 fc; /* f(wi, wo) cos(theta_i), RGB */
  real3 h;
  real D;
} SmoothReflect;

/* What smooth_reflect_cos needs of wo alone: a query's light loop computes it once instead of
 * once per light (models/smooth/smooth_eval.h; GGX's r_o is a square root per light and block,
 * Beckmann's wo.z Lambda(wo) an exp and an erfc). The same operations as computed inside, so the
 * same bits. */
typedef struct {
  real3 wo;
  real zo;  /* GGX: max(wo.z, 0) */
  real r_o; /* GGX: ggx_view_root(wo) */
  real zlo; /* Beckmann: wo.z Lambda(wo) (ndf_z_lambda) */
} SmoothView;

GLINT_FN SmoothView smooth_view(SmoothMaterial m, real3 wo) {
  SmoothView v;
  v.wo = wo;
  v.zo = GLINT_R(0.0);
  v.r_o = GLINT_R(0.0);
  v.zlo = GLINT_R(0.0);
  if (m.ndf == GLINT_NDF_BECKMANN) {
    v.zlo = ndf_z_lambda(m.ndf, wo, m.alpha_x, m.alpha_y);
  } else {
    v.zo = glint_fmax_nn(wo.z, GLINT_R(0.0));
    v.r_o = ggx_view_root(wo, m.alpha_x, m.alpha_y);
  }
  return v;
}

/* has_view (a constant): 1 when v was prepared by smooth_view, 0 when only v.wo is set and the
 * rest is computed here, after the early exit, in the order the single-direction callers (probes,
 * the glint models) had before smooth_view existed (llvm-mca: the probe block's schedule moved
 * 256 -> 283 cycles when r_o came first). */
GLINT_FN SmoothReflect smooth_reflect_cos_parts_with(SmoothMaterial m, SmoothView v, real3 wi,
                                                     int has_view) {
  real3 wo = v.wo;
  SmoothReflect r;
  real3 h = r3_add(wi, wo);
  real hh = r3_dot(h, h);
  /* Branch-free: every lane computes, dead ones (either direction at or below
   * the horizon, or wi = -wo) use |h| = 1 so that h stays finite, and give
   * fc = 0 (their D may be +Inf: see SmoothReflect). */
  glint_mask dead = (wi.z <= GLINT_R(0.0)) | (wo.z <= GLINT_R(0.0)) | !(hh > GLINT_R(0.0));
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  /* No lane live: skip the rest (host: the early return). On the device this
   * pays off for coherent batches, e.g. +30-50% for a lit sphere where a light
   * is behind whole blocks, and costs ~10% on random queries (measured). */
  if (!glint_any(!dead)) {
    r.fc = zero;
    r.h = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
    r.D = GLINT_R(0.0);
    return r;
  }
  real hh_live = glint_select(hh, GLINT_R(1.0), dead);
  real rs = glint_rsqrt_nn(hh_live);
  h = r3_scale(h, rs); /* no division */
  /* D is returned for callers that reuse it (the SMOOTH kernels do not: the compiler drops it). */
  real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
  if (!has_view) v = smooth_view(m, wo);
  /* D V cos_i: V alone overflows fp32 at cosines ~1e-36 (see ndf.h); GGX in one division. */
  real DV_cos_i = m.ndf == GLINT_NDF_BECKMANN
                      ? D * smith_visibility_cos_i_view(m.ndf, wo, v.zlo, wi, m.alpha_x, m.alpha_y)
                      : ggx_D_visibility_cos_i_view(h, v.zo, v.r_o, wi, m.alpha_x, m.alpha_y);
  /* Dead lanes get their 0 through the channels' common factor: one select instead of one per
   * channel. Every Fresnel here is finite and >= 0 in every lane (clamped, or from validated
   * f0 in [0, 1] and ior in (0, 1e6)), so F * 0 = +0, the zero the per-channel select gave. */
  DV_cos_i = glint_select(DV_cos_i, GLINT_R(0.0), dead);
  /* The Fresnel's cos theta_d = wo.h from |wi + wo| alone: for unit wi and wo,
   * wo.(wi + wo) = 1 + wo.wi = |wi + wo|^2 / 2, so wo.h = |wi + wo| / 2 and cos^2 = hh / 4.
   * cos^2, all the conductor's roots need, is then one product after hh instead of after h's
   * root, its scaling and a dot product (~50 cycles off the block's longest chain, issue 13).
   * For directions of lengths^2 1 + 2 d_o and 1 + 2 d_i (normalised to a few ulp), hh / 4 is
   * cos^2 (1 + d_o + d_i): a relative error independent of the angle, where wo.h carried
   * (d_o - d_i) / (2 cos^2). Neither is smaller everywhere (this one at grazing theta_d, the
   * old one where d_o ~ d_i and cos^2 > 1/2); both are a few ulp: over 1M probes the error
   * against the fp64 host path went median 2.00e-7 -> 2.04e-7, max 2.19e-5 -> 2.27e-5
   * (models/smooth/README.md, session 19). The bound 1 only catches hh's rounding above 4
   * (wi = wo). */
  real cd2 = glint_fmin_nn(GLINT_R(0.25) * hh_live, GLINT_R(1.0));
  real cd = glint_fmin_nn(GLINT_R(0.5) * (hh_live * rs), GLINT_R(1.0));
  real3 F = fresnel_eval_cos2(m.fresnel, cd, cd2);
  r.fc = r3_scale(F, DV_cos_i);
  r.h = h;
  r.D = D;
  return r;
}

GLINT_FN SmoothReflect smooth_reflect_cos_parts(SmoothMaterial m, real3 wi, real3 wo) {
  SmoothView v;
  v.wo = wo;
  v.zo = GLINT_R(0.0);
  v.r_o = GLINT_R(0.0);
  v.zlo = GLINT_R(0.0);
  return smooth_reflect_cos_parts_with(m, v, wi, 0);
}

/* f(wi, wo) * cos(theta_i): the radiance reflected towards wo under unit
 * irradiance arriving from wi (the "BRDF probe" of the wire contract).
 * Directions are unit vectors in the local frame. Returns 0 when either is at
 * or below the horizon: a one-sided reflector has no transmission lobe. */
GLINT_FN real3 smooth_reflect_cos(SmoothMaterial m, real3 wi, real3 wo) {
  return smooth_reflect_cos_parts(m, wi, wo).fc;
}

/* smooth_reflect_cos for a view prepared once (smooth_view): the same bits. */
GLINT_FN real3 smooth_reflect_cos_view(SmoothMaterial m, SmoothView v, real3 wi) {
  return smooth_reflect_cos_parts_with(m, v, wi, 1).fc;
}

#endif /* GLINT_SMOOTH_BRDF_H */
