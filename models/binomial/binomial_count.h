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
 *     angular cell, light) - kernels/rng.h - as a quantile of ONE uniform u of
 *     that hash, in every regime: exact inversion of the binomial CDF while the
 *     variance is small (up to 64 trials always), a rounded arcsine normal
 *     approximation with a Cornish-Fisher skew term above the threshold, and
 *     at each switch the maximum with the value the previous regime reached.
 *     For fixed u the quantile of a binomial is non-decreasing in p (its CDF
 *     at any k decreases as p grows), each approximation is built to be too,
 *     and no switch can lower it: for a fixed cell the count never falls as p
 *     grows, so glints appear in place as a light grows (a facet that
 *     reflects a small light also reflects a larger concentric one). See
 *     binomial_whole.
 *     The count is a pure function of (seed, grid, cell, light key): the same
 *     however a batch is split.
 *
 * Lane-safe (kernels/compat.h): no branch on per-query values, so the lane
 * kernel (binomial_lanes.cl) runs GLINT_LANES queries per work-item with the
 * same code the host runs on scalars. Per-query branches are selects; the
 * searches of the exact regime loop while any lane still searches (a uniform
 * bound, per-lane masks freeze the lanes that have stopped), and a regime is
 * computed when any lane of the work-item needs it (glint_any). Per lane the
 * arithmetic is the sequential one, so a lane's count is the scalar count.
 * What diverges: the exact searches (O(count of the rarer outcome) steps, the
 * work-item pays the largest of its lanes) and, per draw, lanes in different
 * regimes (the work-item pays the approximation and a search; binomial_lanes.cl regroups
 * the draws of several blocks by regime where a query has one draw, through the stages of
 * binomial_whole_prob below). */
#ifndef GLINT_BINOMIAL_COUNT_H
#define GLINT_BINOMIAL_COUNT_H

#include "kernels/compat.h"
#include "kernels/rng.h"
#include "models/binomial/binomial_params.h"
#include "models/binomial/binomial_trig.h"

/* This file's loops and regime branches test their masks with glint_any_by_mask (kernels/compat.h:
 * the mask register, vpmovd2m + kortest) instead of glint_any's OR reduction, which PoCL lowers
 * to ~10 extract / or / shuffle instructions on the vector unit. The exact search ran two per
 * 4-step trip (binomial_exact_log), ~20 of its ~120 instructions, and the trip is bound by the
 * vector unit's throughput (models/binomial/README.md "Quad throughput (session 18): the count
 * draw at N_P = 1e2"); with the band pre-filter a trip runs two (the loop's condition, the band)
 * and a third only when a lane is in the band. The same truth value, so the same branches and
 * results. */

/* Trials up to this count are always sampled exactly (CDF inversion, O(count of the rarer
 * outcome)); above it only while the variance is below the normal threshold. */
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
  real normal_threshold; /* variance n p (1 - p) from which counts are approximated */
  real slope_cell;       /* angular correlation length of the pattern, slope units */
  int interpolation;     /* GLINT_BINOMIAL_TRILINEAR, _TETRAHEDRAL or _STOCHASTIC */
} BinomialParams;

GLINT_FN BinomialParams binomial_params_unpack(const GLINT_GLOBAL float *packed) {
  BinomialParams b;
  b.density = (real)packed[0];
  b.p_mode = (int)packed[1];
  b.r = (real)packed[2];
  b.normal_threshold = (real)packed[3];
  b.slope_cell = (real)packed[4];
  b.interpolation = (int)packed[5];
  return b;
}

/* The footprint's grids: per grid its share of the facets and the hash of
 * (seed, grid, cell) that seeds every draw in it. */
typedef struct {
  real n_facets; /* N_P = density * |det J| */
  real share[GLINT_BINOMIAL_GRIDS];
  glint_key cell_key[GLINT_BINOMIAL_GRIDS];
} FootprintGrids;

/* Key of a cell coordinate (a floored real): its float bits. Beyond 2^24
 * cells (uv ~ 1e7 at fine levels) neighbours share keys, which is harmless. */
GLINT_FN glint_key binomial_cell_key(real c) {
  return rng_real_key(c);
}

/* Step 1 above: the footprint's facet count and its ellipse's continuous grid coordinates,
 * which both interpolations (trilinear below, tetrahedral in binomial_tetrahedral.h) share. */
typedef struct {
  real n_facets; /* N_P = density * |det J|, 0 when not finite and positive */
  real lod;      /* log2 of the minor semi-axis (after the anisotropy clamp) */
  real aniso;    /* log2(major / minor) in [0, GLINT_BINOMIAL_MAX_ANISO_LOG2] */
  real theta;    /* the major axis' angle in [0, pi) */
} FootprintShape;

/* `footprint` = (du/dx, dv/dx, du/dy, dv/dy). */
GLINT_FN FootprintShape binomial_footprint_shape(real density,
                                                 const GLINT_PRIVATE real *footprint) {
  FootprintShape f;
  real x1 = footprint[0], y1 = footprint[1], x2 = footprint[2], y2 = footprint[3];
  real area = fabs(x1 * y2 - x2 * y1);
  f.n_facets = density * area;
  f.n_facets =
      glint_select(f.n_facets, GLINT_R(0.0), !(f.n_facets > GLINT_R(0.0)) | !isfinite(f.n_facets));

  /* Ellipse of the covariance J J^T = [[A, B], [B, C]]: eigenvalues
   * m +- d; the small one as det / large (no cancellation), the major-axis
   * angle from atan2, which needs no eigenvector (DB23's (L - d, c) form
   * degenerates for axis-aligned footprints, see the notes' pitfalls). */
  real A = x1 * x1 + x2 * x2, B = x1 * y1 + x2 * y2, C = y1 * y1 + y2 * y2;
  real half_diff = GLINT_R(0.5) * (A - C);
  real lambda1 = GLINT_R(0.5) * (A + C) + sqrt(half_diff * half_diff + B * B);
  real major = sqrt(glint_fmax_nn(lambda1, GLINT_R(0.0)));
  /* sqrt(det) / sqrt(lambda1) */
  real minor = glint_select(GLINT_R(0.0), area / major, lambda1 > GLINT_R(0.0));
  real theta = GLINT_R(0.5) * atan2(GLINT_R(2.0) * B, A - C); /* (-pi/2, pi/2] */
  theta = glint_select(theta, theta + GLINT_PI, theta < GLINT_R(0.0));
  /* No usable footprint: one unit cell per uv unit (the count is 0 anyway
   * unless the Jacobian is degenerate but the density infinite). */
  glint_mask unusable = !(major > GLINT_R(0.0)) | !isfinite(major);
  major = glint_select(major, GLINT_R(1.0), unusable);
  minor = glint_select(minor, GLINT_R(1.0), unusable);
  theta = glint_select(theta, GLINT_R(0.0), unusable);
  const real max_aniso = GLINT_R(1 << GLINT_BINOMIAL_MAX_ANISO_LOG2);
  minor = glint_fmax_nn(minor, major / max_aniso);

  f.lod = log2(minor);
  real aniso = glint_fmin_nn(log2(major / minor), GLINT_R(GLINT_BINOMIAL_MAX_ANISO_LOG2));
  f.aniso = glint_fmax_nn(aniso, GLINT_R(0.0));
  f.theta = theta;
  return f;
}

