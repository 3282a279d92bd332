/* The glinty NDF of Kemppinen, Paulin, Thonat, Thiery, Lehtinen, Boubekeur
 * 2025, "Evaluating and Sampling Glinty NDFs in Constant Time" ("K25"),
 * Sec. 3 and Algorithm 1:
 *
 *   D_star(x, h) = D(h) * S(x, h),                                   (Eq. 11)
 *
 * where S is the pixel-filtered density of facets near (x, T(h)) in the 4D
 * space uv x U (U = the unit square holding the disk image of the NDF):
 *
 *   S = sum_levels [ sum_{i in 2x2 spatial x k angular cells} GLINT_R(r_i, w_l)
 *                      N(x_s - g_s,i; Sigma_s) N(x_a - g_a,i; Sigma_a) / K_P
 *                    + w_l C_l ].
 *
 * Pieces, in the order of Algorithm 1:
 *  - T: the NDF mapped to the disk of radius 1/2 centred in [0,1]^2 (3.2.1
 *    GGX: microsurface stretch + Lambert's azimuthal projection, Eq. 6-7;
 *    3.2.2 Beckmann: Marsaglia's map, B1 and B2 inverted). kemppinen_to_disk.
 *  - The weight D(h) in place of |J_T| (footnote 2): with facets uniform in
 *    U, E[S] = 1 away from the disk edge, so E[D_star] = D (Eq. 2) whatever
 *    the map's Jacobian. The true Jacobian |J_T| (area of U per unit solid
 *    angle) only sets the lobe width. For Beckmann it is (pi/4) D cos, so the
 *    facets are distributed like the NDF; for GGX with Lambert's projection it
 *    is not proportional to D (see kemppinen_to_disk): the facets' density in
 *    solid angle then differs from D, which the weight D makes up for.
 *  - Facets: one per cell of an implicit 4D grid, res_s^2 res_a^2 = K_P
 *    (3.3.1-3.3.2), res_a = 2^l, res_s = sqrt(K_P) 2^-l; a facet's position
 *    and normal come from hashes of (seed, level, cell) with kernels/rng.h's
 *    mixer (kemppinen_mix, lane-wise), so they do not depend on batching.
 *    Facets outside the disk are rejected.
 *  - Gaussian pixel filter Sigma_s = f^2 J J^T (Eq. 5) from the uv Jacobian.
 *  - Facet lobe: Gaussian in U of covariance |J_T| (alpha_star A^-1)^2
 *    (Eq. 4 and Algorithm 1 line 12), A = diag(a, 1/a) the anisotropy.
 *  - k = n^2 explicit angular neighbour cells around x_a; the rest by the
 *    analytic compensation C (Eq. 9-10, erf over rectangles).
 *  - LOD: lambda from the footprint, two levels with tent weights; explicit
 *    facets by the mollified Russian roulette R (Eq. 8), compensation
 *    blended linearly (Fig. 5).
 *
 * Departures (models/kemppinen/README.md says why):
 *  - The level: lambda = log2(8 sigma_max sqrt(K_P)), so that the finer
 *    level's cells are at least 4 sigma_max wide and the 2x2 spatial block
 *    around the nearest vertex reaches >= 2 sigma beyond the query on every
 *    side (the shader's lambda = log2(|J| sqrt(N) f) + 2^f leaves ~1.5 sigma).
 *  - The compensation also covers the spatial truncation: C subtracts
 *    P_s * P_a(B) instead of P_a(B), P_s = the filter's mass in the spatial
 *    block (per axis, from the diagonal of Sigma_s: exact for axis-aligned
 *    footprints, an approximation of a small term otherwise).
 *  - GGX |J_T| uses the solid-angle Jacobian |M| / |M^T h|^3 of the stretch
 *    (K25 Eq. 6 prints exponent 4); see kemppinen_to_disk.
 *  - erf: Abramowitz & Stegun 7.1.26 (absolute error <= 1.5e-7); the
 *    rectangle masses use erfc on the far side of 0 so tails do not cancel.
 *
 * Lane-agnostic (kernels/compat.h): the loops have uniform trip counts (2
 * levels x 4 spatial x k angular cells), per-query cell indices are reals and
 * hash keys `kemp_uint` (uint, or uint16 on the 16-lane device), per-query
 * conditions are selects; a glint_any branch skips roulette-dropped facets. */
#ifndef GLINT_KEMPPINEN_NDF_H
#define GLINT_KEMPPINEN_NDF_H

#include "kernels/compat.h"
#include "kernels/ndf.h"
#include "kernels/rng.h"
#include "models/kemppinen/kemppinen_exp.h"
#include "models/kemppinen/kemppinen_params.h"

/* Unsigned hash keys of one query (uint) or of a block of GLINT_LANES queries
 * (uintN on the device), and conversions from the working precision. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES == 8
typedef uint8 kemp_uint;
#define KEMP_TO_UINT(x) convert_uint8(x)
#if GLINT_USE_DOUBLE
#define KEMP_TO_REAL(x) convert_double8(x)
#else
#define KEMP_TO_REAL(x) convert_float8(x)
#endif
#elif defined(__OPENCL_VERSION__) && GLINT_LANES == 16
typedef uint16 kemp_uint;
#define KEMP_TO_UINT(x) convert_uint16(x)
#if GLINT_USE_DOUBLE
#define KEMP_TO_REAL(x) convert_double16(x)
#else
#define KEMP_TO_REAL(x) convert_float16(x)
#endif
#else
typedef uint kemp_uint;
#define KEMP_TO_UINT(x) ((uint)(x))
#define KEMP_TO_REAL(x) ((real)(x))
#endif

/* kernels/rng.h's lowbias32 mixer and sponge absorb, on kemp_uint (the same
 * numbers as rng_mix / rng_absorb lane by lane). */
