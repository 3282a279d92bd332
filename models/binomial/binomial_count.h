/* Counting reflecting microfacets in a pixel footprint: the stochastic half
 * of the binomial glint model (Kneiphof & Klein 2024, "KK24", Eq. 11 and 16,
 * which leaves the counting machinery to Deliot & Belcour 2023, "DB23").
 *
 *  1. The footprint: the pixel's uv Jacobian J (columns du/dx and du/dy) maps
 *     the pixel square to a parallelogram of area |det J| holding
 *     N_P = density * |det J| facets. Its covariance J J^T gives the ellipse
 *     (semi-axes a >= b, major-axis angle theta) that shapes the grid cells.
 *  2. An implicit anisotropic grid over uv (after DB23 Sec. 4): cells of
 *     2^l by 2^l r_q, rotated to theta_k, so that one cell is about one
 *     footprint and a cell keeps its random numbers while the footprint moves
 *     inside it. l, r_q and theta_k are quantised (powers of two; pi / (4 r_q)
 *     rotation bins); the footprint's continuous (log2 b, log2 r, theta) lies
 *     between 2 x 2 x 2 quantised grids with trilinear weights w_g. The
 *     facets are SPLIT between them (grid g holds w_g N_P of the N_P trials,
 *     DB23's "distributed binomial"), so a footprint between levels neither
 *     doubles nor cross-fades glints: the total count is a sum of binomials
 *     with exactly N_P trials and its mean is N_P p at every blend.
 *     Departure from DB23: trilinear (8 grids) instead of their tetrahedral
 *     split (4 grids) - simpler, and the cost is the per-grid draw below;
 *     cells are plain rectangles instead of a simplex lattice with blended
 *     vertices, since our output is a per-pixel count, not a smooth NDF
 *     texture; N per grid is w_g N_P from the true footprint area instead of
 *     the quantised cell area, so the count matches the footprint exactly.
 *  3. Per grid cell, the number of facets oriented into Omega_h is a draw of
 *     Binomial(w_g N_P, p) from a counter-based hash of (seed, grid, cell,
 *     angular cell, light) - kernels/rng.h - by inversion, so for a fixed cell
 *     the count grows monotonically with p and glints appear in place as a
 *     light or the view moves.
 *
 * Written for GLINT_LANES == 1 (per-query loops and branches). */
#ifndef GLINT_BINOMIAL_COUNT_H
#define GLINT_BINOMIAL_COUNT_H

#include "kernels/compat.h"
#include "kernels/rng.h"
#include "models/binomial/binomial_params.h"

/* Trials up to this count are sampled exactly (CDF inversion, O(n)). */
#define GLINT_BINOMIAL_EXACT_MAX 64
/* Anisotropy of grid cells is clamped to 2^6: a thinner footprint (grazing
 * view) still gets its facet count from its true area, only its cells stop
 * stretching. */
#define GLINT_BINOMIAL_MAX_ANISO_LOG2 6
#define GLINT_BINOMIAL_GRIDS 8

/* The packed parameter block: models/binomial/binomial_params.h. */
typedef struct {
  real density;          /* facets per unit uv area */
  int p_mode;            /* GLINT_P_MODE_* */
  real r;                /* HEURISTIC_R: p = r D(h) / D(n) (DB23) */
  real normal_threshold; /* variance n p (1 - p) from which counts are normal */
  real slope_cell;       /* angular correlation length of the pattern, slope units */
} BinomialParams;

GLINT_FN BinomialParams binomial_params_unpack(const GLINT_GLOBAL float *packed) {
  BinomialParams b;
  b.density = (real)packed[0];
  b.p_mode = (int)packed[1];
  b.r = (real)packed[2];
  b.normal_threshold = (real)packed[3];
  b.slope_cell = (real)packed[4];
  return b;
}

/* The footprint's grids: per grid its share of the facets and the hash of
 * (seed, grid, cell) that seeds every draw in it. */
typedef struct {
  real n_facets; /* N_P = density * |det J| */
  real share[GLINT_BINOMIAL_GRIDS];
  uint cell_key[GLINT_BINOMIAL_GRIDS];
} FootprintGrids;

/* Key of a cell coordinate (a floored real): its float bits. Beyond 2^24
 * cells (uv ~ 1e7 at fine levels) neighbours share keys, which is harmless. */
GLINT_FN uint binomial_cell_key(real c) {
  return rng_float_key((float)c);
}

