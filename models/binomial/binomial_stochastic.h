/* The binomial model's cheapest footprint interpolation (material.binomial.footprint_interpolation
 * STOCHASTIC): all N_P trials in ONE of the tetrahedral scheme's 4 grids
 * (binomial_tetrahedral.h), grid g chosen with probability w_g by a uniform xi, instead of
 * splitting them as w_g N_P between the grids. Every light then costs one binomial draw instead
 * of 4 (TETRAHEDRAL) or 8 (TRILINEAR), and the footprint one rotation and one cell key instead
 * of 3 and 4.
 *
 * Why it stays exact: xi is hashed from keys no draw uses, so it is independent of every
 * cell's count; given xi the chosen grid's count is Binomial(N_P, p) (one draw of N_P trials,
 * binomial_draw_prob), whatever grid xi picks. So the count's law is Binomial(N_P, p) itself,
 * for every footprint: mean N_P p (KK24 Eq. 16, E[L] = L_smooth), variance N_P p (1 - p) (the
 * same convergence law as the split schemes; for integer N_P the split schemes' sum of
 * binomials of fractional trial counts is only close to it).
 *
 * What changes is the pattern in motion: where the split moves facets between grids one at a
 * time as the weights change, here a footprint's count jumps to another cell's when xi crosses
 * a weight boundary (stochastic texture filtering: Pharr, Wronski, Salvi, Fajardo 2024,
 * "Filtering After Shading With Stochastic Texture Filtering"; Kemppinen et al. 2025 Sec. 3.3.3
 * choose between glint levels by a per-point Russian roulette for the same reason: linear
 * blending doubles the glints at half the intensity, DB23 Sec. 4). xi is keyed by the seed and
 * the axis-aligned uv cell of side 2^(l0 + 1), the coarser of the footprint's two levels: it is
 * the same for every footprint of that size in that region, so neighbouring pixels switch grid
 * at the same weights and a footprint moving inside the cell keeps its choice while its
 * weights do; across cells the switches are dithered instead of one seam across the image.
 * DEPARTURE from KK24 / DB23, who blend (split) the grids: a quality knob, not the default. */
#ifndef GLINT_BINOMIAL_STOCHASTIC_H
#define GLINT_BINOMIAL_STOCHASTIC_H

#include "models/binomial/binomial_tetrahedral.h"

/* Absorbed first into xi's key: a float-bits key no level (an integer-valued real) has, so
 * xi's hash chain differs from every cell key's (seed, level, ...). */
#define GLINT_BINOMIAL_SELECT_TAG 0x005e1ec7u

/* The selection uniform xi of the footprint: seed, tag, level l0 + 1 and the uv cell of side
 * 2^(l0 + 1) (q.level[3], q.side[3]). */
GLINT_FN real binomial_select_uniform(TetrahedralSplit q, real u, real v, uint seed_lo,
                                      uint seed_hi) {
  glint_key key = rng_absorb_key(rng_hash2(seed_lo, seed_hi), GLINT_BINOMIAL_SELECT_TAG);
  key = rng_absorb_key(key, binomial_cell_key(q.level[3]));
  key = rng_absorb_key(key, binomial_cell_key(glint_floor(u / q.side[3])));
  key = rng_absorb_key(key, binomial_cell_key(glint_floor(v / q.side[3])));
  return rng_u01_key(key);
}

/* `footprint` = (du/dx, dv/dx, du/dy, dv/dy). Grid 0 holds all N_P facets (share 1), with the
 * chosen grid's cell key (the tetrahedral scheme's key of that grid, bit for bit); grids 1..7
 * hold none (binomial_fraction_lanes skips them). */