GLINT_FN kemp_uint kemppinen_mix(kemp_uint x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

GLINT_FN kemp_uint kemppinen_absorb(kemp_uint h, kemp_uint key) {
  return kemppinen_mix(h ^ (key + 0x9e3779b9u)) + 0x632be5abu;
}

/* K25 Eq. 8: epsilon of the mollified roulette ("0.1 for all our results"). */
#define GLINT_KEMPPINEN_ROULETTE_EPS 0.1f

typedef struct {
  real density;   /* K_P, facets per unit uv area */
  real micro;     /* alpha_star */
  real filter;    /* f */
  int n_side;     /* sqrt(k): angular cells per axis explicitly evaluated */
  real aniso;     /* a, A_star = diag(a, 1/a) */
  real inv_aniso; /* 1 / a: uniform, a product per lane instead of a division */
  /* The facets' colours (K25 3.3.6), uniform over the lanes: n_colors >= 1
   * RGB triples (one white one without colours) and their mean, the colour
   * of the compensation (each facet takes colour c with probability 1/n). */
  int n_colors;
  float colors[3 * GLINT_KEMPPINEN_MAX_COLORS];
  real3 mean_color;
  /* The neighbourhood (GLINT_KEMPPINEN_NEIGHBORHOOD_*, uniform per request):
   * one dithered MIP level instead of two, and the one spatial cell holding
   * the query instead of the 2x2 block (kemppinen_query_levels says why both
   * keep E[S] = 1). */
  int one_level;
  int one_cell;
  /* One colour, (1, 1, 1) (no `colors`: the usual case): the point pass sums the facets'
   * weights in one channel (kemppinen_level_facet_add); 1 * w = w, so the same bits. */
  int white;
} KemppinenParams;

GLINT_FN KemppinenParams kemppinen_params_unpack(const GLINT_GLOBAL float *packed) {
  KemppinenParams p;
  p.density = (real)packed[GLINT_KEMPPINEN_DENSITY];
  p.micro = (real)packed[GLINT_KEMPPINEN_MICRO];
  p.filter = (real)packed[GLINT_KEMPPINEN_FILTER];
  int k = (int)packed[GLINT_KEMPPINEN_NEIGHBORS];
  p.n_side = k >= 16 ? 4 : k >= 9 ? 3 : k >= 4 ? 2 : 1;
  p.aniso = (real)packed[GLINT_KEMPPINEN_ANISO];
  /* Uniform: a scalar division (kernels/compat.h GLINT_UNIFORM), the same bits. */
  p.inv_aniso = (real)((real_scalar)1.0 / GLINT_UNIFORM(p.aniso));
  int n = (int)packed[GLINT_KEMPPINEN_N_COLORS];
  n = n > GLINT_KEMPPINEN_MAX_COLORS ? GLINT_KEMPPINEN_MAX_COLORS : n;
  p.n_colors = n >= 1 ? n : 1;
  /* Once per work-item on the device (per block of 16 queries): only the n_colors triples
   * that are read, summed per channel in the same order as before; the unused entries are 0.
   * The former loop over all 24 floats with i % 3 ran as scalar code with a branch per float,
   * ~2% of the ONE_CELL kernel's time (perf annotate). */
  for (int i = 0; i < 3 * GLINT_KEMPPINEN_MAX_COLORS; ++i) p.colors[i] = 0.0f;
  float sum[3] = {0.0f, 0.0f, 0.0f};
  for (int j = 0; j < p.n_colors; ++j) {
    for (int c = 0; c < 3; ++c) {
      float v = n >= 1 ? packed[GLINT_KEMPPINEN_COLORS + 3 * j + c] : 1.0f;
      p.colors[3 * j + c] = v;
      sum[c] += v;
    }
  }
  real inv_n = (real)((real_scalar)1.0 / (real_scalar)p.n_colors);
  p.mean_color = make_real3((real)sum[0] * inv_n, (real)sum[1] * inv_n, (real)sum[2] * inv_n);
  int hood = (int)packed[GLINT_KEMPPINEN_NEIGHBORHOOD];
  p.one_level = hood >= GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL;
  p.one_cell = hood >= GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL;
  p.white = p.n_colors == 1 && p.colors[0] == 1.0f && p.colors[1] == 1.0f && p.colors[2] == 1.0f;
  return p;
}

/* ---------------------------------------------------------------- the map T */

/* x_a = T(h) in [0,1]^2 (the disk of radius 1/2 centred at (1/2, 1/2)) and
 * |J_T(h)|, the area of U per unit solid angle, for a unit h with D = D(h). */
typedef struct {
  real x, y;
  real jac;
} DiskPoint;

GLINT_FN DiskPoint kemppinen_to_disk(int ndf, real3 h, real ax, real ay, real D) {
  DiskPoint p;
  real hz = fmax(h.z, GLINT_R(0.0));
  if (ndf == GLINT_NDF_BECKMANN) {
    /* K25 3.2.2: B2^-1 takes h to its slope m = (hx, hy) / hz; B1^-1 takes the
     * slope, scaled to t = (mx / ax, my / ay), to the unit disk at radius
     * r = sqrt(1 - exp(-|t|^2)) (Marsaglia 1962: uniform r^2 in [0, 1) gives
     * |t|^2 exponential, i.e. Gaussian slopes, the Beckmann distribution).
     * q = |t|^2 with the division by hz^2 last (kernels/ndf.h D_beckmann). */
    real sx = h.x / ax, sy = h.y / ay;
    real s2 = sx * sx + sy * sy;
    real q = s2 / (hz * hz);
    /* Direction times radius: for q < 1 as (sx, sy) / hz * sqrt((1 - e^-q) / q)
     * (no 0/0 at the pole), else as (sx, sy) / |s| * sqrt(1 - e^-q) (no
     * overflow at grazing h). */
    real small = sqrt(-expm1(-q) / fmax(q, GLINT_R(1e-30))) / fmax(hz, GLINT_R(1e-30));
    small = glint_select(small, GLINT_R(1.0) / fmax(hz, GLINT_R(1e-30)), q < GLINT_R(1e-12));
    real large = sqrt(-expm1(-fmin(q, GLINT_R(80.0)))) / sqrt(fmax(s2, GLINT_R(1e-38)));
    real scale = glint_select(large, small, q < GLINT_R(1.0));
    p.x = GLINT_R(0.5) + GLINT_R(0.5) * sx * scale;
    p.y = GLINT_R(0.5) + GLINT_R(0.5) * sy * scale;
    /* Uniform measure on the disk (area pi/4) <-> the normal pdf D cos dw. */
    p.jac = GLINT_R(0.25) * GLINT_PI * D * hz;
  } else {
    /* K25 3.2.1, Eq. 6: the stretch M^T = diag(1/ax, 1/ay, 1) takes GGX
     * normals to the unit hemisphere (n = M^T h / |M^T h|). Written as
     * s = (hx ay, hy ax, hz ax ay) = ax ay M^T h, so tiny alphas do not
     * overflow. Eq. 7: Lambert's projection (x, y) / sqrt(1 + z), equal area
     * up to a factor 1/2, then the factor 1/2 into the radius-1/2 disk.
     * |J_T| = (1/8) |J_M|, and the solid-angle Jacobian of h -> n is
     * |M| / |M^T h|^3 (the exponent is 3, as for any normalised linear map,
     * Heitz et al. 2016 Eq. 18; K25 Eq. 6 prints 4, which is pi D(h) instead:
     * the two differ by |M^T h| = hz / nz). With |M^T h| = len / (ax ay):
     *   |J_T| = (ax ay)^2 / (8 len^3).
     * Checked against finite differences of T in the tests. */
    real3 s = make_real3(h.x * ay, h.y * ax, hz * ax * ay);
    real len = fmax(r3_length(s), GLINT_R(1e-30));
    real nz = s.z / len;
    real k = GLINT_R(0.5) / (len * sqrt(GLINT_R(1.0) + nz));
    p.x = GLINT_R(0.5) + s.x * k;
    p.y = GLINT_R(0.5) + s.y * k;
    real axy = ax * ay / len;
    p.jac = GLINT_R(0.125) * axy * axy / len;
  }
  return p;
}

/* T^-1 (kemppinen_to_disk inverted): a point of the unit square to the unit
 * half-vector h; valid only inside the disk of radius 1/2 about (1/2, 1/2)
 * (returns h.z = 0 outside). One query per call (GLINT_LANES == 1: it
 * branches on the point). */
#if !defined(__OPENCL_VERSION__) || GLINT_LANES == 1
GLINT_FN real3 kemppinen_from_disk(int ndf, real x, real y, real ax, real ay) {
  real dx = GLINT_R(2.0) * (x - GLINT_R(0.5)), dy = GLINT_R(2.0) * (y - GLINT_R(0.5));
  real d2 = dx * dx + dy * dy;
  real3 none = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  if (!(d2 < GLINT_R(1.0))) return none;
  if (ndf == GLINT_NDF_BECKMANN) {
    /* K25 3.2.2 (B2 o B1): r^2 = 1 - exp(-|t|^2), t = d sqrt(-ln(1 - r^2)) / r
     * (-> d as r -> 0), slope = (ax tx, ay ty), h = (slope, 1) / |.|. */
    real q = -log1p(-d2);
    real scale = d2 > GLINT_R(1e-12) ? sqrt(q / d2) : GLINT_R(1.0);
    return r3_normalize(make_real3(ax * dx * scale, ay * dy * scale, GLINT_R(1.0)));
  }
  /* K25 3.2.1: inverse Lambert projection n = (d sqrt(2 - |d|^2), 1 - |d|^2),
   * then the inverse stretch h ~ M^-T n = (ax nx, ay ny, nz) (kemppinen_to_disk
   * writes the stretch as ax ay M^T h). */
  real k = sqrt(GLINT_R(2.0) - d2);
  return r3_normalize(make_real3(ax * dx * k, ay * dy * k, GLINT_R(1.0) - d2));
}
#endif

/* ------------------------------------------------------- Gaussian rectangles */

/* erfc(|x| / sqrt 2): the one special function of the rectangle masses, by
 * Abramowitz & Stegun 7.1.26 (Hastings): erfc(y) = t (a1 + t (a2 + ...)) e^-y^2,
 * t = 1 / (1 + p y), |absolute error| <= 1.5e-7 for y >= 0 (their bound;
 * measured against libm in the tests). An absolute bound suffices: the masses
 * enter S, whose mean is 1, as absolute terms. Cheaper than the libm erfc on
 * the device (one exp, one division; 12 per level and light). */
/* The rational factor t (a1 + t (a2 + ...)) for y = |x| / sqrt 2, so that
 * erfc(y) = it times exp(-y^2); callers that also need the normal density
 * phi(x) = exp(-y^2) / sqrt(2 pi) share the exp (kemppinen_image.h). */
GLINT_FN real kemppinen_erfc_abs_poly(real x) {
  real y = fabs(x) * GLINT_R(0.70710678118654752440);
  real t = GLINT_R(1.0) / (GLINT_R(1.0) + GLINT_R(0.3275911) * y);
  /* Horner's steps fused in the point pass's device entry (kernels/compat.h glint_fma_fast;
   * elsewhere a product and a sum, the same bits as a + t (...)): one rounding per step, against
   * the formula's 1.5e-7. */
  real p = glint_fma_fast(t, GLINT_R(1.061405429), GLINT_R(-1.453152027));
  p = glint_fma_fast(t, p, GLINT_R(1.421413741));
  p = glint_fma_fast(t, p, GLINT_R(-0.284496736));
  p = glint_fma_fast(t, p, GLINT_R(0.254829592));
  return t * p;
}

GLINT_FN real kemppinen_erfc_abs(real x) {
  real y = fabs(x) * GLINT_R(0.70710678118654752440);
  return kemppinen_erfc_abs_poly(x) * exp(-y * y);
}

/* The same for |x| <= 6 (kemppinen_erfc4_with clamps at its cut): y^2 <= 18, inside
 * kemppinen_exp_neg's domain (models/kemppinen/kemppinen_exp.h: the same bits as exp in the
 * point pass's device entry, with fewer instructions). */
GLINT_FN real kemppinen_erfc_abs_cut(real x) {
  real y = fabs(x) * GLINT_R(0.70710678118654752440);
  return kemppinen_erfc_abs_poly(x) * kemppinen_exp_neg(y * y);
}

/* The same by Abramowitz & Stegun 7.1.27: erfc(y) = (1 + a1 y + a2 y^2 +
 * a3 y^3 + a4 y^4)^-4, |absolute error| <= 5e-4 for y >= 0 (their bound;
 * measured against libm in the tests), no exp: the erfc of the cheaper
 * neighbourhoods (GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL / ONE_CELL), where
 * the compensation's 4 erfc per light and level and P_s's 4 per level would
 * otherwise cost more than their explicit facets (an exp each on the PoCL
 * CPU device; models/kemppinen/README.md "Neighbourhood"). */
/* Its denominator (1 + a1 y + ... + a4 y^4)^4 at y = |x| / sqrt 2, written in z = |x| clamped to
 * `zmax` (callers that zero erfc beyond a cut clamp there, so that four of them multiply without
 * overflow: kemppinen_erfc4_with): 1 + b1 z + ... + b4 z^4 with b_k = a_k 2^(-k/2), the same
 * polynomial without the product by 1 / sqrt 2 per erfc (12 per 16-query block in ONE_CELL k = 1
 * with two lights; session 20). The b_k are A&S's six-digit a_k scaled exactly (b2, b4 exact
 * halvings and quarterings, b1, b3 to 17 digits), so the approximation and its bound are A&S's;
 * only the rounding of the scaled constants and of z (exact) instead of y (one rounding) changes,
 * far below 5e-4 (CheapErfc tests, unchanged bounds). */
GLINT_FN real kemppinen_erfc_cheap_denominator(real x, real zmax) {
  real z = glint_fmin_nn(fabs(x), zmax);
  /* Horner's steps fused in the point pass's 16-lane device entry (kernels/compat.h
   * glint_fma_fast: one rounding instead of two per step, far below the formula's 5e-4), a
   * product and a sum elsewhere. */
  real d = glint_fma_fast(
      z,
      glint_fma_fast(
          z,
          glint_fma_fast(z, glint_fma_fast(z, GLINT_R(0.019527), GLINT_R(3.4365389565666203e-4)),
                         GLINT_R(0.1151945)),
          GLINT_R(0.19685357813486650)),
      GLINT_R(1.0));
  real d2 = d * d;
  return d2 * d2;
}

GLINT_FN real kemppinen_erfc_abs_cheap(real x) {
  return GLINT_R(1.0) / kemppinen_erfc_cheap_denominator(x, GLINT_R(3.0e38));
}

/* Phi(b) - Phi(a) for a <= b (standard normal) from ea = erfc(|a| / sqrt 2)
 * and eb = erfc(|b| / sqrt 2), i.e. from erfc on the side away from 0, so
 * neither tail cancels (the compensation subtracts masses ~1): right of 0
 * (ea - eb) / 2, left of 0 (eb - ea) / 2, across 0 1 - (ea + eb) / 2. */
GLINT_FN real kemppinen_mass_e(real a, real b, real ea, real eb) {
  real m = glint_select(GLINT_R(1.0) - GLINT_R(0.5) * (ea + eb), GLINT_R(0.5) * (eb - ea),
                        b <= GLINT_R(0.0));
  return glint_select(m, GLINT_R(0.5) * (ea - eb), a >= GLINT_R(0.0));
}

GLINT_FN real kemppinen_mass(real a, real b) {
  return kemppinen_mass_e(a, b, kemppinen_erfc_abs(a), kemppinen_erfc_abs(b));
}

/* ------------------------------------------------------------- the footprint */

/* log2(x) for a positive normal x (the MIP level lambda, once per query). fp32:
 * not the device's log2, which PoCL calls out of line (~190 instructions, and
 * every vector register spilled around the call: ~5% of the ONE_CELL
 * directional + point kernel's time, perf). x = m 2^e with m in [sqrt(1/2),
 * sqrt(2)) from the bits, then the atanh series
 *   log2(m) = (2 / ln 2) (s + s^3 / 3 + s^5 / 5 + s^7 / 7 + s^9 / 9 + ...),
 *   s = (m - 1) / (m + 1), |s| <= 3 - 2 sqrt 2 = 0.1716,
 * truncated after s^9: error <= (2 / ln 2) s^11 / 11 / (1 - s^2) = 1.0e-9, far
 * below the fp32 roundings (m - 1 is exact, s ~2 roundings, the series ~3,
 * e + log2(m) one: <= 1.5e-7 + 1/2 ulp of the result; tested against long
 * double, FastLog2.WithinItsBoundOfLongDouble). lambda only sets the MIP level
 * and the tent weights, in which an error of 1e-6 moves S by < 1e-6 (the blend
 * is continuous across integer levels). fp64 keeps the library's log2. */
#if GLINT_USE_DOUBLE
GLINT_FN real kemppinen_log2_pos(real x) {
  return log2(x);
}
#else
#if defined(__OPENCL_VERSION__) && GLINT_LANES == 16
#define KEMP_FLOAT_BITS(x) as_uint16(x)
#define KEMP_BITS_FLOAT(u) as_float16(u)
#elif defined(__OPENCL_VERSION__) && GLINT_LANES == 8
#define KEMP_FLOAT_BITS(x) as_uint8(x)
#define KEMP_BITS_FLOAT(u) as_float8(u)
#elif defined(__OPENCL_VERSION__)
#define KEMP_FLOAT_BITS(x) as_uint(x)
#define KEMP_BITS_FLOAT(u) as_float(u)
#else
/* The builtin, not std::memcpy (these headers may be included inside a namespace). */
GLINT_FN uint kemppinen_float_bits(float f) {
  uint u;
  __builtin_memcpy(&u, &f, sizeof u);
  return u;
}
GLINT_FN float kemppinen_bits_float(uint u) {
  float f;
  __builtin_memcpy(&f, &u, sizeof f);
  return f;
}
#define KEMP_FLOAT_BITS(x) kemppinen_float_bits(x)
#define KEMP_BITS_FLOAT(u) kemppinen_bits_float(u)
#endif
GLINT_FN real kemppinen_log2_pos(real x) {
  kemp_uint b = KEMP_FLOAT_BITS(x);
  /* k = e + 127: the biased exponent of x scaled by 2^(1/2) (0x3f800000 - 0x3f3504f3 moves
   * the split from 1 to sqrt(1/2) = 0x3f3504f3), unsigned, as x > 0 is normal. */
  kemp_uint k = (b + (0x3f800000u - 0x3f3504f3u)) >> 23;
  /* m = x 2^-e: the same mantissa under the exponent 127 + (b's exponent - k). */
  real m = KEMP_BITS_FLOAT(b - (k << 23) + 0x3f800000u);
  real e = KEMP_TO_REAL(k) - GLINT_R(127.0);
#if GLINT_FAST_ROOTS_ACTIVE
  /* The point pass's 16-lane device entry: m + 1 in [1.7, 2.5], inside glint_recip_nn's domain
   * (kernels/compat.h: <= 3 2^-24 + 2^-28 relative), so t = (m - 1) / (m + 1) (m - 1 exact,
   * Sterbenz) carries <= 4 2^-24 + 2^-28 relative instead of 2^-24, and |t p| <= 0.51 moves
   * the result by <= 1.1e-7 more: <= 4.1 2^-24 + 1e-9 + 1/2 ulp, ~2.45e-7 + 1/2 ulp
   * (FastLog2Device, models/kemppinen/tests/kemppinen_log2_device_test.cpp). The
   * division sat on the level set-up's critical path (perf annotate: the instructions waiting
   * on it were ~5% of the ONE_CELL kernel's samples). */
  real t = (m - GLINT_R(1.0)) * glint_recip_nn(m + GLINT_R(1.0));
#else
  real t = (m - GLINT_R(1.0)) / (m + GLINT_R(1.0));
#endif
  real t2 = t * t;
  /* 2 / ln 2 times 1, 1/3, 1/5, 1/7, 1/9. */
  real p = GLINT_R(2.8853900817779268) +
           t2 * (GLINT_R(0.96179669392597560) +
                 t2 * (GLINT_R(0.57707801635558536) +
                       t2 * (GLINT_R(0.41219858311113240) + t2 * GLINT_R(0.32059889797532520))));
  return e + t * p;
}
#endif

/* What one query needs whatever the half-vector: the pixel filter in the
 * stretched uv space x_s = A_star uv and the MIP levels. */
typedef struct {
  real u, v;          /* uv as given (the one-level dither's key) */
  real xs, ys;        /* x_s */
  real sxx, sxy, syy; /* Sigma_s, regularised (uv^2 units) */
  real dj;            /* det J_s (f included): det Sigma_s = dj^2 before regularising */
  real tr;            /* trace of Sigma_s before regularising */
  real eps;           /* the regularisation added to Sigma_s's diagonal */
  real lambda;        /* continuous level in [0, GLINT_KEMPPINEN_MAX_LEVEL] */
  uint seed_key;
} KemppinenFootprint;

/* `footprint` = (du/dx, dv/dx, du/dy, dv/dy). */
GLINT_FN KemppinenFootprint kemppinen_footprint(KemppinenParams p, real u, real v,
                                                const GLINT_PRIVATE real *footprint, uint seed_lo,
                                                uint seed_hi) {
  KemppinenFootprint fp;
  real a = p.aniso;
  /* Algorithm 1 line 2: x_s = A_star uv. det A_star = 1, so K_P is unchanged
   * (line 1: res = sqrt(N) det(A^-1) = sqrt(N)). */
  fp.u = u;
  fp.v = v;
  fp.xs = a * u;
  fp.ys = v * p.inv_aniso;
  /* Columns of J_s = A_star J: (a du/dx, dv/dx / a) and (a du/dy, dv/dy / a). */
  /* Footprint entries clamped to +-1e6 uv per pixel: far beyond any useful
   * footprint (the level saturates at GLINT_KEMPPINEN_MAX_LEVEL long before),
   * and Sigma_s stays finite in fp32 (<= ~1e16) for any finite input. */
  real f = p.filter;
  real j00 = f * a * glint_clamp_nn(footprint[0], GLINT_R(-1e6), GLINT_R(1e6));
  real j10 = f * glint_clamp_nn(footprint[1], GLINT_R(-1e6), GLINT_R(1e6)) * p.inv_aniso;
  real j01 = f * a * glint_clamp_nn(footprint[2], GLINT_R(-1e6), GLINT_R(1e6));
  real j11 = f * glint_clamp_nn(footprint[3], GLINT_R(-1e6), GLINT_R(1e6)) * p.inv_aniso;
  /* Eq. 5 / Algorithm 1 line 11: Sigma_s = f^2 J J^T. */
  real sxx = j00 * j00 + j01 * j01;
  real syy = j10 * j10 + j11 * j11;
  real sxy = j00 * j10 + j01 * j11;
  real dj = j00 * j11 - j01 * j10; /* det Sigma_s = (det J_s)^2, without cancellation */
  real half_tr = GLINT_R(0.5) * (sxx + syy);
  real hd = GLINT_R(0.5) * (sxx - syy);
  /* glint_sqrt_nn: the estimate + Newton step in the point pass's 16-lane device entry
   * (models/kemppinen/kemppinen.cl; <= 4 2^-24 relative, kernels/compat.h), sqrt elsewhere. The
   * operands are finite (Sigma_s <= ~1e16 by the clamp above) and >= 0. */
  real lmax = half_tr + glint_sqrt_nn(hd * hd + sxy * sxy);
  /* Regularisation (the det -> 0 pitfall of the shader's inv_quadratic): a
   * degenerate footprint (a line, a point) still gets a 2D filter, at least
   * 1% of its major axis and 1e-3 of the mean facet spacing 1/sqrt(K_P). */
  real eps = GLINT_R(1e-4) * lmax + (real)((real_scalar)1e-6 / GLINT_UNIFORM(p.density));
  fp.sxx = sxx + eps;
  fp.syy = syy + eps;
  fp.sxy = sxy;
  fp.dj = dj;
  fp.tr = sxx + syy;
  fp.eps = eps;
  /* Level: finer level's cells (2^floor(lambda) / sqrt(K_P)) >= 4 sigma_max. */
  real sigma_max = glint_sqrt_nn(lmax + eps);
  real lambda = kemppinen_log2_pos(glint_fmax_nn(
      GLINT_R(8.0) * sigma_max * (real)sqrt(GLINT_UNIFORM(p.density)), GLINT_R(1e-30)));
  fp.lambda = glint_clamp_nn(lambda, GLINT_R(0.0), GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL));
  fp.seed_key = rng_absorb(rng_absorb(0x4b323555u, seed_lo), seed_hi);
  return fp;
}