/* Step 2 above, trilinear. `footprint` = (du/dx, dv/dx, du/dy, dv/dy). */
GLINT_FN FootprintGrids binomial_footprint_grids(real density, real u, real v,
                                                 const GLINT_PRIVATE real *footprint, uint seed_lo,
                                                 uint seed_hi) {
  FootprintGrids g;
  FootprintShape f = binomial_footprint_shape(density, footprint);
  g.n_facets = f.n_facets;
  real theta = f.theta;
  real lod = f.lod;
  real lod0 = glint_floor(lod);
  real t_lod = lod - lod0;
  real aniso = f.aniso;
  real aniso0 = glint_floor(aniso);
  real t_aniso = aniso - aniso0;

  glint_key seed_key = rng_hash2(seed_lo, seed_hi);
  /* The rotations depend on the anisotropy level and the bin, not on the level: their
   * cosines, sines and rotated uv once for the 4 (ia, ir) pairs, j = 2 ia + ir. */
  real aniso_level[2] = {aniso0 + GLINT_R(0.0), aniso0 + GLINT_R(1.0)};
  real w_a[2], ratio[2], rot_u[4], rot_v[4], w_r[4];
  glint_key bin_key[4];
  for (int ia = 0; ia < 2; ++ia) {
    w_a[ia] = ia ? t_aniso : GLINT_R(1.0) - t_aniso;
    ratio[ia] = exp2(aniso_level[ia]);
    /* pi / (4 r) bins: a cell r sides long, misaligned by half a bin,
     * moves its far end by ~pi/8 of its short side. */
    real bins = GLINT_R(4.0) * ratio[ia];
    real pos = theta * bins / GLINT_PI;
    real bin0 = glint_floor(pos);
    real t_rot = pos - bin0;
    for (int ir = 0; ir < 2; ++ir) {
      int j = 2 * ia + ir;
      real bin = bin0 + (ir ? GLINT_R(1.0) : GLINT_R(0.0));
      w_r[j] = ir ? t_rot : GLINT_R(1.0) - t_rot;
      real angle = bin * GLINT_PI / bins;
      real c = cos(angle), s = sin(angle);
      rot_u[j] = c * u + s * v;
      rot_v[j] = -s * u + c * v;
      /* bins wrap at pi: bin 4r is bin 0 */
      bin_key[j] = binomial_cell_key(glint_select(bin, bin - bins, bin >= bins));
    }
  }
  int k = 0;
  for (int il = 0; il < 2; ++il) {
    real level = lod0 + (il ? GLINT_R(1.0) : GLINT_R(0.0));
    real w_l = il ? t_lod : GLINT_R(1.0) - t_lod;
    real side = exp2(level);
    glint_key level_key = rng_absorb_key(seed_key, binomial_cell_key(level));
    for (int ia = 0; ia < 2; ++ia) {
      glint_key aniso_key = rng_absorb_key(level_key, binomial_cell_key(aniso_level[ia]));
      for (int ir = 0; ir < 2; ++ir) {
        int j = 2 * ia + ir;
        real along = rot_u[j] / (side * ratio[ia]);
        real across = rot_v[j] / side;
        glint_key key = rng_absorb_key(aniso_key, bin_key[j]);
        key = rng_absorb_key(key, binomial_cell_key(glint_floor(along)));
        key = rng_absorb_key(key, binomial_cell_key(glint_floor(across)));
        g.cell_key[k] = key;
        g.share[k] = w_l * w_a[ia] * w_r[j];
        ++k;
      }
    }
  }
  return g;
}

/* The running pmf and CDF of binomial_exact are kept scaled by 2^90: pmf(0) = (1 - q)^n
 * reaches 2^-160 (n < 4 x 40 trials stay exact up to q = 1/2), below fp32's range; scaled it is
 * >= 2^-70, and no scaled term exceeds 2^90. It is formed as (exp(A / 2) 2^45)^2, A =
 * n log1p(-q), so that the scale adds one rounding (inside exp it would add the rounding of
 * A + 62.4, 2^-19 in fp32). A power of two scales u exactly. */
#define GLINT_BINOMIAL_PMF_SCALE GLINT_R(1237940039285380274899124224.0)
#define GLINT_BINOMIAL_PMF_SCALE_SQRT GLINT_R(35184372088832.0)
/* Unit roundoff of `real` (a function, not a macro: the tests include this header for both
 * precisions in one translation unit). */
GLINT_FN real binomial_eps(void) {
  return GLINT_USE_DOUBLE ? GLINT_R(1.1102230246251565e-16) : GLINT_R(5.9604644775390625e-8);
}

/* (n - i) / (i + 1), the recurrence's factor pmf(i + 1) / pmf(i) before q / (1 - q), for the
 * search's step count i, which is the same in every lane (`real_scalar`, kernels/compat.h).
 * Correctly rounded everywhere, so the same bits as the division. On the fp32 AVX-512 device
 * it is Markstein's correction of a product by the reciprocal (P. Markstein 1990, "Computation
 * of elementary functions on the IBM RISC System/6000 processor"; Muller et al., Handbook of
 * Floating-Point Arithmetic, 2nd ed., Sec. 4.9.2): y = RN(1 / b) as ONE scalar division shared
 * by all lanes, q0 = RN(a y), r = a - b q0 (exact with a fused multiply-add), RN(q0 + r y) =
 * RN(a / b). Why: a vdivps of 16 lanes keeps the divider busy 10-12 cycles (kernels/compat.h
 * glint_recip_nn) and a search trip took 4; the product and two FMAs are pipelined (a few
 * percent at N_P = 1e2, models/binomial/README.md "Quad throughput (session 16)"). That RN(q0 + r
 * y) is RN(a / b) holds when q0 is within one ulp of a / b, which RN(a RN(1 / b)) need not be in
 * general; checked instead for every fp32 significand of a and every integer b <= 4096 (a / b
 * depends only on a's significand; 2^23 x 4096 quotients, none differs;
 * BinomialDraw.MarksteinQuotientIsTheDivision checks b <= 128 for every integer a < 2^17 and a
 * sample of significands, GLINT_EXHAUSTIVE=1 all of them), and a searching lane has b = i + 1 <=
 * cap + 3 <= 127 (binomial_exact_cap <= n q + 43.3 + 1 with n q <= 2 threshold <= 80 in the exact
 * regime). fp64, the host and other devices divide. */
