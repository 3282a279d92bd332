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
 * hash keys `kemp_uint` (uint, or uint8 on the 8-lane device), per-query
 * conditions are selects; a glint_any branch skips roulette-dropped facets. */
#ifndef GLINT_KEMPPINEN_NDF_H
#define GLINT_KEMPPINEN_NDF_H

#include "kernels/compat.h"
#include "kernels/ndf.h"
#include "kernels/rng.h"
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
  real density; /* K_P, facets per unit uv area */
  real micro;   /* alpha_star */
  real filter;  /* f */
  int n_side;   /* sqrt(k): angular cells per axis explicitly evaluated */
  real aniso;   /* a, A_star = diag(a, 1/a) */
  /* The facets' colours (K25 3.3.6), uniform over the lanes: n_colors >= 1
   * RGB triples (one white one without colours) and their mean, the colour
   * of the compensation (each facet takes colour c with probability 1/n). */
  int n_colors;
  float colors[3 * GLINT_KEMPPINEN_MAX_COLORS];
  real3 mean_color;
} KemppinenParams;

GLINT_FN KemppinenParams kemppinen_params_unpack(const GLINT_GLOBAL float *packed) {
  KemppinenParams p;
  p.density = (real)packed[GLINT_KEMPPINEN_DENSITY];
  p.micro = (real)packed[GLINT_KEMPPINEN_MICRO];
  p.filter = (real)packed[GLINT_KEMPPINEN_FILTER];
  int k = (int)packed[GLINT_KEMPPINEN_NEIGHBORS];
  p.n_side = k >= 16 ? 4 : k >= 9 ? 3 : k >= 4 ? 2 : 1;
  p.aniso = (real)packed[GLINT_KEMPPINEN_ANISO];
  int n = (int)packed[GLINT_KEMPPINEN_N_COLORS];
  n = n > GLINT_KEMPPINEN_MAX_COLORS ? GLINT_KEMPPINEN_MAX_COLORS : n;
  p.n_colors = n >= 1 ? n : 1;
  float sum[3] = {0.0f, 0.0f, 0.0f};
  for (int i = 0; i < 3 * GLINT_KEMPPINEN_MAX_COLORS; ++i) {
    p.colors[i] = n >= 1 ? packed[GLINT_KEMPPINEN_COLORS + i] : 1.0f;
    if (i < 3 * p.n_colors) sum[i % 3] += p.colors[i];
  }
  real inv_n = GLINT_R(1.0) / (real)p.n_colors;
  p.mean_color = make_real3((real)sum[0] * inv_n, (real)sum[1] * inv_n, (real)sum[2] * inv_n);
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
GLINT_FN real kemppinen_erfc_abs(real x) {
  real y = fabs(x) * GLINT_R(0.70710678118654752440);
  real t = GLINT_R(1.0) / (GLINT_R(1.0) + GLINT_R(0.3275911) * y);
  real poly =
      t *
      (GLINT_R(0.254829592) +
       t * (GLINT_R(-0.284496736) +
            t * (GLINT_R(1.421413741) + t * (GLINT_R(-1.453152027) + t * GLINT_R(1.061405429)))));
  return poly * exp(-y * y);
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

/* What one query needs whatever the half-vector: the pixel filter in the
 * stretched uv space x_s = A_star uv and the MIP levels. */
typedef struct {
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
  fp.xs = a * u;
  fp.ys = v / a;
  /* Columns of J_s = A_star J: (a du/dx, dv/dx / a) and (a du/dy, dv/dy / a). */
  /* Footprint entries clamped to +-1e6 uv per pixel: far beyond any useful
   * footprint (the level saturates at GLINT_KEMPPINEN_MAX_LEVEL long before),
   * and Sigma_s stays finite in fp32 (<= ~1e16) for any finite input. */
  real f = p.filter;
  real j00 = f * a * clamp(footprint[0], GLINT_R(-1e6), GLINT_R(1e6));
  real j10 = f * clamp(footprint[1], GLINT_R(-1e6), GLINT_R(1e6)) / a;
  real j01 = f * a * clamp(footprint[2], GLINT_R(-1e6), GLINT_R(1e6));
  real j11 = f * clamp(footprint[3], GLINT_R(-1e6), GLINT_R(1e6)) / a;
  /* Eq. 5 / Algorithm 1 line 11: Sigma_s = f^2 J J^T. */
  real sxx = j00 * j00 + j01 * j01;
  real syy = j10 * j10 + j11 * j11;
  real sxy = j00 * j10 + j01 * j11;
  real dj = j00 * j11 - j01 * j10; /* det Sigma_s = (det J_s)^2, without cancellation */
  real half_tr = GLINT_R(0.5) * (sxx + syy);
  real hd = GLINT_R(0.5) * (sxx - syy);
  real lmax = half_tr + sqrt(hd * hd + sxy * sxy);
  /* Regularisation (the det -> 0 pitfall of the shader's inv_quadratic): a
   * degenerate footprint (a line, a point) still gets a 2D filter, at least
   * 1% of its major axis and 1e-3 of the mean facet spacing 1/sqrt(K_P). */
  real eps = GLINT_R(1e-4) * lmax + GLINT_R(1e-6) / p.density;
  fp.sxx = sxx + eps;
  fp.syy = syy + eps;
  fp.sxy = sxy;
  fp.dj = dj;
  fp.tr = sxx + syy;
  fp.eps = eps;
  /* Level: finer level's cells (2^floor(lambda) / sqrt(K_P)) >= 4 sigma_max. */
  real sigma_max = sqrt(lmax + eps);
  real lambda = log2(fmax(GLINT_R(8.0) * sigma_max * sqrt(p.density), GLINT_R(1e-30)));
  fp.lambda = clamp(lambda, GLINT_R(0.0), GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL));
  fp.seed_key = rng_absorb(rng_absorb(0x4b323555u, seed_lo), seed_hi);
  return fp;
}

/* A cell index (an integer-valued real, possibly huge at uv = 1e7) as a hash
 * key, wrapped to [0, 2^24): the pattern repeats every 2^24 cells. */
GLINT_FN kemp_uint kemppinen_cell_key(real c) {
  real w = c - GLINT_R(16777216.0) * floor(c * GLINT_R(5.9604644775390625e-8));
  return KEMP_TO_UINT(clamp(w, GLINT_R(0.0), GLINT_R(16777215.0)));
}

/* K25 Eq. 8: GLINT_R(r, w) = smoothstep(max(0, r - eps), min(1, r + eps), w). */
GLINT_FN real kemppinen_roulette(real r, real w) {
  real e0 = fmax(GLINT_R(0.0), r - GLINT_R(GLINT_KEMPPINEN_ROULETTE_EPS));
  real e1 = fmin(GLINT_R(1.0), r + GLINT_R(GLINT_KEMPPINEN_ROULETTE_EPS));
  real t = clamp((w - e0) / (e1 - e0), GLINT_R(0.0), GLINT_R(1.0));
  return t * t * (GLINT_R(3.0) - GLINT_R(2.0) * t);
}

/* The facet of 4D cell (spatial cx, cy; angular ix, iy) at level l: offsets
 * in [0,1)^4 within its cell and its roulette number (K25 3.3.1). */
typedef struct {
  real sx, sy, ax, ay, r;
  real pick; /* in [0, 1): the colour is number floor(pick n) of n (K25 3.3.6) */
} KemppinenFacet;

/* The hash of (seed, level, spatial cell); facets absorb their angular cell. */
GLINT_FN kemp_uint kemppinen_spatial_key(uint seed_key, real level, real cx, real cy) {
  kemp_uint k = kemppinen_absorb((kemp_uint)(seed_key), KEMP_TO_UINT(level));
  return kemppinen_absorb(kemppinen_absorb(k, kemppinen_cell_key(cx)), kemppinen_cell_key(cy));
}

/* 16-bit uniforms, two per hash: k * 2^-16 is exact in float and double. A
 * facet's offsets are quantised to 1/65536 of its cell. */
GLINT_FN real kemppinen_u16_hi(kemp_uint h) {
  return KEMP_TO_REAL(h >> 16) * GLINT_R(1.52587890625e-5);
}
GLINT_FN real kemppinen_u16_lo(kemp_uint h) {
  return KEMP_TO_REAL(h & 0xffffu) * GLINT_R(1.52587890625e-5);
}

GLINT_FN KemppinenFacet kemppinen_facet(kemp_uint spatial_key, real ix, real iy) {
  kemp_uint key =
      kemppinen_absorb(kemppinen_absorb(spatial_key, KEMP_TO_UINT(ix)), KEMP_TO_UINT(iy));
  kemp_uint h1 = kemppinen_mix(key ^ 0x1u), h2 = kemppinen_mix(key ^ 0x2u);
  KemppinenFacet g;
  g.sx = kemppinen_u16_hi(h1);
  g.sy = kemppinen_u16_lo(h1);
  g.ax = kemppinen_u16_hi(h2);
  g.ay = kemppinen_u16_lo(h2);
  g.r = kemppinen_u16_hi(key);
  g.pick = kemppinen_u16_lo(key); /* bits 0-15, independent of r's 16-31 */
  return g;
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

/* The spatial 2x2 block and the angular n x n block of level l, in cells. */
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
  KemppinenBlocks b;
  /* Algorithm 1 lines 9-10 (with res = sqrt(K_P)). */
  b.res_a = floor(exp2(level) + GLINT_R(0.5)); /* 2^l exactly (l integer, <= 24) */
  b.res_s = sqrt(p.density) / b.res_a;
  b.ts_x = fp.xs * b.res_s;
  b.ts_y = fp.ys * b.res_s;
  /* 2x2 spatial cells around the nearest cell vertex. */
  b.bs_x = floor(b.ts_x - GLINT_R(0.5));
  b.bs_y = floor(b.ts_y - GLINT_R(0.5));
  /* n x n angular cells nearest x_a: around the nearest vertex (n even) or
   * centred on x_a's cell (n odd), kept inside [0, res_a) (the shader's
   * clamp has min > max at l <= 0, notes Sec. 5: here a block larger than
   * the grid is the whole grid). */
  real n = (real)p.n_side;
  real hi = fmax(b.res_a - n, GLINT_R(0.0));
  b.ta_x = a.x * b.res_a;
  b.ta_y = a.y * b.res_a;
  b.ba_x = clamp(floor(b.ta_x - GLINT_R(0.5) * (n - GLINT_R(1.0))), GLINT_R(0.0), hi);
  b.ba_y = clamp(floor(b.ta_y - GLINT_R(0.5) * (n - GLINT_R(1.0))), GLINT_R(0.0), hi);
  b.ea_x = fmin(b.ba_x + n, b.res_a);
  b.ea_y = fmin(b.ba_y + n, b.res_a);
  /* det of Sigma_s in cells^2, each factor scaled before multiplying: at
   * density 1e30 det Sigma_s itself underflows float (eps^2 ~ 1e-72). */
  real r2 = b.res_s * b.res_s;
  real djc = fp.dj * r2, ec = fp.eps * r2;
  real det_c = djc * djc + ec * (fp.tr * r2) + ec * ec;
  /* Sigma_c^-1 / 2 = adj(Sigma_s r2) / (2 det_c): scale the entries to cells
   * first (r2 / det_c alone overflows float at density 1e30, and 0 * inf is
   * NaN); each quotient is then ~1 / variance in cells, >= the regulariser. */
  b.qxx = GLINT_R(0.5) * (fp.syy * r2) / det_c;
  b.qxy = -(fp.sxy * r2) / det_c;
  b.qyy = GLINT_R(0.5) * (fp.sxx * r2) / det_c;
  real sax = a.sx * b.res_a, say = a.sy * b.res_a;
  b.inv_sax = GLINT_R(1.0) / sax;
  b.inv_say = GLINT_R(1.0) / say;
  b.norm = GLINT_R(1.0) / (GLINT_R(4.0) * GLINT_PI * GLINT_PI * sqrt(det_c) * sax * say);
  return b;
}

/* One facet's filtered lobe N(x_s - g_s; Sigma_s) N(x_a - g_a; Sigma_a) / K_P,
 * 0 if the facet lies outside the disk U (rejected, 3.3.1). Written in cell
 * units (K_P = res_s^2 res_a^2), so no factor of K_P over- or underflows. */
GLINT_FN real kemppinen_facet_lobe(KemppinenBlocks b, real cx, real cy, real ix, real iy,
                                   KemppinenFacet g) {
  real gx = (ix + g.ax) / b.res_a - GLINT_R(0.5);
  real gy = (iy + g.ay) / b.res_a - GLINT_R(0.5);
  glint_mask outside = gx * gx + gy * gy >= GLINT_R(0.25);
  /* Angular offsets in cells over the standard deviations in cells, spatial
   * offsets in cells through Sigma_s^-1 / 2; one exp for both Gaussians. */
  real ux = (b.ta_x - ix - g.ax) * b.inv_sax, uy = (b.ta_y - iy - g.ay) * b.inv_say;
  real dx = b.ts_x - cx - g.sx, dy = b.ts_y - cy - g.sy;
  real e =
      GLINT_R(0.5) * (ux * ux + uy * uy) + (b.qxx * dx * dx + b.qxy * dx * dy + b.qyy * dy * dy);
  return glint_select(exp(-e) * b.norm, GLINT_R(0.0), outside);
}

/* 1 - P_s: the pixel filter's mass outside the explicit 2x2 spatial block,
 * per axis from the diagonal of Sigma_s (cells); the query lies inside the
 * block, so 1 - mass is the two tails. */
GLINT_FN real kemppinen_spatial_outside(KemppinenFootprint fp, KemppinenBlocks b) {
  real ssx = sqrt(fp.sxx) * b.res_s, ssy = sqrt(fp.syy) * b.res_s;
  real sx0 = (b.bs_x - b.ts_x) / ssx, sx1 = (b.bs_x + GLINT_R(2.0) - b.ts_x) / ssx;
  real sy0 = (b.bs_y - b.ts_y) / ssy, sy1 = (b.bs_y + GLINT_R(2.0) - b.ts_y) / ssy;
  real tx = GLINT_R(0.5) * (kemppinen_erfc_abs(sx0) + kemppinen_erfc_abs(sx1));
  real ty = GLINT_R(0.5) * (kemppinen_erfc_abs(sy0) + kemppinen_erfc_abs(sy1));
  return tx + (GLINT_R(1.0) - tx) * ty;
}

/* K25 Eq. 9-10 for level l: the expected lobe mass of the facets not
 * evaluated explicitly,
 *   C = P_a(square) - P_s(spatial block) P_a(B(k) in the square)
 *     = [P_a(square) - P_a(B)] + (1 - P_s) P_a(B),
 * both brackets from tails (no difference of two numbers near 1). */
GLINT_FN real kemppinen_compensation(KemppinenFootprint fp, KemppinenAngular a, KemppinenBlocks b) {
  /* Angular, per axis, in units of the lobe's standard deviation. */
  real sax = a.sx * b.res_a, say = a.sy * b.res_a;
  real x0 = -b.ta_x / sax, x1 = (b.ba_x - b.ta_x) / sax;
  real x2 = (b.ea_x - b.ta_x) / sax, x3 = (b.res_a - b.ta_x) / sax;
  real y0 = -b.ta_y / say, y1 = (b.ba_y - b.ta_y) / say;
  real y2 = (b.ea_y - b.ta_y) / say, y3 = (b.res_a - b.ta_y) / say;
  /* erfc at the 4 edges per axis, each used by two masses. */
  real ex0 = kemppinen_erfc_abs(x0), ex1 = kemppinen_erfc_abs(x1);
  real ex2 = kemppinen_erfc_abs(x2), ex3 = kemppinen_erfc_abs(x3);
  real ey0 = kemppinen_erfc_abs(y0), ey1 = kemppinen_erfc_abs(y1);
  real ey2 = kemppinen_erfc_abs(y2), ey3 = kemppinen_erfc_abs(y3);
  real xb = kemppinen_mass_e(x1, x2, ex1, ex2), yb = kemppinen_mass_e(y1, y2, ey1, ey2);
  real xsq = kemppinen_mass_e(x0, x3, ex0, ex3);
  real xout = kemppinen_mass_e(x0, x1, ex0, ex1) + kemppinen_mass_e(x2, x3, ex2, ex3);
  real yout = kemppinen_mass_e(y0, y1, ey0, ey1) + kemppinen_mass_e(y2, y3, ey2, ey3);
  real square_minus_block = xsq * yout + yb * xout; /* = P_a(square) - P_a(B) */
  return fmax(square_minus_block + kemppinen_spatial_outside(fp, b) * xb * yb, GLINT_R(0.0));
}

/* K25 3.3.6: facet g's colour, number floor(pick n) of the n colours (each
 * with probability 1/n up to 2^-16: pick is a 16-bit uniform), by selects
 * (the index is per lane, the colour table uniform). */
GLINT_FN real3 kemppinen_facet_color(KemppinenParams p, KemppinenFacet g) {
  real idx = floor(g.pick * (real)p.n_colors);
  real3 c = make_real3((real)p.colors[0], (real)p.colors[1], (real)p.colors[2]);
  for (int k = 1; k < p.n_colors; ++k) {
    real3 ck =
        make_real3((real)p.colors[3 * k], (real)p.colors[3 * k + 1], (real)p.colors[3 * k + 2]);
    c = r3_select(c, ck, idx >= (real)k);
  }
  return c;
}

/* Level l's part of S with MIP weight w: roulette-weighted explicit facets
 * (Algorithm 1 lines 13-18) plus w C (line 20). */
GLINT_FN real3 kemppinen_level(KemppinenParams p, KemppinenFootprint fp, KemppinenAngular a,
                               real level, real w) {
  KemppinenBlocks b = kemppinen_blocks(p, fp, a, level);
  real3 sum = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  int n = p.n_side;
  for (int j = 0; j < 4; ++j) {
    real cx = b.bs_x + (real)(j & 1);
    real cy = b.bs_y + (real)(j >> 1);
    kemp_uint key = kemppinen_spatial_key(fp.seed_key, level, cx, cy);
    for (int m = 0; m < n * n; ++m) {
      real ix = b.ba_x + (real)(m % n);
      real iy = b.ba_y + (real)(m / n);
      /* Cells past the grid's end (res_a < n at the coarsest levels) drop. */
      glint_mask valid = (ix < b.ea_x) & (iy < b.ea_y);
      KemppinenFacet g = kemppinen_facet(key, ix, iy);
      real keep = kemppinen_roulette(g.r, w);
      if (glint_any(valid & (keep > GLINT_R(0.0)))) {
        real wt =
            glint_select(GLINT_R(0.0), keep * kemppinen_facet_lobe(b, cx, cy, ix, iy, g), valid);
        /* K25 3.3.6: the facet's colour from its cell's hash. */
        sum = r3_add(sum, r3_scale(kemppinen_facet_color(p, g), wt));
      }
    }
  }
  /* The compensation in the mean colour (each colour has probability 1/n). */
  return r3_add(sum, r3_scale(p.mean_color, w * kemppinen_compensation(fp, a, b)));
}

/* S(x, h) = D_star / D (RGB: the facets' colours) for the query's footprint
 * and half-vector h (unit). */
GLINT_FN real3 kemppinen_glint_factor(KemppinenParams p, KemppinenFootprint fp, int ndf, real3 h,
                                      real ax, real ay, real D) {
  KemppinenAngular a = kemppinen_angular(p, kemppinen_to_disk(ndf, h, ax, ay, D));
  /* Algorithm 1 lines 7-8: l in {floor, ceil} of lambda, w = 1 - |lambda - l|
   * (lambda <= GLINT_KEMPPINEN_MAX_LEVEL, so w1 = 0 at the last level). */
  real lf = floor(fp.lambda);
  real w1 = fp.lambda - lf;
  real3 s = kemppinen_level(p, fp, a, lf, GLINT_R(1.0) - w1);
  if (glint_any(w1 > GLINT_R(0.0)))
    s = r3_add(s, kemppinen_level(p, fp, a,
                                  fmin(lf + GLINT_R(1.0), GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL)), w1));
  return s;
}

#endif /* GLINT_KEMPPINEN_NDF_H */
