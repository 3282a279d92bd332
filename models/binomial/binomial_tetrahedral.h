/* The binomial model's cheaper footprint interpolation (material.binomial.footprint_interpolation
 * TETRAHEDRAL): the footprint's facets split between 4 grids by barycentric weights instead of
 * the 8 trilinear ones of binomial_footprint_grids (binomial_count.h, step 2), so every light
 * costs 4 binomial draws instead of 8 and the footprint 3 rotations instead of 4, whose cosines
 * and sines come from a short polynomial instead of the library's sin and cos.
 *
 * DEPARTURE from Kneiphof & Klein 2024 (KK24 Eq. 11 and 16 count with our trilinear grids) and
 * from Deliot & Belcour 2023 (DB23 Sec. 4 also evaluates 4 grids, but on their prism split
 * with mid-bin rotations and a simplex cell lattice): the same rectangular cells, keys and
 * per-grid draws as the trilinear scheme, only fewer grids. The split keeps the identities
 * the model rests on: the weights are >= 0 and sum to 1, grid g gets w_g N_P of the N_P trials,
 * so the count is still a sum of independent binomials with N_P trials in all and its mean
 * N_P p (KK24 Eq. 16: E[L] = L_smooth), its variance N_P p (1 - p) (the same convergence law);
 * every weight is continuous in the footprint (no popping as it shrinks, stretches or turns).
 *
 * The construction. The footprint's continuous coordinates (binomial_footprint_shape) are the
 * level lod, the anisotropy a and the major-axis angle theta; their lattice: levels l0 =
 * floor(lod), l0 + 1 (t = frac(lod)); anisotropy levels a0 = floor(a), a0 + 1 (s = frac(a));
 * at anisotropy level a, rotation bins of pi / (4 2^a), so level a0 + 1 has twice as many.
 *  1. (anisotropy, rotation) plane: with x = frac(pos0), pos0 = theta / (pi / (4 2^a0)), the
 *     lower row holds the bins L0 = b0, L1 = b0 + 1 of level a0, the upper row the bins
 *     U0 = 2 b0, U1/2 = 2 b0 + 1, U1 = 2 b0 + 2 of level a0 + 1 (at x = 0, 1/2, 1). Three
 *     triangles tile the unit square conformingly: (L0, U0, U1/2) where x < s / 2, (L1, U1/2,
 *     U1) where x > 1 - s / 2, (L0, L1, U1/2) between; the point's barycentric weights in its
 *     triangle. Rows meet the neighbouring squares' rows at the same bins (the upper row of
 *     a0 is the lower row of a0 + 1), so the weights are continuous across squares too.
 *  2. Times the level interval [l0, l0 + 1]: a prism, split into 3 tetrahedra by the
 *     staircase (comonotone) coupling: lay the triangle's weights end to end on [0, 1] in the
 *     order (lower row before upper, then by angle), the level weights (1 - t, t) likewise;
 *     each grid (vertex, level) gets the length of the overlap of its two intervals. At most
 *     3 + 2 - 1 = 4 overlaps are non-empty; their sums over levels are the triangle's weights
 *     and over vertices the level weights (so both marginals are the trilinear scheme's); the
 *     order is the same in every triangle that shares an edge, so the split is conforming.
 * Every grid with a positive weight is one of the trilinear scheme's 8 (the same cell keys),
 * so both schemes see the same facets where they give a grid the same weight. */
#ifndef GLINT_BINOMIAL_TETRAHEDRAL_H
#define GLINT_BINOMIAL_TETRAHEDRAL_H

#include "models/binomial/binomial_count.h"

#define GLINT_BINOMIAL_TETRAHEDRAL_GRIDS 4

/* cos(pi f) and sin(pi f) for f in [0, 1] with no library call: the rotation angles here are
 * pi f with f = bin / bins (exact, bins a power of two), so the reduction is exact too: f -> 1 - f
 * (cos changes sign), then g -> 1/2 - g (cos and sin swap) leave x = pi g in [0, pi/4], where
 * the Taylor series to x^16 and x^17 has a remainder below x^18 / 18! < 2e-18 (below half an
 * ulp in fp64). PoCL's sin and cos (SLEEF, with a general range reduction) were the trilinear
 * grids' largest single cost (models/binomial/README.md "Cost"); this is a few FMAs per lane and
 * the same arithmetic on host and device. */