GLINT_FN real binomial_markstein_quotient(real a, real_scalar b) {
  real y = (real)((real_scalar)1.0f / b);
  real q0 = a * y;
  real r = fma(-(real)b, q0, a);
  return fma(r, y, q0);
}

#if defined(__OPENCL_VERSION__) && GLINT_LANES >= 8 && !GLINT_USE_DOUBLE && defined(__AVX512F__)
#define GLINT_BINOMIAL_MARKSTEIN_STEP 1
GLINT_FN real binomial_step_quotient(real n, real_scalar i) {
  return binomial_markstein_quotient(n - (real)i, i + (real_scalar)1.0f);
}
/* a / b for constant divisors (3 and 12 in binomial_arcsine_theta, 3 and 9 in
 * binomial_quantile_bound): the same correctly rounded quotient (the check above covers every
 * significand for these divisors: BinomialDraw.MarksteinQuotientIsTheDivision checks all of
 * them) for 3 pipelined operations instead of a vdivps on the shared divider, of which a draw's
 * regime code has ~10 (p1, the arcsine, the normal quantile, the E(p1) bound, the search's
 * ratio). */
GLINT_FN real binomial_quotient_by(real a, real_scalar b) {
  return binomial_markstein_quotient(a, b);
}
#else
#define GLINT_BINOMIAL_MARKSTEIN_STEP 0
GLINT_FN real binomial_step_quotient(real n, real_scalar i) {
  return (n - i) / (i + (real_scalar)1.0);
}
GLINT_FN real binomial_quotient_by(real a, real_scalar b) {
  return a / (real)b;
}
#endif

/* A bound on quantiles of Binomial(n, q): Bernstein's inequality for a sum of independent
 * trials (each at most 1 above its mean), P(X - n q >= t) <= exp(-t^2 / (2 (var + t / 3))),
 * var = n q (1 - q), gives P(X >= n q + t) <= exp(-L) for t = L/3 + sqrt(L^2/9 + 2 L var), so
 * every quantile at levels u < 1 - exp(-L) is at most ceil(n q + t - 1) < the returned
 * floor(n q + t) + 1 (clamped to n). */
GLINT_FN real binomial_quantile_bound(real n, real q, real L) {
  real var = n * q * (GLINT_R(1.0) - q);
  /* the constant divisors as binomial_quotient_by: the same quotients */
  real t = binomial_quotient_by(L, (real_scalar)3.0f) +
           sqrt(binomial_quotient_by(L * L, (real_scalar)9.0f) + GLINT_R(2.0) * L * var);
  return glint_fmin_nn(glint_floor(n * q + t) + GLINT_R(1.0), n);
}

/* The largest count binomial_exact can return for the rarer outcome's probability q: the bound
 * above at L = 17 > 24 ln 2, beyond every 24-bit uniform (P(X > cap) < 2^-24), so capping the
 * search there changes no result in exact arithmetic. It stops a search that rounding would
 * prolong (u = 0 on the failures side, below) and sizes the tail sums. */
GLINT_FN real binomial_exact_cap(real n, real q) {
  return binomial_quantile_bound(n, q, GLINT_R(17.0));
}

/* Whether the quantile of binomial_exact lies beyond k, decided with the tail
 * S = sum_{k < j <= cap} pmf(j) (continuing the recurrence from pmf(k)) and the total
 * T = cdf + S: F(k) = cdf / T = 1 - S / T. Both sums carry the same rounding of pmf(0), which
 * cancels in the ratios, and each side is compared in the form that keeps its relative
 * precision: v against cdf / T while F(k) <= 1/2, 1 - v against S / T above, where F(k) is
 * within rounding of 1 (fp32's 2^-24 spacing near 1 is u's own resolution). Direct search:
 * beyond k iff u >= F(k); failures side: iff v > F'(k). O(cap - k); binomial_exact calls it
 * only when the running CDF is within its error bound of v, in the lanes of `active`. */
GLINT_FN glint_mask binomial_exact_beyond(real n, real k, real cap, real pmf, real cdf, real ratio,
                                          real v, glint_mask flip, glint_mask active) {
  real tail = GLINT_R(0.0);
  real j = k;
  glint_mask summing = active & (j < cap);
  while (glint_any_by_mask(summing)) {
    pmf = glint_select(pmf, pmf * ((n - j) / (j + GLINT_R(1.0)) * ratio), summing);
    tail = glint_select(tail, tail + pmf, summing);
    j += GLINT_R(1.0);
    summing = summing & (j < cap);
  }
  real total = cdf + tail;
  real vt = v * total;
  real wt = (GLINT_R(1.0) - v) * total;
  glint_mask low = (flip & (vt > cdf)) | (!flip & (vt >= cdf));
  glint_mask high = (flip & (wt < tail)) | (!flip & (wt <= tail));
  glint_mask lower_half = cdf <= tail;
  return (lower_half & low) | ((!lower_half) & high);
}