/* Step 1 and 2 above. `footprint` = (du/dx, dv/dx, du/dy, dv/dy). */
GLINT_FN FootprintGrids binomial_footprint_grids(real density, real u, real v,
                                                 const GLINT_PRIVATE real *footprint, uint seed_lo,
                                                 uint seed_hi) {
  FootprintGrids g;
  real x1 = footprint[0], y1 = footprint[1], x2 = footprint[2], y2 = footprint[3];
  real area = fabs(x1 * y2 - x2 * y1);
  g.n_facets = density * area;
  if (!(g.n_facets > R(0.0)) || !isfinite(g.n_facets)) g.n_facets = R(0.0);

  /* Ellipse of the covariance J J^T = [[A, B], [B, C]]: eigenvalues
   * m +- d; the small one as det / large (no cancellation), the major-axis
   * angle from atan2, which needs no eigenvector (DB23's (L - d, c) form
   * degenerates for axis-aligned footprints, see the notes' pitfalls). */
  real A = x1 * x1 + x2 * x2, B = x1 * y1 + x2 * y2, C = y1 * y1 + y2 * y2;
  real half_diff = R(0.5) * (A - C);
  real lambda1 = R(0.5) * (A + C) + sqrt(half_diff * half_diff + B * B);
  real major = sqrt(fmax(lambda1, R(0.0)));
  real minor = lambda1 > R(0.0) ? area / major : R(0.0); /* sqrt(det) / sqrt(lambda1) */
  real theta = R(0.5) * atan2(R(2.0) * B, A - C);        /* (-pi/2, pi/2] */
  if (theta < R(0.0)) theta += GLINT_PI;
  if (!(major > R(0.0)) || !isfinite(major)) {
    /* No usable footprint: one unit cell per uv unit (the count is 0 anyway
     * unless the Jacobian is degenerate but the density infinite). */
    major = R(1.0);
    minor = R(1.0);
    theta = R(0.0);
  }
  const real max_aniso = (real)(1 << GLINT_BINOMIAL_MAX_ANISO_LOG2);
  minor = fmax(minor, major / max_aniso);

  real lod = log2(minor);
  real lod0 = floor(lod);
  real t_lod = lod - lod0;
  real aniso = fmin(log2(major / minor), (real)GLINT_BINOMIAL_MAX_ANISO_LOG2);
  aniso = fmax(aniso, R(0.0));
  real aniso0 = floor(aniso);
  real t_aniso = aniso - aniso0;

  uint seed_key = rng_hash2(seed_lo, seed_hi);
  int k = 0;
  for (int il = 0; il < 2; ++il) {
    real level = lod0 + (real)il;
    real w_l = il ? t_lod : R(1.0) - t_lod;
    real side = exp2(level);
    for (int ia = 0; ia < 2; ++ia) {
      real aniso_level = aniso0 + (real)ia;
      real w_a = ia ? t_aniso : R(1.0) - t_aniso;
      real ratio = exp2(aniso_level);
      /* pi / (4 r) bins: a cell r sides long, misaligned by half a bin,
       * moves its far end by ~pi/8 of its short side. */
      real bins = R(4.0) * ratio;
      real pos = theta * bins / GLINT_PI;
      real bin0 = floor(pos);
      real t_rot = pos - bin0;
      for (int ir = 0; ir < 2; ++ir) {
        real bin = bin0 + (real)ir;
        real w_r = ir ? t_rot : R(1.0) - t_rot;
        real angle = bin * GLINT_PI / bins;
        real c = cos(angle), s = sin(angle);
        real along = (c * u + s * v) / (side * ratio);
        real across = (-s * u + c * v) / side;
        uint key = rng_absorb(seed_key, binomial_cell_key(level));
        key = rng_absorb(key, binomial_cell_key(aniso_level));
        /* bins wrap at pi: bin 4r is bin 0 */
        key = rng_absorb(key, binomial_cell_key(bin >= bins ? bin - bins : bin));
        key = rng_absorb(key, binomial_cell_key(floor(along)));
        key = rng_absorb(key, binomial_cell_key(floor(across)));
        g.cell_key[k] = key;
        g.share[k] = w_l * w_a * w_r;
        ++k;
      }
    }
  }
  return g;
}