/* A cell index (an integer-valued real, possibly huge at uv = 1e7) as a hash
 * key, wrapped to [0, 2^24): the pattern repeats every 2^24 cells. */
GLINT_FN kemp_uint kemppinen_cell_key(real c) {
#if GLINT_FAST_ROOTS_ACTIVE
  /* The 16-lane fp32 point pass, where every lane's |c| < 2^31 (almost always: uv * res_s up to
   * 2e9): c is an integer-valued float, so its truncation to int is exact and the low 24 bits of
   * its two's complement are c mod 2^24 (floored, negative c included), the value below; a NaN c
   * gives 0x80000000, whose low bits are the 0 the clamp below gives it. The same key in 3
   * instructions (a conversion and a mask) instead of a product, a rounding to floor (8 cycles'
   * latency), a fused subtract, a clamp and a conversion, on the chain from the level to every
   * facet's hash (session 20). */
  if (!glint_any(fabs(c) >= GLINT_R(2147483648.0))) return as_uint16(convert_int16(c)) & 0xffffffu;
#endif
  real w = c - GLINT_R(16777216.0) * glint_floor(c * GLINT_R(5.9604644775390625e-8));
  return KEMP_TO_UINT(glint_clamp_nn(w, GLINT_R(0.0), GLINT_R(16777215.0)));
}

/* K25 Eq. 8: GLINT_R(r, w) = smoothstep(max(0, r - eps), min(1, r + eps), w). */
GLINT_FN real kemppinen_roulette(real r, real w) {
  real e0 = glint_fmax_nn(r - GLINT_R(GLINT_KEMPPINEN_ROULETTE_EPS), GLINT_R(0.0));
  real e1 = glint_fmin_nn(r + GLINT_R(GLINT_KEMPPINEN_ROULETTE_EPS), GLINT_R(1.0));
#if GLINT_FAST_ROOTS_ACTIVE
  /* The point pass's 16-lane device entry: e1 - e0 in [0.1, 0.2] (r in [0, 1)), so the
   * reciprocal estimate + Newton step applies (kernels/compat.h glint_recip_nn, <= 3 2^-24 +
   * 2^-28 relative): t moves by < 3e-7 relative, R(r, w) = t^2 (3 - 2 t) by < 1e-6. One division
   * per facet and light otherwise (16 per block at k = 1, 64 at k = 4). */
  real t = glint_clamp_nn((w - e0) * glint_recip_nn(e1 - e0), GLINT_R(0.0), GLINT_R(1.0));
#else
  real t = glint_clamp_nn((w - e0) / (e1 - e0), GLINT_R(0.0), GLINT_R(1.0));
#endif
  return t * t * (GLINT_R(3.0) - GLINT_R(2.0) * t);
}

/* The facet of 4D cell (spatial cx, cy; angular ix, iy) at level l: offsets
 * in [0,1)^4 within its cell and its roulette number (K25 3.3.1). */
typedef struct {
  real sx, sy, ax, ay, r;
  real pick; /* in [0, 1): the colour is number floor(pick n) of n (K25 3.3.6) */
} KemppinenFacet;

/* The hash of (seed, level, spatial cell); facets absorb their angular cell.
 * In steps, so a 2x2 block shares the level's and the columns' absorbs
 * (kemppinen_level_query): (seed, level), then the column cx, then the row cy. */
GLINT_FN kemp_uint kemppinen_level_key(uint seed_key, real level) {
  return kemppinen_absorb((kemp_uint)(seed_key), KEMP_TO_UINT(level));
}

GLINT_FN kemp_uint kemppinen_spatial_key(uint seed_key, real level, real cx, real cy) {
  kemp_uint column = kemppinen_absorb(kemppinen_level_key(seed_key, level), kemppinen_cell_key(cx));
  return kemppinen_absorb(column, kemppinen_cell_key(cy));
}

/* 16-bit uniforms, two per hash: k * 2^-16 is exact in float and double. A
 * facet's offsets are quantised to 1/65536 of its cell. */
GLINT_FN real kemppinen_u16_hi(kemp_uint h) {
  return KEMP_TO_REAL(h >> 16) * GLINT_R(1.52587890625e-5);
}
GLINT_FN real kemppinen_u16_lo(kemp_uint h) {
  return KEMP_TO_REAL(h & 0xffffu) * GLINT_R(1.52587890625e-5);
}