/* The exact quantile F^-1(u; n, p) = min{k : F(k) > u} of Binomial(n, p), integer n, by
 * sequential search of the CDF: pmf(0) = (1 - q)^n = exp(n log1p(-q)) (no cancellation for
 * tiny q), pmf(k + 1) = pmf(k) (n - k) / (k + 1) q / (1 - q). For p > 1/2 the search runs over
 * the rarer outcome (failures, q = 1 - p) from the other end, with v = 1 - u: the failures'
 * CDF is F'(j) = 1 - F(n - j - 1), so n - min{j : F'(j) >= 1 - u} = min{k : F(k) > u}, the same
 * quantile of the same uniform. Both halves return the quantile of u itself, which is why the
 * count is monotone in p across 1/2: the binomial CDF at fixed k decreases as p grows. The
 * search from the rarer end is O(its count) and keeps pmf(0) in range; only u = 0 (probability
 * 2^-24) meets the cap on the failures side, where the loop would run to n.
 *
 * Rounding: monotone in p needs each comparison of v with F(k) to follow the true F, whose
 * change between nearby p can be far below the CDF's rounding error. That error is relative:
 * pmf(0) carries ~5 |n log1p(-q)| eps from exp and log1p (up to 555 eps at n log(1 - q) = -111),
 * each step of the recurrence <= 7 eps (the ratio's rounding repeats). A comparison is taken
 * from the running CDF when v is farther from it than twice that bound, and otherwise from the
 * tail (binomial_exact_beyond), whose relative precision holds near F = 1 too, where fp32's
 * 2^-24 spacing would otherwise decide. That happens for 1e-5 .. 2e-3 of fp32 searches (most
 * at n = 64, p = 1/2) and in fp64 only on exact ties.
 * Lanes outside `active` do not search (their result is meaningless). */
GLINT_FN real binomial_exact_log(real n, real p, real u, real log1m_q, glint_mask active) {
  glint_mask flip = p > GLINT_R(0.5);
  real q = glint_select(p, GLINT_R(1.0) - p, flip);
  real v = glint_select(u, GLINT_R(1.0) - u, flip);
  real vs = v * GLINT_BINOMIAL_PMF_SCALE;
  real cap = binomial_exact_cap(n, q);
  real log_pmf0 = n * log1m_q;
  real pmf_sqrt = exp(GLINT_R(0.5) * log_pmf0) * GLINT_BINOMIAL_PMF_SCALE_SQRT;
  real pmf = pmf_sqrt * pmf_sqrt;
  real cdf = pmf;
  real ratio = q / (GLINT_R(1.0) - q);
  real eps = binomial_eps();
  real rel_error = GLINT_R(2.0) * eps * (GLINT_R(8.0) - GLINT_R(5.0) * log_pmf0);
  /* The near test below, !(|vs - c| > (rel_error + 14 eps i) c), costs 5 vector operations per
   * step; a trip first asks the cheaper question whether any CDF value c of its 4 steps lies in
   * [vs (1 - band), vs (1 + band)] (2 comparisons per step), and takes the near test only then.
   * The interval holds every c that the near test can call near, so the branch taken and every
   * result are the same: let b = (rel_error + 14 eps (cap + 4)) (1 + 5 eps), which bounds the
   * rounded bound of every step compared (i <= cap + 3) and the roundings of |vs - c| and of the
   * product; near means |vs - c| <= b c, so vs / (1 + b) <= c <= vs / (1 - b). band >= 1.99 b
   * (band = 2 (rel_error + 14 eps (cap + 4)), rounded 3 times); then the rounded vs (1 - band) is
   * at most vs / (1 + b) and the rounded vs (1 + band) at least vs / (1 - b), for 2.5 eps <= b <=
   * 0.1 (b >= rel_error >= 16 eps; b <= 2e-4 in fp32, from rel_error <= 1126 eps at n log(1 - q)
   * >= -111 and cap <= 127, both for thresholds <= 40, the validated range, binomial_model.cpp).
   * The running CDF is finite in a searching lane (scaled pmf <= 2^90) and v is a uniform of
   * the hash, so no NaN is called near that the interval misses (BinomialDraw.FourStepSearch*
   * counts the near comparisons outside the band: none). A search whose v comes within the band of
   * a CDF value pays the near test in that trip: most trips do not (models/binomial/README.md "Quad
   * throughput (session 18)"). */
  real band = GLINT_R(2.0) * (rel_error + GLINT_R(14.0) * eps * (cap + GLINT_R(4.0)));
  real band_lo = vs * (GLINT_R(1.0) - band);
  real band_hi = vs * (GLINT_R(1.0) + band);
  /* A lane that still searches has searched every step so far, so its k is the step count i,
   * the same in every lane: pmf and cdf advance with i in all lanes, unmasked, and only k
   * freezes where a lane stops (the stopped lanes' pmf and cdf are not read again). The steps
   * go 4 at a time: the 4 factors (n - i) / (i + 1) q / (1 - q) and the running pmf and CDF
   * of steps i .. i + 3, then each lane's stop as the first of the 4 comparisons that fails
   * (the CDF never falls, so the comparisons fail in order), with one `any` per 4 steps.
   * Should a searching lane's v be near the CDF at any of the 4 (so that the tail decides,
   * binomial_exact_beyond), the block is dropped and that one step taken as the 1-step
   * recurrence. Per searching lane every value and comparison is the 1-step search's, bit for
   * bit; what changes is the work-item's cost: the factors' divisions no longer wait for the
   * previous comparison, and the loop control (a horizontal `any`, a branch) is paid once per
   * 4 steps (models/binomial/README.md "Cost"). */
  real k = GLINT_R(0.0);
  /* The step count, the same in every lane: a scalar, so that its reciprocals are scalar
   * divisions (binomial_step_quotient). */
  real_scalar i = (real_scalar)0.0f;
  glint_mask searching = active & (k < cap);
  while (glint_any_by_mask(searching)) {
    real_scalar i1 = i + (real_scalar)1.0f, i2 = i + (real_scalar)2.0f;
    real_scalar i3 = i + (real_scalar)3.0f, i4 = i + (real_scalar)4.0f;
    real pmf1 = pmf * (binomial_step_quotient(n, i) * ratio);
    real cdf1 = cdf + pmf1;
    real pmf2 = pmf1 * (binomial_step_quotient(n, i1) * ratio);
    real cdf2 = cdf1 + pmf2;
    real pmf3 = pmf2 * (binomial_step_quotient(n, i2) * ratio);
    real cdf3 = cdf2 + pmf3;
    real pmf4 = pmf3 * (binomial_step_quotient(n, i3) * ratio);
    real cdf4 = cdf3 + pmf4;
    glint_mask in_band =
        ((cdf >= band_lo) & (cdf <= band_hi)) | ((cdf1 >= band_lo) & (cdf1 <= band_hi)) |
        ((cdf2 >= band_lo) & (cdf2 <= band_hi)) | ((cdf3 >= band_lo) & (cdf3 <= band_hi));
    glint_mask near = in_band & !in_band; /* no lane */
    /* Whether any searching lane is near one of the 4: only asked when one is in the band (no
     * lane outside it can be near), so a trip without one pays two `any`, not three. */
    int any_near = 0;
    if (glint_any_by_mask(searching & in_band)) {
      near = !(fabs(vs - cdf) > (rel_error + GLINT_R(14.0) * eps * i) * cdf);
      glint_mask near_later = !(fabs(vs - cdf1) > (rel_error + GLINT_R(14.0) * eps * i1) * cdf1) |
                              !(fabs(vs - cdf2) > (rel_error + GLINT_R(14.0) * eps * i2) * cdf2) |
                              !(fabs(vs - cdf3) > (rel_error + GLINT_R(14.0) * eps * i3) * cdf3);
      any_near = glint_any_by_mask(searching & (near | near_later));
    }
    if (any_near) {
      /* One step of the 1-step search at i. */
      glint_mask beyond = vs > cdf;
      if (glint_any_by_mask(searching & near)) {
        glint_mask tail_says =
            binomial_exact_beyond(n, (real)i, cap, pmf, cdf, ratio, v, flip, searching & near);
        beyond = ((!near) & beyond) | (near & tail_says);
      }
      searching = searching & beyond;
      pmf = pmf1;
      cdf = cdf1;
      i = i1;
      k = glint_select(k, (real)i, searching);
      searching = searching & (i < cap);
      continue;
    }
    glint_mask s1 = searching & (vs > cdf);
    glint_mask s2 = s1 & (i1 < cap) & (vs > cdf1);
    glint_mask s3 = s2 & (i2 < cap) & (vs > cdf2);
    glint_mask s4 = s3 & (i3 < cap) & (vs > cdf3);
    k = glint_select(k, (real)i1, s1);
    k = glint_select(k, (real)i2, s2);
    k = glint_select(k, (real)i3, s3);
    k = glint_select(k, (real)i4, s4);
    searching = s4 & (i4 < cap);
    pmf = pmf4;
    cdf = cdf4;
    i = i4;
  }
  return glint_select(k, n - k, flip);
}

