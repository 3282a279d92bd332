/* Lookup in our LTC tables (tools/ltc/, data/ltc/; layout in
 * tools/ltc/README.md): 64 x 64 entries of 8 floats over sqrt(alpha) and
 * sqrt(1 - cos theta_o): M^-1 (4), magnitude, Schlick moment, D_PR, D_H.
 * Used by the LTC and Lecocq area methods and the binomial glint model. The
 * table is a `__global const float *` buffer on the device (portable beyond
 * PoCL's large __constant space), the checked-in arrays on the host. */
#ifndef GLINT_LTC_LOOKUP_H
#define GLINT_LTC_LOOKUP_H

#include "kernels/compat.h"
#include "kernels/layout.h"
#include "kernels/smooth_brdf.h"

/* Bilinear lookup of one LTC table entry (data/ltc/ltc_table.h lookup):
 * x = sqrt(alpha) * 63, y = sqrt(1 - cos(theta_o)) * 63, clamped to the grid. */
GLINT_FN void area_ltc_lookup(const GLINT_GLOBAL float *table, real alpha, real cos_o,
                              GLINT_PRIVATE real *e) {
  const real last = (real)(GLINT_LTC_GRID - 1);
  real x = clamp(sqrt(fmax(alpha, GLINT_R(0.0))), GLINT_R(0.0), GLINT_R(1.0)) * last;
  real y = clamp(sqrt(fmax(GLINT_R(1.0) - cos_o, GLINT_R(0.0))), GLINT_R(0.0), GLINT_R(1.0)) * last;
  int a0 = (int)x, t0 = (int)y;
  a0 = a0 > GLINT_LTC_GRID - 2 ? GLINT_LTC_GRID - 2 : a0;
  t0 = t0 > GLINT_LTC_GRID - 2 ? GLINT_LTC_GRID - 2 : t0;
  real fx = x - (real)a0, fy = y - (real)t0;
  const GLINT_GLOBAL float *e00 = table + (t0 * GLINT_LTC_GRID + a0) * GLINT_LTC_ENTRY;
  const GLINT_GLOBAL float *e10 = e00 + GLINT_LTC_ENTRY;
  const GLINT_GLOBAL float *e01 = e00 + GLINT_LTC_GRID * GLINT_LTC_ENTRY;
  const GLINT_GLOBAL float *e11 = e01 + GLINT_LTC_ENTRY;
  for (int k = 0; k < GLINT_LTC_ENTRY; ++k) {
    e[k] = (GLINT_R(1.0) - fy) * ((GLINT_R(1.0) - fx) * (real)e00[k] + fx * (real)e10[k]) +
           fy * ((GLINT_R(1.0) - fx) * (real)e01[k] + fx * (real)e11[k]);
  }
}

/* The Fresnel-weighted albedo int f cos_i F dwi of table entry e: Schlick
 * f0 * magnitude + (1 - f0) * moment (exact for the albedo). Conductor and
 * dielectric: APPROXIMATION, the exact Fresnel is replaced by Schlick's
 * through its normal-incidence value F(1) (Schlick 1994 Eq. 15); the tables
 * hold no moment for exact Fresnel. */
GLINT_FN real3 area_ltc_albedo(SmoothMaterial m, const GLINT_PRIVATE real *e) {
  real3 f0 = m.fresnel.a;
  if (m.fresnel.kind != GLINT_FRESNEL_SCHLICK) f0 = fresnel_eval(m.fresnel, GLINT_R(1.0));
  return make_real3(f0.x * e[4] + (GLINT_R(1.0) - f0.x) * e[5],
                    f0.y * e[4] + (GLINT_R(1.0) - f0.y) * e[5],
                    f0.z * e[4] + (GLINT_R(1.0) - f0.z) * e[5]);
}

#endif /* GLINT_LTC_LOOKUP_H */
