/* Lookup in our LTC tables (tools/ltc/, data/ltc/; layout in
 * tools/ltc/README.md): 64 x 64 entries of 8 floats over sqrt(alpha) and
 * sqrt(1 - cos theta_o): M^-1 (4), magnitude, Schlick moment, D_PR, D_H.
 * Used by the LTC and Lecocq area methods and the binomial glint model. The
 * table is a `__global const float *` buffer on the device (portable beyond
 * PoCL's large __constant space), the checked-in arrays on the host. */
#ifndef GLINT_LTC_LOOKUP_H
#define GLINT_LTC_LOOKUP_H

#include "kernels/area/unroll.h"
#include "kernels/compat.h"
#include "kernels/layout.h"
#include "kernels/smooth_brdf.h"

#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
/* One lane's scalar type, one table entry as a vector of that type, and the
 * load of GLINT_LANES scalars into a `real`. */
#if GLINT_LTC_ENTRY != 8
#error "the lane lookup loads an LTC entry as 8 floats"
#endif
#if GLINT_USE_DOUBLE
#define GLINT_LANE_SCALAR double
#define GLINT_ENTRY_VEC double8
#define GLINT_ENTRY_LOAD(p) convert_double8(vload8(0, p))
#define GLINT_SHUFFLE_MASK ulong8
#else
#define GLINT_LANE_SCALAR float
#define GLINT_ENTRY_VEC float8
#define GLINT_ENTRY_LOAD(p) vload8(0, p)
#define GLINT_SHUFFLE_MASK uint8
#endif
/* Lane values to and from glint_mask's integer vectors (the cell indices). */
#if GLINT_LANES == 8
#define GLINT_LANE_VLOAD vload8
#if GLINT_USE_DOUBLE
#define GLINT_LANE_TO_INT(v) convert_long8(v)
#define GLINT_LANE_FROM_INT(v) convert_double8(v)
#else
#define GLINT_LANE_TO_INT(v) convert_int8(v)
#define GLINT_LANE_FROM_INT(v) convert_float8(v)
#endif
#else
#define GLINT_LANE_VLOAD vload16
#if GLINT_USE_DOUBLE
#define GLINT_LANE_TO_INT(v) convert_long16(v)
#define GLINT_LANE_FROM_INT(v) convert_double16(v)
#else
#define GLINT_LANE_TO_INT(v) convert_int16(v)
#define GLINT_LANE_FROM_INT(v) convert_float16(v)
#endif
#endif
#endif

#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
/* out[c] = component c of the 8 entries r[0..7] (an 8 x 8 transpose) in three rounds of
 * shuffles: pairs of lanes, then quadruples, then halves. */
GLINT_FN void area_ltc_transpose8(const GLINT_PRIVATE GLINT_ENTRY_VEC *r,
                                  GLINT_PRIVATE GLINT_ENTRY_VEC *out) {
  GLINT_ENTRY_VEC p[8], q[8];
  GLINT_UNROLL for (int j = 0; j < 8; j += 2) {
    p[j] = shuffle2(r[j], r[j + 1], (GLINT_SHUFFLE_MASK)(0, 8, 2, 10, 4, 12, 6, 14));
    p[j + 1] = shuffle2(r[j], r[j + 1], (GLINT_SHUFFLE_MASK)(1, 9, 3, 11, 5, 13, 7, 15));
  }
  /* p[0] = components 0,2,4,6 of lanes 0,1; p[1] = 1,3,5,7 of lanes 0,1; ... */
  GLINT_UNROLL for (int h = 0; h < 8; h += 4) {
    GLINT_UNROLL for (int o = 0; o < 2; ++o) {
      q[h + o] = shuffle2(p[h + o], p[h + 2 + o], (GLINT_SHUFFLE_MASK)(0, 1, 8, 9, 4, 5, 12, 13));
      q[h + 2 + o] =
          shuffle2(p[h + o], p[h + 2 + o], (GLINT_SHUFFLE_MASK)(2, 3, 10, 11, 6, 7, 14, 15));
    }
  }
  /* q[h + c] = components c and c + 4 (c = 0 .. 3) of lanes h .. h + 3. */
  GLINT_UNROLL for (int c = 0; c < 4; ++c) {
    out[c] = shuffle2(q[c], q[4 + c], (GLINT_SHUFFLE_MASK)(0, 1, 2, 3, 8, 9, 10, 11));
    out[c + 4] = shuffle2(q[c], q[4 + c], (GLINT_SHUFFLE_MASK)(4, 5, 6, 7, 12, 13, 14, 15));
  }
}
#endif

#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
/* The lanes' lookup from their alpha cells a0v and weights fxv and their
 * grid coordinate y (area_ltc_lookup below): each lane's four entries are a
 * gather, interpolated per lane with the same arithmetic as the scalar path
 * (so lanes equal it) over the 8 floats of an entry at once (vload8), then
 * transposed into one vector per entry component. */