/* Standard normal from two uniforms (Box & Muller 1958). u1 in (0, 1]. */
GLINT_FN real binomial_gaussian(uint h1, uint h2) {
  real u1 = R(1.0) - rng_u01(h1);
  real u2 = rng_u01(h2);
  return sqrt(R(-2.0) * log(u1)) * cos(R(2.0) * GLINT_PI * u2);
}

/* Binomial(n, q) for integer n <= GLINT_BINOMIAL_EXACT_MAX and q <= 1/2 by
 * inversion of the CDF with the uniform u: pmf(0) = (1 - q)^n =
 * exp(n log1p(-q)) (no cancellation for tiny q; >= 2^-64, no underflow),
 * pmf(k + 1) = pmf(k) (n - k) / (k + 1) q / (1 - q). */
GLINT_FN real binomial_exact(real n, real q, real u) {
  real pmf = exp(n * log1p(-q));
  real cdf = pmf;
  real ratio = q / (R(1.0) - q);
  real k = R(0.0);
  while (u >= cdf && k < n) {
    pmf *= (n - k) / (k + R(1.0)) * ratio;
    k += R(1.0);
    cdf += pmf;
  }
  return k;
}

/* Poisson(lambda) by inversion (Devroye 1986, X.3.3), for the small means
 * binomial_draw sends here (lambda < 2 * threshold <= 80, so exp(-lambda)
 * stays a normal float). Capped at `cap`. */
GLINT_FN real binomial_poisson(real lambda, real u, real cap) {
  real pmf = exp(-lambda);
  real cdf = pmf;
  real k = R(0.0);
  while (u >= cdf && k < cap && pmf > R(0.0)) {
    k += R(1.0);
    pmf *= lambda / k;
    cdf += pmf;
  }
  return k;
}

/* A draw of "Binomial(n, p)" for real n >= 0: floor(n) whole trials plus one
 * partial trial that succeeds with probability frac(n) p, so that the mean is
 * n p exactly for every real n (a footprint holding 0.3 facets reflects with
 * probability 0.3 p; with N_P < 1 this is what keeps the estimator unbiased).
 * Whole trials: exact inversion up to GLINT_BINOMIAL_EXACT_MAX; above it a
 * normal approximation when the variance n p (1 - p) reaches `threshold`
 * (continuous, clamped to [0, n], as DB23 and KK24's code do), otherwise a
 * Poisson draw for the rarer outcome (p or 1 - p; the variance bound keeps its
 * mean below 2 threshold). The draw uses `key`'s stream only. */
GLINT_FN real binomial_draw(real n, real p, real threshold, uint key) {
  if (!(n > R(0.0)) || !(p > R(0.0))) return R(0.0);
  p = fmin(p, R(1.0));
  real whole = floor(n);
  real part = n - whole;
  real k = R(0.0);
  real u = rng_u01(rng_absorb(key, 1u));
  if (whole > R(0.0)) {
    int flip = p > R(0.5);
    real q = flip ? R(1.0) - p : p;
    real draw;
    if (whole <= (real)GLINT_BINOMIAL_EXACT_MAX) {
      draw = binomial_exact(whole, q, u);
    } else if (whole * q * (R(1.0) - q) >= threshold) {
      real g = binomial_gaussian(rng_absorb(key, 2u), rng_absorb(key, 3u));
      draw = clamp(whole * q + sqrt(whole * q * (R(1.0) - q)) * g, R(0.0), whole);
    } else {
      draw = binomial_poisson(whole * q, u, whole);
    }
    k = flip ? whole - draw : draw;
  }
  if (part > R(0.0) && rng_u01(rng_absorb(key, 4u)) < part * p) k += R(1.0);
  return k;
}

/* sum_g k_g / N_P: the footprint's fraction of facets that reflect, whose
 * mean is p (the factor b(N_P, p) / N_P of KK24 Eq. 11 and 16). `light_key`
 * identifies the light and the angular cell. 0 when the footprint holds no
 * facets. */
GLINT_FN real binomial_fraction(FootprintGrids g, real p, real threshold, uint light_key) {
  if (!(g.n_facets > R(0.0)) || !(p > R(0.0))) return R(0.0);
  real count = R(0.0);
  for (int k = 0; k < GLINT_BINOMIAL_GRIDS; ++k) {
    if (!(g.share[k] > R(0.0))) continue;
    count +=
        binomial_draw(g.share[k] * g.n_facets, p, threshold, rng_absorb(g.cell_key[k], light_key));
  }
  return count / g.n_facets;
}

#endif /* GLINT_BINOMIAL_COUNT_H */