GLINT_FN FootprintGrids binomial_footprint_grids_stochastic(real density, real u, real v,
                                                            const GLINT_PRIVATE real *footprint,
                                                            uint seed_lo, uint seed_hi) {
  FootprintShape f = binomial_footprint_shape(density, footprint);
  TetrahedralSplit q = binomial_tetrahedral_split(f);
  real xi = binomial_select_uniform(q, u, v, seed_lo, seed_hi);
  /* The chosen grid: the last with w_k > 0 whose interval [w_0 + .. + w_(k-1), + w_k) starts at
   * or below xi, so grid k is chosen for xi in its interval (probability w_k) and the last grid
   * holding facets also for xi beyond the rounded sum of the weights. Per lane, by selects of
   * its lattice coordinates (grid -> vertex as in TetrahedralSplit). */
  real grid_aniso[GLINT_BINOMIAL_TETRAHEDRAL_GRIDS], grid_ratio[GLINT_BINOMIAL_TETRAHEDRAL_GRIDS],
      grid_bin[GLINT_BINOMIAL_TETRAHEDRAL_GRIDS];
  /* grid 0 at vertex 0, grid 3 at vertex 2; grid 1 at vertex 0 where early, else 1; grid 2 at
   * vertex 2 where late, else 1 */
  grid_aniso[0] = q.vert_aniso[0];
  grid_ratio[0] = q.vert_ratio[0];
  grid_bin[0] = q.vert_bin[0];
  grid_aniso[1] = glint_select(q.vert_aniso[1], q.vert_aniso[0], q.early);
  grid_ratio[1] = glint_select(q.vert_ratio[1], q.vert_ratio[0], q.early);
  grid_bin[1] = glint_select(q.vert_bin[1], q.vert_bin[0], q.early);
  grid_aniso[2] = glint_select(q.vert_aniso[1], q.vert_aniso[2], q.late);
  grid_ratio[2] = glint_select(q.vert_ratio[1], q.vert_ratio[2], q.late);
  grid_bin[2] = glint_select(q.vert_bin[1], q.vert_bin[2], q.late);
  grid_aniso[3] = q.vert_aniso[2];
  grid_ratio[3] = q.vert_ratio[2];
  grid_bin[3] = q.vert_bin[2];
  real level = q.level[0], side = q.side[0];
  real aniso = grid_aniso[0], ratio = grid_ratio[0], bin = grid_bin[0];
  real start = GLINT_R(0.0);
  for (int k = 1; k < GLINT_BINOMIAL_TETRAHEDRAL_GRIDS; ++k) {
    start += q.w[k - 1];
    glint_mask pick = (q.w[k] > GLINT_R(0.0)) & (xi >= start);
    level = glint_select(level, q.level[k], pick);
    side = glint_select(side, q.side[k], pick);
    aniso = glint_select(aniso, grid_aniso[k], pick);
    ratio = glint_select(ratio, grid_ratio[k], pick);
    bin = glint_select(bin, grid_bin[k], pick);
  }
  real rot_u, rot_v;
  binomial_tetrahedral_rotate(bin, ratio, u, v, &rot_u, &rot_v);
  FootprintGrids g;
  g.n_facets = f.n_facets;
  g.cell_key[0] = binomial_tetrahedral_key(rng_hash2(seed_lo, seed_hi), level, side, aniso, ratio,
                                           bin, rot_u, rot_v);
  g.share[0] = GLINT_R(1.0);
  for (int k = 1; k < GLINT_BINOMIAL_GRIDS; ++k) {
    g.share[k] = GLINT_R(0.0);
    g.cell_key[k] = rng_hash2(0u, 0u);
  }
  return g;
}

/* The footprint's grids by the material's interpolation (a uniform branch: one material per
 * request). */
GLINT_FN FootprintGrids binomial_footprint_grids_for(int interpolation, real density, real u,
                                                     real v, const GLINT_PRIVATE real *footprint,
                                                     uint seed_lo, uint seed_hi) {
  if (interpolation == GLINT_BINOMIAL_STOCHASTIC)
    return binomial_footprint_grids_stochastic(density, u, v, footprint, seed_lo, seed_hi);
  if (interpolation == GLINT_BINOMIAL_TETRAHEDRAL)
    return binomial_footprint_grids_tetrahedral(density, u, v, footprint, seed_lo, seed_hi);
  return binomial_footprint_grids(density, u, v, footprint, seed_lo, seed_hi);
}

#endif /* GLINT_BINOMIAL_STOCHASTIC_H */