/* log(1 - q) of the rarer outcome's probability q, the one logarithm of binomial_exact_log:
 * it depends on p alone, so the draws of one light share it (binomial_prob). */
GLINT_FN real binomial_log1m_rarer(real p) {
  return log1p(-glint_select(p, GLINT_R(1.0) - p, p > GLINT_R(0.5)));
}

GLINT_FN real binomial_exact(real n, real p, real u, glint_mask active) {
  return binomial_exact_log(n, p, u, binomial_log1m_rarer(p), active);
}

/* Standard normal quantile for t in (0, 1/2], i.e. z <= 0: Acklam's rational approximation
 * (P. J. Acklam 2003, "An algorithm for computing the inverse normal cumulative distribution
 * function"; relative error < 1.15e-9, far below what the draws can resolve). */
GLINT_FN real binomial_normal_quantile_tail(real t) {
  real r = sqrt(GLINT_R(-2.0) * log(t));
  return (((((GLINT_R(-7.784894002430293e-03) * r + GLINT_R(-3.223964580411365e-01)) * r +
             GLINT_R(-2.400758277161838e+00)) *
                r +
            GLINT_R(-2.549732539343734e+00)) *
               r +
           GLINT_R(4.374664141464968e+00)) *
              r +
          GLINT_R(2.938163982698783e+00)) /
         ((((GLINT_R(7.784695709041462e-03) * r + GLINT_R(3.224671290700398e-01)) * r +
            GLINT_R(2.445134137142996e+00)) *
               r +
           GLINT_R(3.754408661907416e+00)) *
              r +
          GLINT_R(1.0));
}

GLINT_FN real binomial_normal_quantile_central(real t) {
  real x = t - GLINT_R(0.5);
  real r = x * x;
  return (((((GLINT_R(-3.969683028665376e+01) * r + GLINT_R(2.209460984245205e+02)) * r +
             GLINT_R(-2.759285104469687e+02)) *
                r +
            GLINT_R(1.383577518672690e+02)) *
               r +
           GLINT_R(-3.066479806614716e+01)) *
              r +
          GLINT_R(2.506628277459239e+00)) *
         x /
         (((((GLINT_R(-5.447609879822406e+01) * r + GLINT_R(1.615858368580409e+02)) * r +
             GLINT_R(-1.556989798598866e+02)) *
                r +
            GLINT_R(6.680131188771972e+01)) *
               r +
           GLINT_R(-1.328068155288572e+01)) *
              r +
          GLINT_R(1.0));
}

/* Lower tail below 0.02425, the central region above (per lane; the tail only when a lane of
 * `used` needs it: the other lanes' z is not read, and each u is in a tail with probability
 * 0.0485, so 16 lanes of which all ask would take the tail's log, sqrt and division in 55% of
 * the work-items, and only the ~half of them that are approximated at N_P = 1e2 in ~1 - 0.95^8
 * = 33%). Per lane the same arithmetic, so a used lane's z is the same; an unused lane in the
 * tail keeps the central form's value, finite there (its denominator is >= 1.1e-4 on (0, 1/2]). */
GLINT_FN real binomial_normal_quantile_lower(real t, glint_mask used) {
  glint_mask tail = t < GLINT_R(0.02425);
  real z = binomial_normal_quantile_central(t);
  if (glint_any_by_mask(used & tail)) z = glint_select(z, binomial_normal_quantile_tail(t), tail);
  return z;
}

/* The standard normal z of the uniform u = m 2^-24: the quantile of the middle of u's bin,
 * (m + 1/2) 2^-24, formed from the nearer end so that it is exact in fp32 too (|z| <= 5.4), and
 * odd: the bins of m and 2^24 - 1 - m give -z and z. Meaningful in the lanes of `used`. */
GLINT_FN real binomial_normal_of_uniform(real u, glint_mask used) {
  const real half_bin = GLINT_R(2.98023223876953125e-8); /* 2^-25 */
  glint_mask upper = u >= GLINT_R(0.5);
  real z = binomial_normal_quantile_lower(
      glint_select(u + half_bin, (GLINT_R(1.0) - u) - half_bin, upper), used);
  return glint_select(z, -z, upper);
}