GLINT_FN void binomial_cos_sin_pi(real f, GLINT_PRIVATE real *c, GLINT_PRIVATE real *s) {
  glint_mask upper = f > GLINT_R(0.5);
  real g = glint_select(f, GLINT_R(1.0) - f, upper);
  glint_mask swap = g > GLINT_R(0.25);
  g = glint_select(g, GLINT_R(0.5) - g, swap);
  real x = GLINT_PI * g, x2 = x * x;
  /* Horner in x^2: cos = sum (-1)^j x^2j / (2j)!, sin = x sum (-1)^j x^2j / (2j + 1)! */
  real cp = GLINT_R(4.779477332387385e-14);  /* 1 / 16! */
  real sp = GLINT_R(2.8114572543455206e-15); /* 1 / 17! */
  cp = cp * x2 - GLINT_R(1.1470745597729725e-11);
  sp = sp * x2 - GLINT_R(7.647163731819816e-13);
  cp = cp * x2 + GLINT_R(2.08767569878681e-09);
  sp = sp * x2 + GLINT_R(1.6059043836821613e-10);
  cp = cp * x2 - GLINT_R(2.755731922398589e-07);
  sp = sp * x2 - GLINT_R(2.505210838544172e-08);
  cp = cp * x2 + GLINT_R(2.48015873015873e-05);
  sp = sp * x2 + GLINT_R(2.7557319223985893e-06);
  cp = cp * x2 - GLINT_R(0.001388888888888889);
  sp = sp * x2 - GLINT_R(0.0001984126984126984);
  cp = cp * x2 + GLINT_R(0.041666666666666664);
  sp = sp * x2 + GLINT_R(0.008333333333333333);
  cp = cp * x2 - GLINT_R(0.5);
  sp = sp * x2 - GLINT_R(0.16666666666666666);
  cp = cp * x2 + GLINT_R(1.0);
  sp = (sp * x2 + GLINT_R(1.0)) * x;
  real co = glint_select(cp, sp, swap), si = glint_select(sp, cp, swap);
  *c = glint_select(co, -co, upper);
  *s = si;
}

/* The cell key of uv in the grid (level, anisotropy level, rotation bin): the chain of
 * binomial_footprint_grids (seed, level, anisotropy level, bin wrapped at pi, cell), with the
 * grid's side = 2^level, ratio = 2^aniso_level and bins = 4 ratio passed in (exact powers of
 * two, computed once per footprint instead of per grid). */
GLINT_FN glint_key binomial_tetrahedral_key(glint_key seed_key, real level, real side,
                                            real aniso_level, real ratio, real bin, real rot_u,
                                            real rot_v) {
  real bins = GLINT_R(4.0) * ratio;
  glint_key key = rng_absorb_key(seed_key, binomial_cell_key(level));
  key = rng_absorb_key(key, binomial_cell_key(aniso_level));
  key = rng_absorb_key(key, binomial_cell_key(glint_select(bin, bin - bins, bin >= bins)));
  key = rng_absorb_key(key, binomial_cell_key(glint_floor(rot_u / (side * ratio))));
  return rng_absorb_key(key, binomial_cell_key(glint_floor(rot_v / side)));
}

/* Steps 1 and 2 above without the cell keys: the 4 grids' weights and lattice coordinates. */
typedef struct {
  real w[GLINT_BINOMIAL_TETRAHEDRAL_GRIDS];
  real level[GLINT_BINOMIAL_TETRAHEDRAL_GRIDS]; /* l0 or l0 + 1 */
  real side[GLINT_BINOMIAL_TETRAHEDRAL_GRIDS];  /* 2^level */
  /* The triangle's vertices: anisotropy level, 2^that, rotation bin at that level. */
  real vert_aniso[3], vert_ratio[3], vert_bin[3];
  /* Grid 0 is at vertex 0, grid 3 at vertex 2; grid 1 at vertex 0 where `early`, else 1; grid 2
   * at vertex 2 where `late`, else 1. */
  glint_mask early, late;
} TetrahedralSplit;