GLINT_FN void area_ltc_lookup_cells(const GLINT_GLOBAL float *table, glint_mask a0v, real fxv,
                                    real y, GLINT_PRIVATE real *e) {
  glint_mask t0v = min(GLINT_LANE_TO_INT(y), (glint_mask)(GLINT_LTC_GRID - 2));
  real fyv = y - GLINT_LANE_FROM_INT(t0v);
  glint_mask off = (t0v * GLINT_LTC_GRID + a0v) * GLINT_LTC_ENTRY;
  GLINT_ENTRY_VEC r[GLINT_LANES];
  GLINT_UNROLL for (int j = 0; j < GLINT_LANES; ++j) {
    GLINT_LANE_SCALAR fx = fxv[j], fy = fyv[j];
    const GLINT_GLOBAL float *e00 = table + off[j];
    const GLINT_GLOBAL float *e01 = e00 + GLINT_LTC_GRID * GLINT_LTC_ENTRY;
    GLINT_ENTRY_VEC c00 = GLINT_ENTRY_LOAD(e00), c10 = GLINT_ENTRY_LOAD(e00 + GLINT_LTC_ENTRY);
    GLINT_ENTRY_VEC c01 = GLINT_ENTRY_LOAD(e01), c11 = GLINT_ENTRY_LOAD(e01 + GLINT_LTC_ENTRY);
    GLINT_LANE_SCALAR one = (GLINT_LANE_SCALAR)1.0;
    r[j] = (one - fy) * ((one - fx) * c00 + fx * c10) + fy * ((one - fx) * c01 + fx * c11);
  }
  /* r[j] holds lane j's entry; e[k] wants component k of every lane: 8 x 8 transposes in
   * shuffles (area_ltc_transpose8), for 16 lanes one per half joined by a concatenation,
   * instead of scalar stores to a private array read back as vectors, whose store-to-load
   * forwarding stalls (the 16-lane path did that until session 16: ~10% of the binomial lane
   * kernel's samples with one quad, perf annotate). Data movement only: the same bits. */
#if GLINT_LANES == 8
  area_ltc_transpose8(r, e);
#else
  GLINT_ENTRY_VEC lo[8], hi[8];
  area_ltc_transpose8(r, lo);
  area_ltc_transpose8(r + 8, hi);
  GLINT_UNROLL for (int c = 0; c < 8; ++c) e[c] = (real)(lo[c], hi[c]);
#endif
}
#endif

/* Bilinear lookup of one LTC table entry (data/ltc/ltc_table.h lookup):
 * x = sqrt(alpha) * 63, y = sqrt(1 - cos(theta_o)) * 63, clamped to the grid. */
GLINT_FN void area_ltc_lookup(const GLINT_GLOBAL float *table, real alpha, real cos_o,
                              GLINT_PRIVATE real *e) {
  const real last = (real)(GLINT_LTC_GRID - 1);
  real x = clamp(sqrt(fmax(alpha, GLINT_R(0.0))), GLINT_R(0.0), GLINT_R(1.0)) * last;
  real y = clamp(sqrt(fmax(GLINT_R(1.0) - cos_o, GLINT_R(0.0))), GLINT_R(0.0), GLINT_R(1.0)) * last;
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
  /* Lanes: the cells and weights of every lane at once (vector ops). */
  glint_mask a0v = min(GLINT_LANE_TO_INT(x), (glint_mask)(GLINT_LTC_GRID - 2));
  area_ltc_lookup_cells(table, a0v, x - GLINT_LANE_FROM_INT(a0v), y, e);
#else
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
#endif
}

/* area_ltc_lookup for an alpha that is the same in every lane (a material's:
 * the smooth model's LTC pass), given once as a scalar. Lanes: the alpha
 * cell and weight are computed once as scalars, with the same operations as
 * area_ltc_lookup's vector ones (sqrt, clamp, truncation, subtraction are
 * exact or correctly rounded alike on a scalar and a vector), so every lane
 * gets the same bits; then the compiler sees a uniform weight, and the
 * per-lane blend broadcasts only the cos theta_o weight (it extracted and
 * broadcast both per lane: the x cell came from a vector square root it did
 * not scalarise). Without lanes it is area_ltc_lookup. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
GLINT_FN void area_ltc_lookup_uniform_alpha(const GLINT_GLOBAL float *table,
                                            GLINT_LANE_SCALAR alpha, real cos_o,
                                            GLINT_PRIVATE real *e) {
  const GLINT_LANE_SCALAR last = (GLINT_LANE_SCALAR)(GLINT_LTC_GRID - 1);
  GLINT_LANE_SCALAR x = clamp(sqrt(fmax(alpha, (GLINT_LANE_SCALAR)0.0)), (GLINT_LANE_SCALAR)0.0,
                              (GLINT_LANE_SCALAR)1.0) *
                        last;
  int a0 = min((int)x, GLINT_LTC_GRID - 2);
  real y = clamp(sqrt(fmax(GLINT_R(1.0) - cos_o, GLINT_R(0.0))), GLINT_R(0.0), GLINT_R(1.0)) * last;
  area_ltc_lookup_cells(table, (glint_mask)a0, (real)(x - (GLINT_LANE_SCALAR)a0), y, e);
}
#else
GLINT_FN void area_ltc_lookup_uniform_alpha(const GLINT_GLOBAL float *table, real alpha, real cos_o,
                                            GLINT_PRIVATE real *e) {
  area_ltc_lookup(table, alpha, cos_o, e);
}
#endif

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