/* The facet's hash (session 18): the spatial cell's key absorbed once with the angular cell
 * (ix, iy) packed into one word, (ix + 2^16 iy) times an odd constant, then
 *   key -> the angular offsets (ax, ay), mix(key ^ 1) -> the spatial offsets (sx, sy),
 *   mix(key ^ 0x68e31da4) -> the roulette number r and the colour pick (kemppinen_facet_draws),
 * each a 16-bit half. Until session 17 it was two absorbs (column ix, then row iy), key -> (r,
 * pick), mix(key ^ 1) -> (sx, sy), mix(key ^ 2) -> (ax, ay): four lowbias32 mixes per facet, and
 * with the roulette-free neighbourhoods (ONE_LEVEL, ONE_CELL) r is never read. Now a one-level
 * neighbourhood without colours needs two mixes per facet (key and mix(key ^ 1)), the paper's
 * three, and the chain from the spatial key to the last offset is two mixes (four multiplies)
 * instead of three. The roles are the old ones permuted (each field a 16-bit half of key or of a
 * mix of it), so every field is as uniform and as independent of the others as before; the
 * pattern itself is a new one (models/kemppinen/README.md, session 18). Why the odd multiplier
 * (the golden ratio's 0x9e3779b1; a bijection of 32-bit words, one multiply off the key's
 * dependent chain): without it the words of neighbouring cells along x differ in their low bits
 * only, and lowbias32 leaves their low halves weakly dependent: ay against the next cell's ay,
 * 8 x 8 chi-square 247 at 2e7 samples (63 degrees of freedom, Cramer's V ~0.001; 609 for even
 * ix), which the FacetHash test caught (the old hash had the same kind in pick along y, 297).
 * The multiplier moves the difference into the high bits, which lowbias32's first xor-shift folds
 * down (50.8). The packing is injective for ix, iy < 2^16, i.e. at levels l <= 16;
 * beyond (res_a > 65536 angular cells per axis: the pixel filter then spans > 2^13 mean facet
 * spacings, so the explicit facets weigh nothing against the compensation) the word is taken
 * mod 2^32: (ix + 2^16, iy) shares a key with (ix, iy + 1), and (ix, iy + 2^16) with (ix, iy),
 * as spatial cells 2^24 apart do (kemppinen_cell_key). The k neighbour cells of one query are
 * at most 4 apart, so no query sees two facets of one key. */
#define GLINT_KEMPPINEN_CELL_WORD_MUL 0x9e3779b1u
/* The absorbed word of angular cell (ix, iy). */
GLINT_FN kemp_uint kemppinen_cell_word(real ix, real iy) {
  return (KEMP_TO_UINT(ix) + (KEMP_TO_UINT(iy) << 16)) * GLINT_KEMPPINEN_CELL_WORD_MUL;
}

/* The word of cell (ix + mx, iy + my) from the word of (ix, iy), for the point pass's block of
 * cells: the same word mod 2^32 by distributivity (KEMP_TO_UINT(ix + mx) = KEMP_TO_UINT(ix) + mx
 * while ix + mx <= 2^24 is exact; beyond, at level 24, the cell is past the grid's end and its
 * facet is dropped whatever its key), with a uniform product instead of one per facet and lane
 * (the multiplier cost PAPER k = 4 5-9% before, models/kemppinen/README.md session 18). */
GLINT_FN kemp_uint kemppinen_cell_word_at(kemp_uint base_word, int mx, int my) {
  return base_word + (uint)(mx + (my << 16)) * GLINT_KEMPPINEN_CELL_WORD_MUL;
}

GLINT_FN kemp_uint kemppinen_facet_key(kemp_uint spatial_key, real ix, real iy) {
  return kemppinen_absorb(spatial_key, kemppinen_cell_word(ix, iy));
}

/* The hash of the facet's spatial offsets (sx: bits 16-31, sy: bits 0-15); the polygon pass
 * (kemppinen_polygons.h) reads it before the other fields. */
GLINT_FN kemp_uint kemppinen_facet_spatial_hash(kemp_uint key) {
  return kemppinen_mix(key ^ 0x1u);
}

/* The facet's offsets in its 4D cell. Not r and pick: they are left 0 here, and a caller that
 * reads them takes kemppinen_facet_draws (kemppinen_facet_of_key does both). */
GLINT_FN KemppinenFacet kemppinen_facet_offsets(kemp_uint key) {
  kemp_uint h1 = kemppinen_facet_spatial_hash(key);
  KemppinenFacet g;
  g.sx = kemppinen_u16_hi(h1);
  g.sy = kemppinen_u16_lo(h1);
  g.ax = kemppinen_u16_hi(key);
  g.ay = kemppinen_u16_lo(key);
  g.r = GLINT_R(0.0);
  g.pick = GLINT_R(0.0);
  return g;
}

/* The hash of the facet's roulette number (bits 16-31) and colour pick (bits 0-15). Not
 * mix(key ^ 2), as until session 17: lowbias32 of two keys that differ in their low bits only
 * (key ^ 1, key ^ 2) has dependent low halves (8 x 8 chi-square of lo16(mix(k ^ 1)) against
 * lo16(mix(k ^ 2)) over 2e6 random k: 801, 63 degrees of freedom; the old hash's sy against
 * ay). A dense constant spreads the difference over both halves before the first xor-shift
 * (the same statistic 78; FacetHash test). */
GLINT_FN kemp_uint kemppinen_facet_draws(kemp_uint key) {
  return kemppinen_mix(key ^ 0x68e31da4u);
}

GLINT_FN KemppinenFacet kemppinen_facet_of_key(kemp_uint key) {
  KemppinenFacet g = kemppinen_facet_offsets(key);
  kemp_uint h2 = kemppinen_facet_draws(key);
  g.r = kemppinen_u16_hi(h2);
  g.pick = kemppinen_u16_lo(h2); /* bits 0-15, independent of r's 16-31 */
  return g;
}

GLINT_FN KemppinenFacet kemppinen_facet(kemp_uint spatial_key, real ix, real iy) {
  return kemppinen_facet_of_key(kemppinen_facet_key(spatial_key, ix, iy));
}

/* The angular query: x_a = T(h) and the lobe's standard deviations in U. */
typedef struct {
  real x, y;
  real sx, sy;
} KemppinenAngular;

GLINT_FN KemppinenAngular kemppinen_angular(KemppinenParams p, DiskPoint d) {
  KemppinenAngular q;
  q.x = d.x;
  q.y = d.y;
  /* Eq. 4, Algorithm 1 line 12: Sigma_a = |J_T| (alpha_star A^-1)^2, A^-1 =
   * diag(1/a, a). Floored so a dead half-vector (D = 0) stays finite. */
  real s = fmax(p.micro * sqrt(fmax(d.jac, GLINT_R(0.0))), GLINT_R(1e-12));
  q.sx = s / p.aniso;
  q.sy = s * p.aniso;
  return q;
}

/* ---------------------------------------------- a level's spatial half */

/* What level l needs of the query whatever the half-vector (the spatial half
 * of Algorithm 1 lines 9-11): shared by every light of a query
 * (kemppinen_level_query), by the polygon pass and the sampler through
 * kemppinen_blocks. In cells. */
typedef struct {
  real res_a, inv_res_a; /* 2^l and 2^-l, both exact (l integer, <= 24) */
  real res_s;
  real ts_x, ts_y; /* x_s res_s */
  real bs_x, bs_y; /* first spatial cell */
  /* Sigma_s^-1 / 2 in cells, and the pixel filter's norm 1 / (2 pi sqrt(det)) in cells. */
  real qxx, qxy, qyy;
  real norm_s;
} KemppinenSpatial;

GLINT_FN KemppinenSpatial kemppinen_spatial(KemppinenParams p, KemppinenFootprint fp, real level) {
  KemppinenSpatial s;
  /* Algorithm 1 lines 9-10 (with res = sqrt(K_P)). */
  /* 2^l exactly (l integer in [0, 24]) by a shift, not exp2 (a polynomial per
   * lane on the device); the same value as the former floor(exp2(l) + 1/2). */
  kemp_uint l =
      KEMP_TO_UINT(glint_clamp_nn(level, GLINT_R(0.0), GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL)));
#if GLINT_USE_DOUBLE
  s.res_a = KEMP_TO_REAL(((kemp_uint)1u) << l);
  s.inv_res_a = GLINT_R(1.0) / s.res_a; /* exact: a power of two */
#else
  /* fp32: 2^l and 2^-l written as exponent fields (biased 127 + l and 127 - l, both normal
   * for l in [0, 24]): the same exact values without a conversion and a division per lane
   * (the division's latency stalled the query's set-up, perf annotate). */
  s.res_a = KEMP_BITS_FLOAT((l + 127u) << 23);
  s.inv_res_a = KEMP_BITS_FLOAT((127u - l) << 23);
#endif
  /* sqrt(K_P) / 2^l as a product by the exact 2^-l: the same bits as the
   * quotient (both round sqrt(K_P) 2^-l once), without a division. */
  s.res_s = (real)sqrt(GLINT_UNIFORM(p.density)) * s.inv_res_a; /* a scalar root: uniform */
  s.ts_x = fp.xs * s.res_s;
  s.ts_y = fp.ys * s.res_s;
  /* 2x2 spatial cells around the nearest cell vertex. */
  s.bs_x = glint_floor(s.ts_x - GLINT_R(0.5));
  s.bs_y = glint_floor(s.ts_y - GLINT_R(0.5));
  /* det of Sigma_s in cells^2, each factor scaled before multiplying: at
   * density 1e30 det Sigma_s itself underflows float (eps^2 ~ 1e-72). */
  real r2 = s.res_s * s.res_s;
  real djc = fp.dj * r2, ec = fp.eps * r2;
  real det_c = djc * djc + ec * (fp.tr * r2) + ec * ec;
  /* Sigma_c^-1 / 2 = adj(Sigma_s r2) / (2 det_c): scale the entries to cells
   * first (r2 / det_c alone overflows float at density 1e30, and 0 * inf is
   * NaN); each quotient is then ~1 / variance in cells, >= the regulariser. */
#if GLINT_FAST_ROOTS_ACTIVE
  /* The point pass's 16-lane device entry: both from one reciprocal square root estimate and its
   * Newton step (kernels/compat.h glint_rsqrt_nn, <= 4 2^-24 relative), instead of two divisions
   * and a square root on the divider (10-12 cycles each per 16 lanes) ahead of every facet lobe:
   * inv_det = rs^2 carries <= 9 2^-24 relative (two of the estimate's errors and one rounding),
   * norm_s <= ~5.7 2^-24 (with 1 / 2 pi rounded to fp32), against 1 and ~2 roundings. det_c is a
   * positive normal float where the level follows the footprint (>= ~1e-12: eps keeps the filter's
   * cells >= 1e-2 of its major axis) and +inf only past fp32's range (level 24, footprints near the
   * 1e6 clamp at density 1e30), where the division gave 0 and the estimate's Newton step would give
   * NaN (0 * inf): selected to the same 0. */
  real rs = glint_select(glint_rsqrt_nn(det_c), GLINT_R(0.0), det_c == GLINT_R(INFINITY));
  real inv_det = rs * rs;
  s.norm_s = rs * GLINT_R(0.15915494309189533577);
#else
  real inv_det = GLINT_R(1.0) / det_c;
  s.norm_s = GLINT_R(1.0) / (GLINT_R(2.0) * GLINT_PI * sqrt(det_c));
#endif
  s.qxx = GLINT_R(0.5) * (fp.syy * r2) * inv_det;
  s.qxy = -(fp.sxy * r2) * inv_det;
  s.qyy = GLINT_R(0.5) * (fp.sxx * r2) * inv_det;
  return s;
}

/* erfc(|x| / sqrt 2) of four standard scores, 0 beyond
 * GLINT_KEMPPINEN_ERFC_CUT: erfc(6 / sqrt 2) = 1.97e-9, far below the
 * approximation's own error (1.5e-7). Chosen per lane (the value never
 * depends on the other queries of a block); computed only when some lane of
 * the block needs one of the four (on the host: when the query does). Edges
 * of the unit square and of the spatial block are usually that far. */
#define GLINT_KEMPPINEN_ERFC_CUT 6.0f
typedef struct {
  real a, b, c, d;
} KemppinenErfc4;