/* Binomial(n, p) by a normal approximation written as a quantile of z, so that it is monotone
 * in p for fixed z:
 *  - on the arcsine scale (Anscombe 1948, "The transformation of Poisson, binomial and
 *    negative-binomial data"): asin(sqrt(X / n)) is close to normal with mean
 *    theta = asin(sqrt(p)) and variance 1/(4n), so X ~ n sin^2(theta + z / (2 sqrt(n)));
 *  - minus its mean excess, E[sin^2(theta + e)] - p = (1 - 2p)(1 - exp(-1/(2n))) / 2 for
 *    e ~ N(0, 1/(4n)) (exact), so the mean is n p;
 *  - minus a Cornish-Fisher term (Cornish & Fisher 1937): the arcsine form's third cumulant is
 *    1.5 n p (1 - p)(1 - 2p) to leading order, the binomial's n p (1 - p)(1 - 2p); the
 *    quantile term (1 - 2p)(z^2 - 1) / 12 removes the excess and has mean 0;
 *  - rounded to the nearest integer, the continuity-corrected count: a number of facets, and
 *    one the exact counts of the neighbouring regimes can meet (binomial_whole). Rounding adds
 *    1/12 to the variance and, at standard deviations >= 1, nothing measurable to the mean.
 * Monotone in p for fixed z: theta grows, the angle is clamped to [0, pi/2] where sin^2 grows
 * (in fp32 theta and the sine are binomial_trig.h's, which fall between no two consecutive fp32
 * inputs: checked on every one on the device, as the lane kernels and the one-query kernel build
 * them, BinomialTrigDevice; on the host on every one from 2^-30 up and one in 509 below, where
 * both are their leading term exactly, BinomialTrig. fp64 keeps libm's sin and asin(sqrt) --
 * PoCL's on the device, glibc's on the host -- whose never falling is NOT verified by any test:
 * a gap that predates session 19), -(1 - 2p) grows, and the Cornish-Fisher term falls at most at
 * rate 1/6 (|z| < 1; the arcsine term then grows at rate >= n/2 for variances >= 1). The plain n p
 * + z sqrt(n p (1-p)) is not monotone (sqrt(p (1 - p)) falls above p = 1/2, which a positive z
 * turns into a falling count, and likewise for z << 0 at small n p). Near p = 1, asin(sqrt(p))
 * resolves the failures n (1 - p) to ~n eps, as fine as fp32's p itself. Measured against the pmf
 * by explicit sums over the draw's exact law (all 2^24 uniforms): total variation 1e-3 .. 3e-3 at
 * variance 9, 1e-4 at 210; variance n p (1 - p) + O(1): +1.3% at variance 9. */
GLINT_FN real binomial_arcsine_theta(real n, real p, real theta, real z) {
  real phi =
      glint_clamp_nn(theta + GLINT_R(0.5) * z / sqrt(n), GLINT_R(0.0), GLINT_R(0.5) * GLINT_PI);
  real s = binomial_sin_quadrant(phi);
  /* 1 - exp(-x) for x = 1/(2n) < 1/128 (n > 64 here): the series to x^3, relative error x^3/24 */
  real x = GLINT_R(0.5) / n;
  real mean_excess =
      GLINT_R(0.5) * (GLINT_R(1.0) - GLINT_R(2.0) * p) * x *
      (GLINT_R(1.0) -
       GLINT_R(0.5) * x * (GLINT_R(1.0) - binomial_quotient_by(x, (real_scalar)3.0f)));
  real skew = binomial_quotient_by((GLINT_R(1.0) - GLINT_R(2.0) * p) * (z * z - GLINT_R(1.0)),
                                   (real_scalar)12.0f);
  return glint_clamp_nn(glint_floor(n * (s * s - mean_excess) - skew + GLINT_R(0.5)), GLINT_R(0.0),
                        n);
}

/* theta = asin(sqrt(p)) depends on p alone: the draws of one light share it (binomial_prob). */
GLINT_FN real binomial_arcsine(real n, real p, real z) {
  return binomial_arcsine_theta(n, p, binomial_asin_sqrt(p), z);
}

/* What the draws of one light at probability p (clamped to 1) share: asin(sqrt(p)) and
 * log(1 - q). Each draw would compute the same values; computed once per light, and only when
 * a draw first needs it (has_theta, has_log1m_q: uniform flags, as the glint_any branches that
 * set them): at N_P >= 1e4 nearly no work-item searches, and its log1p was paid for nothing
 * (models/binomial/README.md "Quad throughput (session 17)"). The same operations on the same
 * p, so the same bits as computing both up front. */
typedef struct {
  real p;
  real theta;      /* asin(sqrt(p)), binomial_arcsine */
  real log1m_q;    /* binomial_log1m_rarer(p), binomial_exact */
  int has_theta;   /* theta is set */
  int has_log1m_q; /* log1m_q is set */
} BinomialProb;

GLINT_FN BinomialProb binomial_prob(real p) {
  BinomialProb b;
  b.p = glint_fmin_nn(p, GLINT_R(1.0));
  b.theta = GLINT_R(0.0);
  b.log1m_q = GLINT_R(0.0);
  b.has_theta = 0;
  b.has_log1m_q = 0;
  return b;
}

GLINT_FN real binomial_prob_theta(GLINT_PRIVATE BinomialProb *b) {
  if (!b->has_theta) {
    b->theta = binomial_asin_sqrt(b->p);
    b->has_theta = 1;
  }
  return b->theta;
}

GLINT_FN real binomial_prob_log1m_q(GLINT_PRIVATE BinomialProb *b) {
  if (!b->has_log1m_q) {
    b->log1m_q = binomial_log1m_rarer(b->p);
    b->has_log1m_q = 1;
  }
  return b->log1m_q;
}

/* Binomial(n, p) for integer n >= 1 and p in (0, 1] from one uniform u, monotone
 * non-decreasing in p for fixed u in every regime and across every switch:
 *  - n <= GLINT_BINOMIAL_EXACT_MAX, or where the variance n p (1 - p) is below `threshold`
 *    (p < p1 or p > p2, the roots of n p (1 - p) = threshold): the exact quantile E(p);
 *  - between the switches, p1 <= p <= p2: the approximation A(p), z from the same u.
 * A and E are different functions of u, so at p1 A can be below E for the same u (and at p2
 * E below A). Each regime therefore continues as the maximum with the value the previous one
 * reached at its switch: max(A(p), E(p1)) between the switches, max(A(p2), E(p1), E(p))
 * above p2, so that no switch can lower a count. The maximum differs from A(p) only where the
 * two quantiles of u differ at p1 (by one count, for a small fraction of u) and only until A
 * has grown past E(p1): an upward bias in a band of p above p1. Measured on the draw's exact
 * law (all 2^24 uniforms), relative to n p: at threshold 9, +8e-4 at p1, +1.5e-4 at 1.01 p1,
 * 2e-6 at 1.1 p1 (n = 1000 and 1e6; 2e-4 at p1 for n = 65); at threshold 40, 6e-5 at p1; at
 * threshold 1, where counts near p1 are ~1 and no approximation fits them, +2.7% at p1,
 * +0.6% at 2 p1, 2e-4 at 5 p1. Above p2, <= 3e-5. Elsewhere the mean is n p.
 * E(p1) is only computed when A(p) is below a bound on it (binomial_quantile_bound), i.e.
 * within a few counts of p1's: elsewhere the draw costs one A.
 * In lanes: the approximation runs when any lane of `active` is between the switches, the
 * search E(p) once for the lanes below p1 and above p2 together. */