GLINT_FN TetrahedralSplit binomial_tetrahedral_split(FootprintShape f) {
  TetrahedralSplit q;
  real lod0 = glint_floor(f.lod);
  real t = f.lod - lod0;
  real a0 = glint_floor(f.aniso);
  real s = f.aniso - a0;
  /* 2^l and 2^a of the lower levels; the upper ones are exactly twice */
  real side0 = exp2(lod0), ratio0 = exp2(a0);
  real bins0 = GLINT_R(4.0) * ratio0;
  real pos0 = f.theta * bins0 / GLINT_PI;
  real b0 = glint_floor(pos0);
  real x = pos0 - b0;

  /* Step 1: the triangle and its weights beta, vertices (anisotropy level, bin) in order. */
  glint_mask tri_a = x < GLINT_R(0.5) * s;
  glint_mask tri_c = x > GLINT_R(1.0) - GLINT_R(0.5) * s;
  real one_minus_x = GLINT_R(1.0) - x;
  real beta0 = glint_select(GLINT_R(1.0) - x - GLINT_R(0.5) * s, GLINT_R(1.0) - s, tri_a | tri_c);
  real beta1 = glint_select(x - GLINT_R(0.5) * s, s - GLINT_R(2.0) * x, tri_a);
  beta1 = glint_select(beta1, GLINT_R(2.0) * one_minus_x, tri_c);
  beta0 = glint_fmax_nn(beta0, GLINT_R(0.0));
  beta1 = glint_fmax_nn(beta1, GLINT_R(0.0));
  real a1 = a0 + GLINT_R(1.0);
  q.vert_aniso[0] = a0;
  q.vert_bin[0] = glint_select(b0, b0 + GLINT_R(1.0), tri_c);
  q.vert_aniso[1] = glint_select(a0, a1, tri_a | tri_c);
  q.vert_bin[1] = glint_select(b0 + GLINT_R(1.0), GLINT_R(2.0) * b0, tri_a);
  q.vert_bin[1] = glint_select(q.vert_bin[1], GLINT_R(2.0) * b0 + GLINT_R(1.0), tri_c);
  q.vert_aniso[2] = a1;
  q.vert_bin[2] = GLINT_R(2.0) * b0 + glint_select(GLINT_R(1.0), GLINT_R(2.0), tri_c);
  for (int i = 0; i < 3; ++i)
    q.vert_ratio[i] = glint_select(ratio0, GLINT_R(2.0) * ratio0, q.vert_aniso[i] > a0);

  /* Step 2: the overlaps of [0, C1), [C1, C2), [C2, 1) (vertices) with [0, T), [T, 1)
   * (levels l0, l0 + 1). Grid 0 is (vertex 0, l0), grid 3 (vertex 2, l0 + 1); grid 1 is
   * (vertex 0, l0 + 1) if T <= C1 else (vertex 1, l0); grid 2 (vertex 2, l0) if T > C2 else
   * (vertex 1, l0 + 1). */
  real c1 = beta0, c2 = beta0 + beta1, T = GLINT_R(1.0) - t;
  q.early = T <= c1;
  q.late = T > c2;
  q.w[0] = fmin(c1, T);
  q.w[1] = glint_select(fmin(T, c2) - c1, c1 - T, q.early);
  q.w[2] = glint_select(c2 - fmax(T, c1), T - c2, q.late);
  q.w[3] = GLINT_R(1.0) - fmax(c2, T);
  for (int k = 0; k < GLINT_BINOMIAL_TETRAHEDRAL_GRIDS; ++k)
    q.w[k] = glint_fmax_nn(q.w[k], GLINT_R(0.0));
  real l1 = lod0 + GLINT_R(1.0);
  q.level[0] = lod0;
  q.level[1] = glint_select(lod0, l1, q.early);
  q.level[2] = glint_select(l1, lod0, q.late);
  q.level[3] = l1;
  q.side[0] = side0;
  q.side[1] = glint_select(side0, GLINT_R(2.0) * side0, q.early);
  q.side[2] = glint_select(GLINT_R(2.0) * side0, side0, q.late);
  q.side[3] = GLINT_R(2.0) * side0;
  return q;
}