GLINT_FN KemppinenErfc4 kemppinen_erfc4_with(real a, real b, real c, real d, int cheap) {
  real zero = GLINT_R(0.0), cut = GLINT_R(GLINT_KEMPPINEN_ERFC_CUT);
  KemppinenErfc4 e;
  e.a = zero;
  e.b = zero;
  e.c = zero;
  e.d = zero;
  glint_mask na = fabs(a) < cut, nb = fabs(b) < cut, nc = fabs(c) < cut, nd = fabs(d) < cut;
  if (cheap) {
    if (glint_any(na | nb | nc | nd)) {
      /* A&S 7.1.27 is 1 / P with P = (1 + a1 y + ...)^4: the four from one
       * division, 1 / (Pa Pb Pc Pd), and products (a division costs ~10
       * multiplies on the CPU device). |x| is clamped at the cut (6; y = 6 / sqrt 2),
       * where P < 1.2e6, so the product of four stays < 2e24 (no overflow in
       * fp32); lanes beyond the cut are zeroed below as before. Each erfc
       * then carries ~5 roundings instead of 1 (relative 3e-7 in fp32), far
       * below the approximation's 5e-4 (tested against libm). */
      real pa = kemppinen_erfc_cheap_denominator(a, cut);
      real pb = kemppinen_erfc_cheap_denominator(b, cut);
      real pc = kemppinen_erfc_cheap_denominator(c, cut);
      real pd = kemppinen_erfc_cheap_denominator(d, cut);
      real pab = pa * pb, pcd = pc * pd;
      /* pab pcd in [1, 2e24]: glint_recip_nn's estimate + Newton step in the 16-lane point
       * pass (<= 3 2^-24 + 2^-28 relative, kernels/compat.h), the division elsewhere. */
      real r = glint_recip_nn(pab * pcd);
      real rab = r * pcd, rcd = r * pab; /* 1 / (pa pb), 1 / (pc pd) */
      e.a = glint_select(zero, rab * pb, na);
      e.b = glint_select(zero, rab * pa, nb);
      e.c = glint_select(zero, rcd * pd, nc);
      e.d = glint_select(zero, rcd * pc, nd);
    }
  } else if (glint_any(na | nb | nc | nd)) {
    /* The lanes beyond the cut evaluate at the cut (their value is dropped):
     * far beyond it exp(-y^2) is subnormal in fp32, which costs a microcode
     * assist per instruction on x86 (kemppinen_lobe_cut). Lanes inside: the
     * same bits. */
    e.a = glint_select(zero, kemppinen_erfc_abs_cut(glint_fmin_nn(fabs(a), cut)), na);
    e.b = glint_select(zero, kemppinen_erfc_abs_cut(glint_fmin_nn(fabs(b), cut)), nb);
    e.c = glint_select(zero, kemppinen_erfc_abs_cut(glint_fmin_nn(fabs(c), cut)), nc);
    e.d = glint_select(zero, kemppinen_erfc_abs_cut(glint_fmin_nn(fabs(d), cut)), nd);
  }
  return e;
}

GLINT_FN KemppinenErfc4 kemppinen_erfc4(real a, real b, real c, real d) {
  return kemppinen_erfc4_with(a, b, c, d, 0);
}

/* 1 - P_s: the pixel filter's mass outside the explicit 2x2 spatial block
 * (first cell bs, query ts, in cells of res_s per unit), per axis from the
 * diagonal of Sigma_s; the query lies inside the block, so 1 - mass is the
 * two tails. */
GLINT_FN real kemppinen_outside_width(KemppinenFootprint fp, real res_s, real ts_x, real ts_y,
                                      real bs_x, real bs_y, real width, int cheap) {
  real isx, isy;
  if (cheap) {
    /* One division for both (the cheap neighbourhoods). qx qy stays within
     * fp32: qx = sigma_x res_s is ~1/8 or less where the level follows the
     * footprint, >= sqrt(1e-4) / 8 by the regulariser, >= 1e-3 at level 0
     * (eps >= 1e-6 / K_P), and at level 24 <= 1.2e8 (footprint clamp 1e6,
     * f <= 4, a <= 20) x 6e7 (K_P <= 1e30): qx in [1e-3, 7e15]. ~3 roundings
     * instead of 1. */
#if GLINT_FAST_ROOTS_ACTIVE
    /* The 16-lane point pass: 1 / sqrt by the estimate + Newton step (kernels/compat.h, <= 4
     * 2^-24 relative; fp.sxx, fp.syy in [eps, ~1e16], positive normal floats) and 1 / res_s
     * (res_s = sqrt(K_P) 2^-l in [~6e-11, 1e15] for densities >= 1e-6, inside glint_recip_nn's
     * domain, <= 3 2^-24 + 2^-28): ~8 roundings' worth relative on the standard scores instead of
     * ~6, against the cheap erfc's 5e-4 absolute; two root sequences and a product fewer than
     * below. */
    real inv_res_s = glint_recip_nn(res_s);
    isx = glint_rsqrt_nn(fp.sxx) * inv_res_s;
    isy = glint_rsqrt_nn(fp.syy) * inv_res_s;
#else
    real qx = glint_sqrt_nn(fp.sxx) * res_s, qy = glint_sqrt_nn(fp.syy) * res_s;
    real r = glint_recip_nn(qx * qy); /* qx qy in [1e-6, 5e31]: see glint_recip_nn */
    isx = qy * r;
    isy = qx * r;
#endif
  } else {
    isx = GLINT_R(1.0) / (sqrt(fp.sxx) * res_s);
    isy = GLINT_R(1.0) / (sqrt(fp.syy) * res_s);
  }
  KemppinenErfc4 e = kemppinen_erfc4_with((bs_x - ts_x) * isx, (bs_x + width - ts_x) * isx,
                                          (bs_y - ts_y) * isy, (bs_y + width - ts_y) * isy, cheap);
  real tx = GLINT_R(0.5) * (e.a + e.b);
  real ty = GLINT_R(0.5) * (e.c + e.d);
  return tx + (GLINT_R(1.0) - tx) * ty;
}

/* 1 - P_s of the material's spatial neighbourhood with first cell bs: the 2x2 block, or with
 * ONE_CELL the one cell holding the query (first cell floor(ts)); the erfc of A&S 7.1.27 for the
 * one-level neighbourhoods (kemppinen_erfc4_with). One function for the point pass
 * (kemppinen_level_query_into) and the polygon pass (kemppinen_spatial_outside), so the two
 * passes of one material compensate the same spatial cells with the same formula (the point
 * pass's 16-lane device entry takes its roots by the fast estimates in kemppinen_outside_width). */
GLINT_FN real kemppinen_neighborhood_outside(KemppinenParams p, KemppinenFootprint fp, real res_s,
                                             real ts_x, real ts_y, real bs_x, real bs_y) {
  return kemppinen_outside_width(fp, res_s, ts_x, ts_y, bs_x, bs_y,
                                 p.one_cell ? GLINT_R(1.0) : GLINT_R(2.0), p.one_level);
}

/* Everything of level l that every light of the query shares: the spatial
 * half, the hashes of the 2x2 spatial cells (the facets absorb their angular
 * cell, kemppinen_facet) and 1 - P_s. */
typedef struct {
  KemppinenSpatial s;
  real level;
  kemp_uint key[4];
  real outside;
} KemppinenLevelQuery;

/* Written in place: on the device this struct is 17 vectors (1088 bytes), and assigning a
 * returned one made PoCL copy it with an out-of-line memcpy (vzeroupper and every vector
 * register spilled around the call), once or twice per query (perf). */
GLINT_FN void kemppinen_level_query_into(KemppinenParams p, KemppinenFootprint fp, real level,
                                         GLINT_PRIVATE KemppinenLevelQuery *q) {
  q->s = kemppinen_spatial(p, fp, level);
  q->level = level;
  if (p.one_cell) {
    /* GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL: the cell holding the query, the
     * same facet (the same hash) as that cell of the 2x2 block. */
    q->s.bs_x = glint_floor(q->s.ts_x);
    q->s.bs_y = glint_floor(q->s.ts_y);
    q->key[0] = kemppinen_spatial_key(fp.seed_key, level, q->s.bs_x, q->s.bs_y);
    q->key[1] = q->key[0];
    q->key[2] = q->key[0];
    q->key[3] = q->key[0];
    q->outside = kemppinen_neighborhood_outside(p, fp, q->s.res_s, q->s.ts_x, q->s.ts_y, q->s.bs_x,
                                                q->s.bs_y);
    return;
  }
  /* kemppinen_spatial_key of the 2x2 block: 7 absorbs instead of 12. */
  kemp_uint lk = kemppinen_level_key(fp.seed_key, level);
  kemp_uint col0 = kemppinen_absorb(lk, kemppinen_cell_key(q->s.bs_x));
  kemp_uint col1 = kemppinen_absorb(lk, kemppinen_cell_key(q->s.bs_x + GLINT_R(1.0)));
  for (int j = 0; j < 4; ++j)
    q->key[j] =
        kemppinen_absorb((j & 1) ? col1 : col0, kemppinen_cell_key(q->s.bs_y + (real)(j >> 1)));
  q->outside =
      kemppinen_neighborhood_outside(p, fp, q->s.res_s, q->s.ts_x, q->s.ts_y, q->s.bs_x, q->s.bs_y);
}

GLINT_FN KemppinenLevelQuery kemppinen_level_query(KemppinenParams p, KemppinenFootprint fp,
                                                   real level) {
  KemppinenLevelQuery q;
  kemppinen_level_query_into(p, fp, level, &q);
  return q;
}

/* ---------------------------------------------- a level's angular half */

/* The n x n angular cells nearest x_a (ta = x_a res_a, per axis): around the
 * nearest vertex (n even) or centred on x_a's cell (n odd), kept inside
 * [0, res_a) (the shader's clamp has min > max at l <= 0, notes Sec. 5: here
 * a block larger than the grid is the whole grid). First cell; the end is
 * min(first + n, res_a). */
GLINT_FN real kemppinen_angular_first(real ta, real n, real res_a) {
  real hi = glint_fmax_nn(res_a - n, GLINT_R(0.0));
  return glint_clamp_nn(glint_floor(ta - GLINT_R(0.5) * (n - GLINT_R(1.0))), GLINT_R(0.0), hi);
}

/* The spatial 2x2 block and the angular n x n block of level l, in cells
 * (the polygon pass and the sampler; the point-light pass uses the halves). */
typedef struct {
  real res_s, res_a;
  real ts_x, ts_y; /* x_s res_s */
  real bs_x, bs_y; /* first spatial cell */
  real ta_x, ta_y; /* x_a res_a */
  real ba_x, ba_y; /* first angular cell */
  real ea_x, ea_y; /* one past the last angular cell (clipped to res_a) */
  /* Per-level constants of the facet lobes (kemppinen_facet_lobe), in cells:
   * Sigma_s^-1 / 2, 1 / sigma_a per axis, and the two Gaussians' norm. */
  real qxx, qxy, qyy;
  real inv_sax, inv_say;
  real norm;
} KemppinenBlocks;

GLINT_FN KemppinenBlocks kemppinen_blocks(KemppinenParams p, KemppinenFootprint fp,
                                          KemppinenAngular a, real level) {
  KemppinenSpatial s = kemppinen_spatial(p, fp, level);
  KemppinenBlocks b;
  b.res_a = s.res_a;
  b.res_s = s.res_s;
  b.ts_x = s.ts_x;
  b.ts_y = s.ts_y;
  b.bs_x = s.bs_x;
  b.bs_y = s.bs_y;
  b.qxx = s.qxx;
  b.qxy = s.qxy;
  b.qyy = s.qyy;
  real n = (real)p.n_side;
  b.ta_x = a.x * b.res_a;
  b.ta_y = a.y * b.res_a;
  b.ba_x = kemppinen_angular_first(b.ta_x, n, b.res_a);
  b.ba_y = kemppinen_angular_first(b.ta_y, n, b.res_a);
  b.ea_x = fmin(b.ba_x + n, b.res_a);
  b.ea_y = fmin(b.ba_y + n, b.res_a);
  real sax = a.sx * b.res_a, say = a.sy * b.res_a;
  b.inv_sax = GLINT_R(1.0) / sax;
  b.inv_say = GLINT_R(1.0) / say;
  b.norm = s.norm_s / (GLINT_R(2.0) * GLINT_PI * sax * say);
  return b;
}