/* binomial_whole_prob's three stages, so that the lane kernel can run each stage on lanes
 * regrouped by regime (binomial_lanes.cl, GLINT_BLOCKS > 1) with the same per-lane arithmetic:
 * the switch p1 = (1 - sqrt(1 - 4 threshold / n)) / 2 without cancellation (NaN where
 * 4 threshold > n, only read in lanes that are not clearly exact). */
GLINT_FN real binomial_switch_p1(real n, real threshold) {
  return GLINT_R(2.0) * threshold /
         (n * (GLINT_R(1.0) + sqrt(GLINT_R(1.0) - GLINT_R(4.0) * threshold / n)));
}

/* Stage 1: the lanes of `active` between the switches (p1 <= p; the approximation's), with p1
 * where a lane is not clearly exact. Clearly exact (variance below half the threshold, so p <
 * p1 or p > p2 whatever the rounding of p1) skips computing p1. */
GLINT_FN glint_mask binomial_whole_regime(real n, real p, real threshold, glint_mask active,
                                          GLINT_PRIVATE real *p1_out) {
  glint_mask clearly_exact = (n <= GLINT_R(GLINT_BINOMIAL_EXACT_MAX)) |
                             (GLINT_R(4.0) * threshold > n) |
                             (n * p * (GLINT_R(1.0) - p) < GLINT_R(0.5) * threshold);
  glint_mask approx = active & !clearly_exact;
  real p1 = GLINT_R(0.0);
  if (glint_any_by_mask(approx)) {
    p1 = binomial_switch_p1(n, threshold);
    approx = approx & !(p < p1);
  }
  *p1_out = p1;
  return approx;
}

/* Stage 2, in the lanes of `approx`: A(p) (p clamped to p2 = 1 - p1), and in *near_p1 the lanes
 * where E(p1) can exceed it. */
GLINT_FN real binomial_whole_approx(real n, GLINT_PRIVATE BinomialProb *prob, real u, real p1,
                                    glint_mask approx, GLINT_PRIVATE glint_mask *near_p1_out) {
  real p = prob->p;
  real p2 = GLINT_R(1.0) - p1;
  /* asin(sqrt(fmin(p, p2))): the light's theta unless p > p2 */
  real theta = binomial_prob_theta(prob);
  glint_mask above_p2 = approx & (p > p2);
  if (glint_any_by_mask(above_p2)) theta = glint_select(theta, binomial_asin_sqrt(p2), above_p2);
  real x =
      binomial_arcsine_theta(n, glint_fmin_nn(p, p2), theta, binomial_normal_of_uniform(u, approx));
  /* max(x, E(p1)) needs E(p1) only if it can exceed x: E(p1) <= the cap for every u, and
   * <= the Bernstein bound at L = -log(1 - u) for this u (L enlarged by 1e-3 against its
   * rounding; plus one count for a comparison that rounding decides, binomial_exact).
   * Whether it is skipped depends on u and on x, which grows with p: once skipped, it stays
   * skipped. */
  glint_mask near_p1 = approx & (x < binomial_exact_cap(n, p1));
  if (glint_any_by_mask(near_p1)) {
    real level = GLINT_R(1.001) * -log1p(-u) + GLINT_R(0.001);
    near_p1 = near_p1 & (x < binomial_quantile_bound(n, p1, level) + GLINT_R(1.0));
  }
  *near_p1_out = near_p1;
  return x;
}

/* Stage 3: the searches. `first` = near_p1 | search lanes get E(p_first) (p_first = p1 in the
 * lanes near p1, p elsewhere; log1m_first its binomial_log1m_rarer), the maximum with x where
 * approximated; a lane that needs both (near p1 and searching) its E(p) in a second search. */
GLINT_FN real binomial_whole_searches(real n, GLINT_PRIVATE BinomialProb *prob, real u, real x,
                                      real p_first, real log1m_first, glint_mask approx,
                                      glint_mask near_p1, glint_mask search) {
  glint_mask first = near_p1 | search;
  real e = binomial_exact_log(n, p_first, u, log1m_first, first);
  x = glint_select(x, glint_select(e, fmax(x, e), approx), first);
  glint_mask both = near_p1 & search;
  if (glint_any_by_mask(both)) {
    real e2 = binomial_exact_log(n, prob->p, u, binomial_prob_log1m_q(prob), both);
    x = glint_select(x, fmax(x, e2), both);
  }
  return x;
}

GLINT_FN real binomial_whole_prob(real n, GLINT_PRIVATE BinomialProb *prob, real threshold, real u,
                                  glint_mask active) {
  real p = prob->p;
  real p1;
  glint_mask approx = binomial_whole_regime(n, p, threshold, active, &p1);
  real p2 = GLINT_R(1.0) - p1;
  real x = GLINT_R(0.0);
  glint_mask near_p1 = approx & !approx; /* no lane */
  if (glint_any_by_mask(approx)) x = binomial_whole_approx(n, prob, u, p1, approx, &near_p1);
  /* E(p): the whole answer below p1 (or clearly exact), the last maximum above p2. */
  glint_mask exact = active & !approx;
  glint_mask search = exact | (approx & (p > p2));
  /* One search for both: E(p1) in the lanes near p1, E(p) in the others that need it (each
   * lane's own arithmetic, as two searches would do it), so a work-item whose lanes straddle a
   * switch pays one set-up and the longer of the two loops instead of both. A lane that needs
   * both (approximated above p2 yet near p1: only where p1 and p2 nearly meet, n ~ 4 threshold)
   * gets its E(p) in a second search. The maxima commute, so the order does not matter. */
  glint_mask first = near_p1 | search;
  if (glint_any_by_mask(first)) {
    real p_first = p, log1m_first;
    if (glint_any_by_mask(near_p1)) {
      p_first = glint_select(p, p1, near_p1);
      /* E(p) in no lane: p's logarithm is not needed */
      log1m_first = glint_any_by_mask(search) ? binomial_prob_log1m_q(prob) : GLINT_R(0.0);
      log1m_first = glint_select(log1m_first, binomial_log1m_rarer(p1), near_p1);
    } else {
      log1m_first = binomial_prob_log1m_q(prob);
    }
    x = binomial_whole_searches(n, prob, u, x, p_first, log1m_first, approx, near_p1, search);
  }
  return x;
}