/* uv rotated to the rotation bin `bin` of an anisotropy level with ratio 2^a (pi / (4 ratio)
 * bins): the angle bin pi / bins, as binomial_footprint_grids has it (bin <= bins). */
GLINT_FN void binomial_tetrahedral_rotate(real bin, real ratio, real u, real v,
                                          GLINT_PRIVATE real *rot_u, GLINT_PRIVATE real *rot_v) {
  real c, sn;
  binomial_cos_sin_pi(bin / (GLINT_R(4.0) * ratio), &c, &sn);
  *rot_u = c * u + sn * v;
  *rot_v = -sn * u + c * v;
}

/* Steps 1 and 2 above for the footprint's shape f (binomial_footprint_shape). Grids 4..7 hold
 * no facets (binomial_fraction_lanes skips them). */
GLINT_FN FootprintGrids binomial_tetrahedral_grids_of_shape(FootprintShape f, real u, real v,
                                                            uint seed_lo, uint seed_hi) {
  FootprintGrids g;
  g.n_facets = f.n_facets;
  TetrahedralSplit q = binomial_tetrahedral_split(f);
  real rot_u[3], rot_v[3];
  for (int i = 0; i < 3; ++i)
    binomial_tetrahedral_rotate(q.vert_bin[i], q.vert_ratio[i], u, v, &rot_u[i], &rot_v[i]);
  glint_mask early = q.early, late = q.late;
  glint_key seed_key = rng_hash2(seed_lo, seed_hi);
  g.cell_key[0] = binomial_tetrahedral_key(seed_key, q.level[0], q.side[0], q.vert_aniso[0],
                                           q.vert_ratio[0], q.vert_bin[0], rot_u[0], rot_v[0]);
  g.cell_key[1] = binomial_tetrahedral_key(
      seed_key, q.level[1], q.side[1], glint_select(q.vert_aniso[0], q.vert_aniso[1], !early),
      glint_select(q.vert_ratio[0], q.vert_ratio[1], !early),
      glint_select(q.vert_bin[0], q.vert_bin[1], !early), glint_select(rot_u[0], rot_u[1], !early),
      glint_select(rot_v[0], rot_v[1], !early));
  g.cell_key[2] = binomial_tetrahedral_key(
      seed_key, q.level[2], q.side[2], glint_select(q.vert_aniso[1], q.vert_aniso[2], late),
      glint_select(q.vert_ratio[1], q.vert_ratio[2], late),
      glint_select(q.vert_bin[1], q.vert_bin[2], late), glint_select(rot_u[1], rot_u[2], late),
      glint_select(rot_v[1], rot_v[2], late));
  g.cell_key[3] = binomial_tetrahedral_key(seed_key, q.level[3], q.side[3], q.vert_aniso[2],
                                           q.vert_ratio[2], q.vert_bin[2], rot_u[2], rot_v[2]);
  for (int k = 0; k < GLINT_BINOMIAL_TETRAHEDRAL_GRIDS; ++k) g.share[k] = q.w[k];
  for (int k = GLINT_BINOMIAL_TETRAHEDRAL_GRIDS; k < GLINT_BINOMIAL_GRIDS; ++k) {
    g.share[k] = GLINT_R(0.0);
    g.cell_key[k] = rng_hash2(0u, 0u);
  }
  return g;
}

/* `footprint` = (du/dx, dv/dx, du/dy, dv/dy). */
GLINT_FN FootprintGrids binomial_footprint_grids_tetrahedral(real density, real u, real v,
                                                             const GLINT_PRIVATE real *footprint,
                                                             uint seed_lo, uint seed_hi) {
  return binomial_tetrahedral_grids_of_shape(binomial_footprint_shape(density, footprint), u, v,
                                             seed_lo, seed_hi);
}

#endif /* GLINT_BINOMIAL_TETRAHEDRAL_H */