/* One facet's filtered lobe N(x_s - g_s; Sigma_s) N(x_a - g_a; Sigma_a) / K_P,
 * 0 if the facet lies outside the disk U (rejected, 3.3.1). Written in cell
 * units (K_P = res_s^2 res_a^2), so no factor of K_P over- or underflows:
 * dxc, dyc = x_s res_s - the spatial cell, ta = x_a res_a, inv_res_a = 2^-l
 * (so (ix + g.ax) inv_res_a is the exact quotient), inv_sa = 1 / sigma_a in
 * cells, q = Sigma_s^-1 / 2 in cells, norm = both Gaussians' norms. */
GLINT_FN real kemppinen_facet_lobe_at(real inv_res_a, real ta_x, real ta_y, real inv_sax,
                                      real inv_say, real dxc, real dyc, real qxx, real qxy,
                                      real qyy, real norm, real e_lim, real ix, real iy,
                                      KemppinenFacet g) {
  real gx = (ix + g.ax) * inv_res_a - GLINT_R(0.5);
  real gy = (iy + g.ay) * inv_res_a - GLINT_R(0.5);
  glint_mask outside = gx * gx + gy * gy >= GLINT_R(0.25);
  /* Angular offsets in cells over the standard deviations in cells, spatial
   * offsets in cells through Sigma_s^-1 / 2; one exp for both Gaussians. */
  real ux = (ta_x - ix - g.ax) * inv_sax, uy = (ta_y - iy - g.ay) * inv_say;
  real dx = dxc - g.sx, dy = dyc - g.sy;
  real e = GLINT_R(0.5) * (ux * ux + uy * uy) + (qxx * dx * dx + qxy * dx * dy + qyy * dy * dy);
  /* Beyond e_lim (kemppinen_lobe_cut) the lobe is 0: the exp's argument is
   * clamped there, so neither exp(-e) nor its product with norm is subnormal. */
  return glint_select(kemppinen_exp_neg(glint_fmin_nn(e, e_lim)) * norm, GLINT_R(0.0),
                      outside | (e > e_lim));
}

/* The exponent beyond which a facet's lobe exp(-e) norm is taken as 0:
 * min(80, (logb(norm) + 125) ln 2). Below it exp(-e) >= e^-80 = 1.8e-35 and
 * exp(-e) norm >= 2^-125, both normal floats. Why: exp(-e) for e in (87, 104)
 * and small norms give subnormal fp32 results, PoCL does not flush them to 0,
 * and on x86 every vector instruction that produces or reads a subnormal lane
 * takes a microcode assist (~100+ cycles); with 16 random queries per
 * work-item some lane almost always had one, and the instructions after the
 * facet's exp were ~20% of the ONE_CELL kernel's time (perf annotate). What is
 * dropped: lobes below e^-80 of the facet's peak or below 2^-125 absolute (S
 * is ~1; a dropped term changes it by < 1e-34 relative to the facet's own
 * weight). */
GLINT_FN real kemppinen_lobe_cut(real norm) {
#if GLINT_USE_DOUBLE
  real lb = logb(norm);
#else
  /* fp32: logb(norm) from the exponent field, (bits >> 23) - 127 (norm > 0: sign bit clear),
   * 3 instructions instead of PoCL's logb (~12 per light and level: vgetexpps and the special
   * cases). The same value for every normal norm. Otherwise the cut is the same as with logb:
   * a zero or subnormal norm gives -127 (logb: -inf or its exponent < -126), so e_lim < 0 <= e
   * and the facet is 0 either way; +inf or NaN give 128, so e_lim = 80, as logb's +inf or NaN
   * does through glint_fmin_nn. */
  real lb = KEMP_TO_REAL(KEMP_FLOAT_BITS(norm) >> 23) - GLINT_R(127.0);
#endif
  return glint_fmin_nn((lb + GLINT_R(125.0)) * GLINT_R(0.69314718055994530942), GLINT_R(80.0));
}

GLINT_FN real kemppinen_facet_lobe(KemppinenBlocks b, real cx, real cy, real ix, real iy,
                                   KemppinenFacet g) {
  /* No cut (the tests' explicit sums and the sampler's pdf take every lobe). With the point
   * pass's exp (models/kemppinen/kemppinen_exp.h, domain x <= 86) a cut at 86 instead: no entry
   * that compiles it calls this today, and exp(-86) = 4e-38 is 0 to any sum of lobes. */
#if GLINT_KEMPPINEN_FAST_EXP
  real e_lim = GLINT_R(86.0);
#else
  real e_lim = GLINT_R(INFINITY);
#endif
  return kemppinen_facet_lobe_at(GLINT_R(1.0) / b.res_a, b.ta_x, b.ta_y, b.inv_sax, b.inv_say,
                                 b.ts_x - cx, b.ts_y - cy, b.qxx, b.qxy, b.qyy, b.norm, e_lim, ix,
                                 iy, g);
}

/* 1 - P_s of the blocks' spatial neighbourhood for the material's setting (the polygon pass;
 * with ONE_CELL b.bs must be the cell holding the query, kemppinen_blocks_one_cell). PAPER: the
 * 2x2 block with 7.1.26's erfc, as before session 20. */
GLINT_FN real kemppinen_spatial_outside(KemppinenParams p, KemppinenFootprint fp,
                                        KemppinenBlocks b) {
  return kemppinen_neighborhood_outside(p, fp, b.res_s, b.ts_x, b.ts_y, b.bs_x, b.bs_y);
}

/* GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL for the blocks (the polygon pass): the spatial cell
 * holding the query, as kemppinen_level_query_into chooses it for the point pass. */
GLINT_FN void kemppinen_blocks_one_cell(GLINT_PRIVATE KemppinenBlocks *b) {
  b->bs_x = glint_floor(b->ts_x);
  b->bs_y = glint_floor(b->ts_y);
}

/* K25 Eq. 9-10 for level l: the expected lobe mass of the facets not
 * evaluated explicitly,
 *   C = P_a(square) - P_s(spatial block) P_a(B(k) in the square)
 *     = [P_a(square) - P_a(B)] + (1 - P_s) P_a(B),
 * both brackets from tails (no difference of two numbers near 1). Angular
 * edges in cells (square [0, res_a], block [ba, ea]) about ta, scaled by
 * 1 / sigma_a in cells. */
GLINT_FN real kemppinen_compensation_with(real ta_x, real ta_y, real ba_x, real ba_y, real ea_x,
                                          real ea_y, real res_a, real inv_sax, real inv_say,
                                          real outside, int cheap) {
  real x0 = -ta_x * inv_sax, x1 = (ba_x - ta_x) * inv_sax;
  real x2 = (ea_x - ta_x) * inv_sax, x3 = (res_a - ta_x) * inv_sax;
  real y0 = -ta_y * inv_say, y1 = (ba_y - ta_y) * inv_say;
  real y2 = (ea_y - ta_y) * inv_say, y3 = (res_a - ta_y) * inv_say;
  /* erfc at the 4 edges per axis, each used by two masses; the square's
   * edges are many standard deviations away except near the disk's rim. */
  KemppinenErfc4 eb = kemppinen_erfc4_with(x1, x2, y1, y2, cheap);
  real cut = GLINT_R(GLINT_KEMPPINEN_ERFC_CUT);
  /* x0 <= -cut is ta_x inv_sax >= cut (x0 is that product negated, exactly), so both edges of
   * an axis are far when the smaller of the two products is: the same mask with two compares
   * and one and fewer (x0, y0 are then only needed in the rare branch below). */
  glint_mask square_far =
      (glint_fmin_nn(ta_x * inv_sax, x3) >= cut) & (glint_fmin_nn(ta_y * inv_say, y3) >= cut);
  /* The block holds x_a strictly inside (x1 < 0 < x2, y1 < 0 < y2): so it does whenever x_a
   * lies in the unit square, as T(h) does up to rounding (kemppinen_angular_first keeps ta in
   * [ba, ea]), except on a cell edge. Where that holds in every lane and the square's edges are
   * far (the branch below), each mass_e and each select of the folded branch picks its
   * across-0 or tail operand; this is that branch with those choices made: the same IEEE
   * operations on the same values in the same statements, so the same bits, without the 8
   * selects and their compares per light and level (the compensation was ~18% of the ONE_CELL
   * k = 1 kernel, models/kemppinen/README.md session 17). */
  glint_mask inside =
      (x1 < GLINT_R(0.0)) & (x2 > GLINT_R(0.0)) & (y1 < GLINT_R(0.0)) & (y2 > GLINT_R(0.0));
  if (!glint_any(!(square_far & inside))) {
    real hx1 = GLINT_R(0.5) * eb.a, hx2 = GLINT_R(0.5) * eb.b;
    real hy1 = GLINT_R(0.5) * eb.c, hy2 = GLINT_R(0.5) * eb.d;
    real xb_in = GLINT_R(1.0) - GLINT_R(0.5) * (eb.a + eb.b);
    real yb_in = GLINT_R(1.0) - GLINT_R(0.5) * (eb.c + eb.d);
    real xout_in = hx1 + hx2;
    real yout_in = hy1 + hy2;
    real yb_xout_in = yb_in * xout_in;
    real square_minus_block_in = yout_in + yb_xout_in;
    return glint_fmax_nn(square_minus_block_in + outside * xb_in * yb_in, GLINT_R(0.0));
  }
  real xb = kemppinen_mass_e(x1, x2, eb.a, eb.b), yb = kemppinen_mass_e(y1, y2, eb.c, eb.d);
  real square_minus_block; /* = P_a(square) - P_a(B) */
  if (glint_any(!square_far)) {
    KemppinenErfc4 es = kemppinen_erfc4_with(x0, x3, y0, y3, cheap);
    real xsq = kemppinen_mass_e(x0, x3, es.a, es.b);
    real xout = kemppinen_mass_e(x0, x1, es.a, eb.a) + kemppinen_mass_e(x2, x3, eb.b, es.b);
    real yout = kemppinen_mass_e(y0, y1, es.c, eb.c) + kemppinen_mass_e(y2, y3, eb.d, es.d);
    /* yb * xout rounded in a statement of its own, in both branches: kernels that fuse
     * multiply-adds (GLINT_CONTRACT_FMA) fuse within one expression only, and xsq * yout + yb *
     * xout with xsq = 1 would round differently from the branch below, whose choice depends on
     * the block's other lanes (a lane's bits must not). */
    real yb_xout = yb * xout;
    square_minus_block = xsq * yout + yb_xout;
  } else {
    /* Every lane's square edges lie beyond the cut on their own side (x0, y0 <= -6 <= 6 <= x3,
     * y3): the branch above with its erfc at those edges 0, folded. There xsq = mass_e(x0, x3,
     * 0, 0) = 1 - (0 + 0) / 2 = 1, mass_e(x0, x1, 0, e) = (x1 <= 0 ? e / 2 : 1 - e / 2) (x0 < 0),
     * mass_e(x2, x3, e, 0) = (x2 >= 0 ? e / 2 : 1 - e / 2) (x3 > 0), each the same IEEE
     * operations on the same values (e + 0 = e - 0 = e for e >= 0, 1 * y = y): the same bits,
     * without the 7 three-way selects of the general case (the compensation was ~22% of the
     * ONE_CELL k = 1 kernel's time, measured by removing it). Usually taken: the unit square's
     * edges are within 6 sigma_a of x_a only near the 4 points where the disk touches them. */
    real hx1 = GLINT_R(0.5) * eb.a, hx2 = GLINT_R(0.5) * eb.b;
    real hy1 = GLINT_R(0.5) * eb.c, hy2 = GLINT_R(0.5) * eb.d;
    real xout = glint_select(GLINT_R(1.0) - hx1, hx1, x1 <= GLINT_R(0.0)) +
                glint_select(GLINT_R(1.0) - hx2, hx2, x2 >= GLINT_R(0.0));
    real yout = glint_select(GLINT_R(1.0) - hy1, hy1, y1 <= GLINT_R(0.0)) +
                glint_select(GLINT_R(1.0) - hy2, hy2, y2 >= GLINT_R(0.0));
    real yb_xout = yb * xout;
    square_minus_block = yout + yb_xout;
  }
  return glint_fmax_nn(square_minus_block + outside * xb * yb, GLINT_R(0.0));
}