GLINT_FN real binomial_whole(real n, real p, real threshold, real u, glint_mask active) {
  BinomialProb prob = binomial_prob(p);
  return binomial_whole_prob(n, &prob, threshold, u, active);
}

/* Whether the quantile of u of Binomial(n, p) (integer n >= 1, p in (0, 1]) is 0 for certain,
 * decided without the search: it is 0 iff u < F(0) = (1 - p)^n, and (1 - p)^n >= 1 - n p
 * (Bernoulli's inequality), so u < 1 - n p suffices. The margin 2^-16 (550 fp32 ulps of 1)
 * covers the rounding of 1 - n p (<= 2 eps) and the relative error that binomial_exact_log
 * allows its running CDF before it asks the tail (<= 2 eps (8 - 5 n log(1 - p)) <= 36 eps at
 * n p < 1, p <= 1/2): where this holds, the search returns 0 at its first comparison, without
 * the tail, so skipping it changes no count (binomial_test: SurelyZero*). Such a lane is in
 * the exact regime (n p < 1 puts p below the switch p1, whose variance is >= threshold >= 1).
 * Most draws of a small light are such zeros; a work-item whose lanes all are skips the
 * search and its set-up (pmf(0) = exp(n log(1 - q)), the cap, the switches). */
GLINT_FN glint_mask binomial_surely_zero(real n, real p, real u) {
  return (p <= GLINT_R(0.5)) & (u < GLINT_R(1.0) - n * p - GLINT_R(1.52587890625e-5));
}

/* A draw's inputs before its whole trials are counted: the whole trials, their uniform u and
 * the lanes that draw them, and the lanes whose partial trial succeeds. `p` is the draw's
 * probability as given (0 in lanes that do not draw), `p_clamped` fmin(p, 1) (BinomialProb). */
typedef struct {
  real whole;
  real u;
  glint_mask has_whole;
  glint_mask partial;
} BinomialDrawInputs;

GLINT_FN BinomialDrawInputs binomial_draw_inputs(real n, real p, real p_clamped, glint_key key,
                                                 glint_mask active) {
  BinomialDrawInputs d;
  glint_mask drawn = active & (n > GLINT_R(0.0)) & (p > GLINT_R(0.0));
  p = p_clamped;
  d.whole = glint_floor(n);
  real part = n - d.whole;
  d.u = rng_u01_key(rng_absorb_key(key, 1u));
  d.has_whole = drawn & (d.whole > GLINT_R(0.0)) & !binomial_surely_zero(d.whole, p, d.u);
  d.partial = drawn & (part > GLINT_R(0.0)) & (rng_u01_key(rng_absorb_key(key, 4u)) < part * p);
  return d;
}

/* The draw's count from its whole trials' count k_whole (read in the lanes of has_whole). */
GLINT_FN real binomial_draw_count(BinomialDrawInputs d, real k_whole) {
  real k = glint_select(GLINT_R(0.0), k_whole, d.has_whole);
  return glint_select(k, k + GLINT_R(1.0), d.partial);
}

/* A draw of "Binomial(n, p)" for real n >= 0: floor(n) whole trials plus one partial trial
 * that succeeds with probability frac(n) p, so that the mean is n p exactly for every real n (a
 * footprint holding 0.3 facets reflects with probability 0.3 p; with N_P < 1 this is what
 * keeps the estimator unbiased). The whole trials use one uniform of `key`'s stream in every
 * regime (binomial_whole); the partial trial its own, succeeding when it is below frac(n) p.
 * Each part is non-decreasing in p for its fixed uniform, so their sum is: for a given cell,
 * light and view the count never falls as p grows. 0 in the lanes outside `active`. */
GLINT_FN real binomial_draw_prob(real n, real p, GLINT_PRIVATE BinomialProb *prob, real threshold,
                                 glint_key key, glint_mask active) {
  BinomialDrawInputs d = binomial_draw_inputs(n, p, prob->p, key, active);
  real k = GLINT_R(0.0);
  if (glint_any_by_mask(d.has_whole))
    k = binomial_whole_prob(d.whole, prob, threshold, d.u, d.has_whole);
  return binomial_draw_count(d, k);
}

GLINT_FN real binomial_draw_lanes(real n, real p, real threshold, glint_key key,
                                  glint_mask active) {
  BinomialProb prob = binomial_prob(p);
  return binomial_draw_prob(n, p, &prob, threshold, key, active);
}

/* sum_g k_g / N_P: the footprint's fraction of facets that reflect, whose
 * mean is p (the factor b(N_P, p) / N_P of KK24 Eq. 11 and 16). `light_key`
 * identifies the light and the angular cell. 0 when the footprint holds no
 * facets, and in the lanes outside `active`. */
GLINT_FN real binomial_fraction_lanes(FootprintGrids g, real p, real threshold, glint_key light_key,
                                      glint_mask active) {
  glint_mask counted = active & (g.n_facets > GLINT_R(0.0)) & (p > GLINT_R(0.0));
  real count = GLINT_R(0.0);
  if (!glint_any_by_mask(counted)) return count;
  BinomialProb prob = binomial_prob(p);
  for (int k = 0; k < GLINT_BINOMIAL_GRIDS; ++k) {
    glint_mask in_grid = counted & (g.share[k] > GLINT_R(0.0));
    /* += 0 in the other lanes: the sum of the grids that hold facets, as before */
    if (glint_any_by_mask(in_grid))
      count += binomial_draw_prob(g.share[k] * g.n_facets, p, &prob, threshold,
                                  rng_absorb_key(g.cell_key[k], light_key), in_grid);
  }
  return glint_select(GLINT_R(0.0), count / g.n_facets, counted);
}

#if !defined(__OPENCL_VERSION__) || GLINT_LANES == 1
/* The one-query forms (host, tests). */
GLINT_FN real binomial_draw(real n, real p, real threshold, uint key) {
  return binomial_draw_lanes(n, p, threshold, key, 1);
}
GLINT_FN real binomial_fraction(FootprintGrids g, real p, real threshold, uint light_key) {
  return binomial_fraction_lanes(g, p, threshold, light_key, 1);
}
#endif

#endif /* GLINT_BINOMIAL_COUNT_H */