GLINT_FN real kemppinen_compensation_at(real ta_x, real ta_y, real ba_x, real ba_y, real ea_x,
                                        real ea_y, real res_a, real inv_sax, real inv_say,
                                        real outside) {
  return kemppinen_compensation_with(ta_x, ta_y, ba_x, ba_y, ea_x, ea_y, res_a, inv_sax, inv_say,
                                     outside, 0);
}

/* K25 3.3.6: facet g's colour, number floor(pick n) of the n colours (each
 * with probability 1/n up to 2^-16: pick is a 16-bit uniform), by selects
 * (the index is per lane, the colour table uniform). By pointer: the
 * parameter block holds a table, and passing it by value made PoCL copy the
 * whole block to the stack per facet (a third of the facet loop's
 * instructions). */
GLINT_FN real3 kemppinen_facet_color_of(const GLINT_PRIVATE KemppinenParams *p, KemppinenFacet g) {
  real3 c = make_real3((real)p->colors[0], (real)p->colors[1], (real)p->colors[2]);
  real idx = glint_floor(g.pick * (real)p->n_colors);
  for (int k = 1; k < p->n_colors; ++k) {
    real3 ck =
        make_real3((real)p->colors[3 * k], (real)p->colors[3 * k + 1], (real)p->colors[3 * k + 2]);
    c = r3_select(c, ck, idx >= (real)k);
  }
  return c;
}

GLINT_FN real3 kemppinen_facet_color(KemppinenParams p, KemppinenFacet g) {
  return kemppinen_facet_color_of(&p, g);
}

/* What one light's half-vector gives every level: x_a = T(h) and the lobe's
 * inverse standard deviations and norm in U (Eq. 4), two divisions per light
 * instead of per level. */
typedef struct {
  real x, y;
  real inv_sx, inv_sy;
  real norm; /* 1 / (2 pi sigma_x sigma_y) */
} KemppinenLobe;

GLINT_FN KemppinenLobe kemppinen_lobe(KemppinenAngular a) {
  KemppinenLobe l;
  l.x = a.x;
  l.y = a.y;
  l.inv_sx = GLINT_R(1.0) / a.sx;
  l.inv_sy = GLINT_R(1.0) / a.sy;
  l.norm = l.inv_sx * l.inv_sy * GLINT_R(0.15915494309189533577);
  return l;
}

/* What level l needs of one lobe (one light's half-vector): x_a in cells, the n x n angular
 * block [ba, ea), 1 / sigma_a in cells, both Gaussians' norm and the lobe cut. */
typedef struct {
  real ta_x, ta_y, ba_x, ba_y, ea_x, ea_y;
  real inv_sax, inv_say, norm, e_lim;
} KemppinenLevelLobe;

GLINT_FN KemppinenLevelLobe kemppinen_level_lobe(const GLINT_PRIVATE KemppinenParams *p,
                                                 const GLINT_PRIVATE KemppinenLevelQuery *q,
                                                 KemppinenLobe a) {
  KemppinenLevelLobe o;
  real res_a = q->s.res_a, inv_res_a = q->s.inv_res_a;
  real nr = (real)p->n_side;
  o.ta_x = a.x * res_a;
  o.ta_y = a.y * res_a;
  o.ba_x = kemppinen_angular_first(o.ta_x, nr, res_a);
  o.ba_y = kemppinen_angular_first(o.ta_y, nr, res_a);
  o.ea_x = glint_fmin_nn(o.ba_x + nr, res_a);
  o.ea_y = glint_fmin_nn(o.ba_y + nr, res_a);
  /* 1 / sigma_a and the angular norm in cells: exact rescalings by 2^-l. */
  o.inv_sax = a.inv_sx * inv_res_a;
  o.inv_say = a.inv_sy * inv_res_a;
  o.norm = q->s.norm_s * (a.norm * (inv_res_a * inv_res_a));
  o.e_lim = kemppinen_lobe_cut(o.norm);
  return o;
}

/* One explicit facet of the lobe (Algorithm 1 lines 13-18): its roulette-weighted lobe, 0 past
 * the grid's end, added to `sum` in its colour (K25 3.3.6, from its cell's hash). (dxc, dyc): the
 * query in cells of spatial cell j; `spatial_key`: spatial cell j's key, `word`: the cell's
 * (kemppinen_cell_word of (ix, iy), by kemppinen_cell_word_at). A
 * white material (p->white) adds the weight to sum->x only, and kemppinen_level_sum_white copies
 * it to y and z after the loops: the colour (1, 1, 1) times the weight is the weight exactly, so
 * each channel is the same sum in the same order as before, the same bits, without 3 products
 * and 2 sums per facet and light (the facet loop is ~125 instructions per 16 lanes). */
GLINT_FN void kemppinen_level_facet_add(const GLINT_PRIVATE KemppinenParams *p,
                                        const GLINT_PRIVATE KemppinenLevelQuery *q,
                                        const GLINT_PRIVATE KemppinenLevelLobe *o, real dxc,
                                        real dyc, kemp_uint spatial_key, kemp_uint word, real ix,
                                        real iy, real w, GLINT_PRIVATE real3 *sum) {
  kemp_uint key = kemppinen_absorb(spatial_key, word); /* kemppinen_facet_key */
  /* The offsets only: r and the colour pick (a third mix) where they are read. */
  KemppinenFacet g = kemppinen_facet_offsets(key);
  kemp_uint draws = key;
  if (!(p->one_level && p->white)) draws = kemppinen_facet_draws(key); /* uniform */
  real lobe =
      kemppinen_facet_lobe_at(q->s.inv_res_a, o->ta_x, o->ta_y, o->inv_sax, o->inv_say, dxc, dyc,
                              q->s.qxx, q->s.qxy, q->s.qyy, o->norm, o->e_lim, ix, iy, g);
  real wt;
  if (p->one_level) { /* uniform: a branch, not a select */
    /* One level (w = 1): R(r, 1) = 1 for every r, no roulette; keep = 1 below, and 1 * lobe =
     * lobe, keep > 0: the same bits without the product and the compare. n = 1: the one cell
     * [ba, ba + 1) never passes the grid's end (kemppinen_angular_first: ba <= res_a - 1, and
     * ba + 1 <= 2^24 is exact), so `valid` holds in every lane, even a dead one (a NaN ta
     * clamps to 0). */
    wt = p->n_side == 1 ? lobe : glint_select(GLINT_R(0.0), lobe, (ix < o->ea_x) & (iy < o->ea_y));
  } else {
    /* Cells past the grid's end (res_a < n at the coarsest levels) drop. */
    glint_mask valid = (ix < o->ea_x) & (iy < o->ea_y);
    /* No branch on the roulette: with 16 lanes some lane almost always
     * keeps the facet, and the branch cost 10% (measured at k = 1, 4). */
    real keep = kemppinen_roulette(kemppinen_u16_hi(draws), w);
    wt = glint_select(GLINT_R(0.0), keep * lobe, valid & (keep > GLINT_R(0.0)));
  }
  if (p->white) /* uniform */
    sum->x = sum->x + wt;
  else {
    g.pick = kemppinen_u16_lo(draws);
    *sum = r3_add(*sum, r3_scale(kemppinen_facet_color_of(p, g), wt));
  }
}

/* After kemppinen_level_facet_add's loop: a white material's sum is in x only. */
GLINT_FN real3 kemppinen_level_sum_white(const GLINT_PRIVATE KemppinenParams *p, real3 sum) {
  return p->white ? make_real3(sum.x, sum.x, sum.x) : sum;
}

/* The lobe's compensation (line 20) in the mean colour (each colour has probability 1/n),
 * times the level's weight w. */
GLINT_FN real3 kemppinen_level_compensation(const GLINT_PRIVATE KemppinenParams *p,
                                            const GLINT_PRIVATE KemppinenLevelQuery *q,
                                            const GLINT_PRIVATE KemppinenLevelLobe *o, real w) {
  real c =
      kemppinen_compensation_with(o->ta_x, o->ta_y, o->ba_x, o->ba_y, o->ea_x, o->ea_y, q->s.res_a,
                                  o->inv_sax, o->inv_say, q->outside, p->one_level);
  return r3_scale(p->mean_color, w * c);
}

/* Level l's part of S with MIP weight w: roulette-weighted explicit facets
 * (Algorithm 1 lines 13-18) plus w C (line 20). The loops have uniform trip
 * counts (4 spatial x n x n angular cells); a facet is skipped only when the
 * roulette drops it (or it lies past the grid) in every lane. */
GLINT_FN real3 kemppinen_level_at(const GLINT_PRIVATE KemppinenParams *p,
                                  const GLINT_PRIVATE KemppinenLevelQuery *q, KemppinenLobe a,
                                  real w) {
  KemppinenLevelLobe o = kemppinen_level_lobe(p, q, a);
  int n = p->n_side;
  real3 sum = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  int n_cells = p->one_cell ? 1 : 4;
  kemp_uint base_word = kemppinen_cell_word(o.ba_x, o.ba_y);
  for (int j = 0; j < n_cells; ++j) {
    real dxc = q->s.ts_x - (q->s.bs_x + (real)(j & 1));
    real dyc = q->s.ts_y - (q->s.bs_y + (real)(j >> 1));
    for (int my = 0; my < n; ++my) {
      real iy = o.ba_y + (real)my;
      for (int mx = 0; mx < n; ++mx)
        kemppinen_level_facet_add(p, q, &o, dxc, dyc, q->key[j],
                                  kemppinen_cell_word_at(base_word, mx, my), o.ba_x + (real)mx, iy,
                                  w, &sum);
    }
  }
  return r3_add(kemppinen_level_sum_white(p, sum), kemppinen_level_compensation(p, q, &o, w));
}

/* kemppinen_level_at for two lobes (two lights of the query) in one pass over the cells: per
 * lobe the same operations in the same order as kemppinen_level_at, so the same bits, but the
 * two lights' hash chains, exps and erfc are independent work in one loop body, which the CPU
 * overlaps (one light at a time was a chain of dependent long-latency steps: the hash's
 * multiplies, the exp, the divisions). */
GLINT_FN void kemppinen_level_at2(const GLINT_PRIVATE KemppinenParams *p,
                                  const GLINT_PRIVATE KemppinenLevelQuery *q, KemppinenLobe a,
                                  KemppinenLobe b, real w, GLINT_PRIVATE real3 *sa,
                                  GLINT_PRIVATE real3 *sb) {
  KemppinenLevelLobe oa = kemppinen_level_lobe(p, q, a);
  KemppinenLevelLobe ob = kemppinen_level_lobe(p, q, b);
  int n = p->n_side;
  real3 suma = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 sumb = suma;
  int n_cells = p->one_cell ? 1 : 4;
  kemp_uint base_a = kemppinen_cell_word(oa.ba_x, oa.ba_y);
  kemp_uint base_b = kemppinen_cell_word(ob.ba_x, ob.ba_y);
  for (int j = 0; j < n_cells; ++j) {
    real dxc = q->s.ts_x - (q->s.bs_x + (real)(j & 1));
    real dyc = q->s.ts_y - (q->s.bs_y + (real)(j >> 1));
    for (int my = 0; my < n; ++my) {
      real iya = oa.ba_y + (real)my, iyb = ob.ba_y + (real)my;
      for (int mx = 0; mx < n; ++mx) {
        kemppinen_level_facet_add(p, q, &oa, dxc, dyc, q->key[j],
                                  kemppinen_cell_word_at(base_a, mx, my), oa.ba_x + (real)mx, iya,
                                  w, &suma);
        kemppinen_level_facet_add(p, q, &ob, dxc, dyc, q->key[j],
                                  kemppinen_cell_word_at(base_b, mx, my), ob.ba_x + (real)mx, iyb,
                                  w, &sumb);
      }
    }
  }
  *sa = r3_add(kemppinen_level_sum_white(p, suma), kemppinen_level_compensation(p, q, &oa, w));
  *sb = r3_add(kemppinen_level_sum_white(p, sumb), kemppinen_level_compensation(p, q, &ob, w));
}

/* The same for one level of a footprint and angular query (the tests' entry). */
GLINT_FN real3 kemppinen_level(KemppinenParams p, KemppinenFootprint fp, KemppinenAngular a,
                               real level, real w) {
  KemppinenLevelQuery q = kemppinen_level_query(p, fp, level);
  return kemppinen_level_at(&p, &q, kemppinen_lobe(a), w);
}

/* Keeps a loop rolled on the device: the two MIP levels share one copy of the
 * level code (half the kernel's 25 KB of instructions, which did not fit the
 * CPU's micro-op cache). */
#ifdef __OPENCL_VERSION__
#define GLINT_KEMPPINEN_NOUNROLL _Pragma("nounroll")
#else
#define GLINT_KEMPPINEN_NOUNROLL
#endif

/* The one MIP level of the one-level neighbourhoods (GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL /
 * ONE_CELL, kemppinen_query_levels_into says why it is unbiased): the coarser, floor(lambda) + 1,
 * with probability w1 = lambda - floor(lambda) (the tent weight of Algorithm 1 lines 7-8), else
 * the finer, from a 24-bit uniform t hashed from the seed and the float bits of the query's uv,
 * clamped to the last level. A function of the footprint alone, so every pass of a query (the
 * point pass, the polygon pass kemppinen_polygon_glints) dithers to the same level: one query
 * sees one level's glints under all of its lights. */
GLINT_FN real kemppinen_dithered_level(KemppinenFootprint fp) {
  real lf = glint_floor(fp.lambda);
  real w1 = fp.lambda - lf;
  kemp_uint key =
      kemppinen_absorb(kemppinen_absorb((kemp_uint)(fp.seed_key ^ 0x6c6f6431u), rng_real_key(fp.u)),
                       rng_real_key(fp.v));
  /* t from the second absorb's word itself (a full lowbias32 mix plus a constant, a bijection:
   * uniform over 2^32), not from one more mix of it as until session 19: that mix added a chain
   * of two multiplies ahead of the level, the spatial key and every facet, and nothing to the
   * word's uniformity (OneLevel tests: the coarser level's frequency against w1). */
  real t = KEMP_TO_REAL(key >> 8) * GLINT_R(5.9604644775390625e-8);
  real level = glint_select(lf, lf + GLINT_R(1.0), t < w1);
  return glint_fmin_nn(level, GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL));
}

/* The two MIP levels of a query (Algorithm 1 lines 7-8: l in {floor, ceil}
 * of lambda, w = 1 - |lambda - l|; lambda <= GLINT_KEMPPINEN_MAX_LEVEL, so
 * w1 = 0 at the last level), prepared once for all of its lights. `n`: 2 if
 * some lane has w1 > 0 (uniform per block), else 1. */
typedef struct {
  KemppinenLevelQuery l[2];
  real w[2];
  int n;
} KemppinenQueryLevels;

/* In place, as kemppinen_level_query_into (2 x 1088 bytes on the device). */
GLINT_FN void kemppinen_query_levels_into(KemppinenParams p, KemppinenFootprint fp,
                                          GLINT_PRIVATE KemppinenQueryLevels *L) {
  real lf = glint_floor(fp.lambda);
  real w1 = fp.lambda - lf;
  if (p.one_level) {
    /* GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL / ONE_CELL (not in K25): one
     * level per query, the finer with probability w0 = 1 - w1 and the
     * coarser with w1, from a uniform t of the query's uv (and the seed), all
     * its facets at weight 1. Over t this is the tent blend of Algorithm 1
     * lines 7-8 in expectation: E_t[S] = w0 S_0 + w1 S_1, where K25's roulette
     * gives E_r[R(r, w) lobe] = w lobe per facet (Eq. 8), the same value; so
     * E[D_star] = D (Eq. 2) still holds, each level alone being a point
     * process of density K_P. What changes is the variance: a query near
     * w1 = 1/2 sees one level's glints at full strength or the other's, not
     * both at half (dithering between the levels across pixels), and half the
     * facets. t is a 24-bit uniform, so P(coarser) = w1 within 2^-24. */
    L->w[0] = GLINT_R(1.0);
    L->w[1] = GLINT_R(0.0);
    L->n = 1;
    /* l[1] is not set: only l[lv < n] is read (as in the two-level path when n = 1). */
    kemppinen_level_query_into(p, fp, kemppinen_dithered_level(fp), &L->l[0]);
    return;
  }
  L->w[0] = GLINT_R(1.0) - w1;
  L->w[1] = w1;
  L->n = glint_any(w1 > GLINT_R(0.0)) ? 2 : 1;
  GLINT_KEMPPINEN_NOUNROLL
  for (int lv = 0; lv < L->n; ++lv)
    kemppinen_level_query_into(
        p, fp, glint_fmin_nn(lf + (real)lv, GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL)), &L->l[lv]);
}

GLINT_FN KemppinenQueryLevels kemppinen_query_levels(KemppinenParams p, KemppinenFootprint fp) {
  KemppinenQueryLevels L;
  kemppinen_query_levels_into(p, fp, &L);
  return L;
}

/* kemppinen_lobe(kemppinen_angular(p, kemppinen_to_disk(h))) with fewer
 * divisions, for the point-light pass (one per light and query; a division or
 * square root costs ~10 multiplies on the CPU device, and this chain had 7
 * divisions and 3 roots per light). The same formulas rearranged, so the
 * values agree to a few fp32 roundings (not bit for bit; tested against the
 * composed functions in fp64):
 *  - GGX: |J_T| = (ax ay)^2 / (8 len^3) (kemppinen_to_disk), so 1 / sigma =
 *    1 / (alpha_star sqrt(|J_T|)) = len^(3/2) sqrt(8) / (alpha_star ax ay):
 *    one square root and a product, the quotient uniform per request (the
 *    composed form is a chain of 3 divisions and 2 roots per light).
 *  - both NDFs: 1 / sigma once, the anisotropic pair as products with a and
 *    1 / a (sigma_x = sigma / a, sigma_y = sigma a, Eq. 4). */
GLINT_FN KemppinenLobe kemppinen_lobe_of_h(const GLINT_PRIVATE KemppinenParams *p, int ndf, real3 h,
                                           real ax, real ay, real D) {
  KemppinenLobe l;
  real sd = GLINT_R(0.0); /* sqrt(|J_T|), Beckmann */
  if (ndf == GLINT_NDF_BECKMANN) {
    DiskPoint d = kemppinen_to_disk(ndf, h, ax, ay, D);
    l.x = d.x;
    l.y = d.y;
    sd = sqrt(glint_fmax_nn(d.jac, GLINT_R(0.0)));
  } else {
    /* kemppinen_to_disk's GGX branch (K25 3.2.1, Eq. 6-7). */
    real hz = glint_fmax_nn(h.z, GLINT_R(0.0));
    real3 s = make_real3(h.x * ay, h.y * ax, hz * ax * ay);
    /* The floor only keeps a dead h = 0 finite: a unit h has len >= ax ay >= 1e-8 (alpha in
     * [1e-4, 1], validation). */
    real len = glint_fmax_nn(glint_sqrt_nn(r3_dot(s, s)), GLINT_R(1e-15));
    /* Lambert's 1 / (2 len sqrt(1 + nz)), nz = s.z / len, as 1 / (2 sqrt(len (len + s.z))):
     * one division instead of two (s.z >= 0, nothing cancels; len (len + s.z) >= 1e-30 is a
     * normal float). fp32: ~4 roundings on k instead of ~5 (tested against long double,
     * DiskMap.PointPassLobeMatchesThePaperFormulas). */
    real k = GLINT_R(0.5) * glint_rsqrt_nn(len * (len + s.z));
    l.x = GLINT_R(0.5) + s.x * k;
    l.y = GLINT_R(0.5) + s.y * k;
    /* 1 / sigma = len^(3/2) sqrt(8) / (alpha_star ax ay): no division on the
     * chain after len (the last quotient is uniform). kemppinen_angular's
     * floor sigma >= 1e-12 becomes 1 / sigma <= 1e12; alpha_star ax ay >=
     * 1e-13 (validation), so the uniform factor is finite (and +inf only
     * gives the floor's 1e12, as sigma would); len >= 1e-15 > 0. */
    real c =
        (real)((real_scalar)2.8284271247461900976 /
               (GLINT_UNIFORM(p->micro) * GLINT_UNIFORM(ax) * GLINT_UNIFORM(ay))); /* uniform */
    real inv_s = glint_fmin_nn(len * glint_sqrt_nn(len) * c, GLINT_R(1e12));
    l.inv_sx = inv_s * p->aniso;
    l.inv_sy = inv_s * p->inv_aniso;
    l.norm = l.inv_sx * l.inv_sy * GLINT_R(0.15915494309189533577);
    return l;
  }
  /* kemppinen_angular's floor: sigma >= 1e-12, so a dead half-vector stays finite. */
  real inv_s = GLINT_R(1.0) / glint_fmax_nn(p->micro * sd, GLINT_R(1e-12));
  l.inv_sx = inv_s * p->aniso;
  l.inv_sy = inv_s * p->inv_aniso;
  l.norm = l.inv_sx * l.inv_sy * GLINT_R(0.15915494309189533577);
  return l;
}

/* S(x, h) = D_star / D (RGB: the facets' colours) for the query's levels and
 * half-vector h (unit). */
GLINT_FN real3 kemppinen_glint_factor_at(const GLINT_PRIVATE KemppinenParams *p,
                                         const GLINT_PRIVATE KemppinenQueryLevels *L, int ndf,
                                         real3 h, real ax, real ay, real D) {
  KemppinenLobe a = kemppinen_lobe_of_h(p, ndf, h, ax, ay, D);
  real3 s = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  GLINT_KEMPPINEN_NOUNROLL
  for (int lv = 0; lv < L->n; ++lv) s = r3_add(s, kemppinen_level_at(p, &L->l[lv], a, L->w[lv]));
  return s;
}

/* kemppinen_glint_factor_at for two half-vectors (two lights of the query), the levels'
 * facets and compensations of both in one pass (kemppinen_level_at2): the same bits as two
 * calls. */
GLINT_FN void kemppinen_glint_factor_at2(const GLINT_PRIVATE KemppinenParams *p,
                                         const GLINT_PRIVATE KemppinenQueryLevels *L, int ndf,
                                         real3 ha, real3 hb, real ax, real ay, real Da, real Db,
                                         GLINT_PRIVATE real3 *sa, GLINT_PRIVATE real3 *sb) {
  KemppinenLobe a = kemppinen_lobe_of_h(p, ndf, ha, ax, ay, Da);
  KemppinenLobe b = kemppinen_lobe_of_h(p, ndf, hb, ax, ay, Db);
  real3 za = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 zb = za;
  GLINT_KEMPPINEN_NOUNROLL
  for (int lv = 0; lv < L->n; ++lv) {
    real3 la, lb;
    kemppinen_level_at2(p, &L->l[lv], a, b, L->w[lv], &la, &lb);
    za = r3_add(za, la);
    zb = r3_add(zb, lb);
  }
  *sa = za;
  *sb = zb;
}

/* The same from the footprint (one half-vector; the tests' entry). */
GLINT_FN real3 kemppinen_glint_factor(KemppinenParams p, KemppinenFootprint fp, int ndf, real3 h,
                                      real ax, real ay, real D) {
  KemppinenQueryLevels L = kemppinen_query_levels(p, fp);
  return kemppinen_glint_factor_at(&p, &L, ndf, h, ax, ay, D);
}

#endif /* GLINT_KEMPPINEN_NDF_H */
