/* The procedural physically based glint BRDF of Chermain, Sauvage, Dischler
 * and Dachsbacher 2020 ("CSDD20", /work/shared/papers), for one query:
 *
 *   f_P(wo, wi) = F(wo.h) G2(wo, wi, h) D_P(h) / (4 cos_o cos_i)   (Eq. 14, Alg. 1)
 *   D_P(h) = P22_P(slope(h)) / (h.z)^4                             (Eq. 13, Alg. 1 l. 10)
 *   G2 = G1(wo, h) G1(wi, h), V-cavity G1                          (Eq. 15-16)
 *   P22_P = lerp over the two levels around the footprint's LOD of the
 *           footprint-weighted sum of per-cell SDFs                (Eq. 12, Alg. 1-2)
 *   per cell: two marginals of the dictionary (data/chermain/), rotated and
 *           scaled to (alpha_x, alpha_y)                           (Eq. 5-11, Alg. 3)
 *
 * Footprint: the uv Jacobian's covariance J J^T (eigen form, as the binomial
 * model), its minor axis clamped to major / max_anisotropy (Alg. 1 l. 4), LOD
 * l = max(0, nLevels - 1 + log2(minor)) (Alg. 1 l. 6). A level-L cell is
 * 2^(L - 15) uv units wide. Cells whose centre lies in the footprint ellipse
 * are weighted by Heckbert's truncated Gaussian exp(-2 r^2) - exp(-2) (the
 * Gaussian W_P of Sec. 6.1), normalised to sum 1 (Eq. 12); if no centre lies
 * inside (a footprint smaller than a cell) the cell holding uv has weight 1.
 * Cell count: at the level floor(l) the ellipse's semi-axes are b < 2 cells
 * and a <= gamma b < 2 gamma. A cell whose centre is inside lies in the
 * ellipse grown by the half-diagonal r = 0.71, of area pi a b + P r + pi r^2
 * with perimeter P <= pi sqrt(2) (a + b): at most 6 pi gamma + 2.5 pi cells,
 * 159 for gamma = 8, 310 for gamma = 16 (the largest allowed); the level
 * above has a quarter of that. The loops stop at GLINT_CHERMAIN_MAX_CELLS
 * (1024) per level, which valid inputs never reach.
 *
 * Departures from the paper (models/chermain/README.md):
 *  - Eq. 11 / Alg. 3 l. 16 write the slope transform as S^-1 R^-1; we apply
 *    R^-1 S^-1 (scale into the dictionary's isotropic frame, then rotate).
 *    With S^-1 R^-1 the anisotropic lobe itself is rotated by the random
 *    angle, so the cell average is not the anisotropic Beckmann target that
 *    Alg. 3 l. 10 and Sec. 7.1 promise; with R^-1 S^-1 the rotation acts on
 *    the isotropic dictionary SDF and the average is exactly the target. The
 *    Jacobian alpha_dict^2 / (alpha_x alpha_y) is the same.
 *  - The cell seed is (request seed, coherent cell index s0) through
 *    kernels/rng.h instead of the paper code's integer hash.
 * A footprint of 0 (or NaN) falls back to the smooth Beckmann BRDF with the
 * same V-cavity G, as the paper's code does.
 *
 * Written for GLINT_LANES == 1 (per-query loops over cells). */
#ifndef GLINT_CHERMAIN_EVAL_H
#define GLINT_CHERMAIN_EVAL_H

#include "kernels/compat.h"
#include "kernels/fresnel.h"
#include "kernels/kernel_args.h"
#include "kernels/punctual_lights.h"
#include "kernels/query.h"
#include "kernels/rng.h"
#include "kernels/smooth_brdf.h"
#include "models/chermain/chermain_params.h"

#define GLINT_CHERMAIN_MAX_CELLS 1024

typedef struct {
  real log_density; /* ln(rho), rho = facets per unit uv area */
  real beta;        /* microfacet relative area */
  real zeta;        /* density randomisation */
  real max_aniso;   /* gamma */
  int dict_size;    /* N */
  int n_colors;     /* colour table size (0: white) */
  real3 colors[GLINT_CHERMAIN_MAX_COLORS];
} ChermainParams;

GLINT_FN ChermainParams chermain_params_unpack(const GLINT_GLOBAL float *packed) {
  ChermainParams p;
  p.log_density = (real)packed[0];
  p.beta = (real)packed[1];
  p.zeta = (real)packed[2];
  p.max_aniso = (real)packed[3];
  p.dict_size = (int)packed[4];
  p.n_colors = (int)packed[5];
  for (int c = 0; c < GLINT_CHERMAIN_MAX_COLORS; ++c) {
    const GLINT_GLOBAL float *rgb = packed + GLINT_CHERMAIN_COLOR_OFFSET + 3 * c;
    p.colors[c] = make_real3((real)rgb[0], (real)rgb[1], (real)rgb[2]);
  }
  return p;
}

/* V-cavity masking G1(w, m) = H(w.m) min(1, 2 (m.n)(w.n) / (w.m)) (Eq. 16). */
GLINT_FN real chermain_g1(real3 w, real3 m) {
  real wm = r3_dot(w, m);
  real g = fmin(GLINT_R(1.0), fmax(GLINT_R(0.0), GLINT_R(2.0) * m.z * w.z / wm));
  return wm > GLINT_R(0.0) ? g : GLINT_R(0.0);
}

/* Marginal `index` of the dictionary at distribution level `level` and slope
 * x: linear interpolation between the nodes x_k = k X_MAX / (BINS - 1) of the
 * even function's positive half, 0 beyond X_MAX (data/chermain/README.md; the
 * normalisation assumed this interpolation, Sec. 7.3). */
GLINT_FN real chermain_marginal(const GLINT_GLOBAL float *table, int index, int level, real x) {
  real t = fabs(x) * (GLINT_R(GLINT_CHERMAIN_BINS - 1) / GLINT_R(GLINT_CHERMAIN_X_MAX));
  if (!(t <= GLINT_R(GLINT_CHERMAIN_BINS - 1))) return GLINT_R(0.0);
  int k = (int)t;
  k = k > GLINT_CHERMAIN_BINS - 2 ? GLINT_CHERMAIN_BINS - 2 : k;
  real f = t - (real)k;
  const GLINT_GLOBAL float *row =
      table + (index * GLINT_CHERMAIN_LEVELS + level) * GLINT_CHERMAIN_BINS;
  return (GLINT_R(1.0) - f) * (real)row[k] + f * (real)row[k + 1];
}

/* The anisotropic Beckmann SDF, the dictionary's limit (Sec. 4.3, "Coarsest
 * LOD"; Alg. 3 l. 10): exp(-(x^2 / ax^2 + y^2 / ay^2)) / (pi ax ay). */
GLINT_FN real chermain_target_sdf(real sx, real sy, real alpha_x, real alpha_y) {
  real tx = sx / alpha_x, ty = sy / alpha_y;
  real t2 = tx * tx + ty * ty;
  /* exp(-80) ~ 1.8e-35: beyond it the SDF is below any float result (as kernels/ndf.h). */
  return t2 <= GLINT_R(80.0) ? exp(-t2) / (GLINT_PI * alpha_x * alpha_y) : GLINT_R(0.0);
}

/* Alg. 3: the SDF of the cell with coherent index s0 (Eq. 8) at hierarchy
 * level `level`, at slope (sx, sy). `cell_key` = hash of (seed, s0). */
GLINT_FN real3 chermain_cell_sdf(const GLINT_GLOBAL float *table, ChermainParams p, real alpha_x,
                                 real alpha_y, uint cell_key, real level, real sx, real sy) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  /* l. 3-4: discard the cell with probability 1 - beta. */
  if (rng_u01(rng_hash2(cell_key, 1u)) >= p.beta) return zero;
  /* l. 5-6: facets in the cell n = 4^(level - (nLevels - 1)) rho, l_dist = log4(n). */
  real l_dist =
      level - GLINT_R(GLINT_CHERMAIN_LEVELS - 1) + p.log_density * GLINT_R(0.72134752044448170);
  /* l. 7-8: density randomisation, l_dist ~ N(l_dist, zeta^2) (Box-Muller). */
  if (p.zeta > GLINT_R(0.0)) {
    real u1 = GLINT_R(1.0) - rng_u01(rng_hash2(cell_key, 2u));
    real u2 = rng_u01(rng_hash2(cell_key, 3u));
    l_dist += p.zeta * sqrt(GLINT_R(-2.0) * log(u1)) * cos(GLINT_R(2.0) * GLINT_PI * u2);
  }
  /* l. 9-10: round and clamp; the last level is the target Beckmann SDF. */
  l_dist = clamp(floor(l_dist + GLINT_R(0.5)), GLINT_R(0.0), GLINT_R(GLINT_CHERMAIN_LEVELS));
  if (l_dist >= GLINT_R(GLINT_CHERMAIN_LEVELS)) {
    real t = chermain_target_sdf(sx, sy, alpha_x, alpha_y);
    return make_real3(t, t, t);
  }
  /* l. 11-12: the cell's colour (white without a table); the last level, above, has none. */
  real3 color = make_real3(GLINT_R(1.0), GLINT_R(1.0), GLINT_R(1.0));
  if (p.n_colors > 0) {
    real nc = (real)p.n_colors;
    int c = (int)fmin(floor(nc * rng_u01(rng_hash2(cell_key, 7u))), nc - GLINT_R(1.0));
    color = p.colors[c];
  }
  /* l. 13-16 (order R^-1 S^-1, see the header): into the dictionary's frame
   * (Eq. 10: S^-1 = alpha_dict diag(1 / alpha_x, 1 / alpha_y)), then the
   * inverse of the cell's random rotation theta = 2 pi U_r (Eq. 9). */
  real qx = sx * (GLINT_R(GLINT_CHERMAIN_ALPHA_DICT) / alpha_x);
  real qy = sy * (GLINT_R(GLINT_CHERMAIN_ALPHA_DICT) / alpha_y);
  /* The product of two marginals is 0 outside the square |x|, |y| <= X_MAX,
   * hence outside its circumcircle whatever the rotation: skip the work. */
  if (!(qx * qx + qy * qy <= GLINT_R(2.0 * GLINT_CHERMAIN_X_MAX * GLINT_CHERMAIN_X_MAX)))
    return zero;
  real theta = GLINT_R(2.0) * GLINT_PI * rng_u01(rng_hash2(cell_key, 4u));
  real c = cos(theta), s = sin(theta);
  real rx = c * qx + s * qy;
  real ry = -s * qx + c * qy;
  /* l. 17-18: two marginals of the first N. */
  real n = (real)p.dict_size;
  int i = (int)fmin(floor(n * rng_u01(rng_hash2(cell_key, 5u))), n - GLINT_R(1.0));
  int j = (int)fmin(floor(n * rng_u01(rng_hash2(cell_key, 6u))), n - GLINT_R(1.0));
  /* l. 19 (Eq. 11 with Eq. 5): product of the marginals, times the Jacobian
   * alpha_dict^2 / (alpha_x alpha_y) of the scaling. */
  int lv = (int)l_dist;
  real sdf = chermain_marginal(table, i, lv, rx) * chermain_marginal(table, j, lv, ry) *
             (GLINT_R(GLINT_CHERMAIN_ALPHA_DICT * GLINT_CHERMAIN_ALPHA_DICT) / (alpha_x * alpha_y));
  return r3_scale(color, sdf);
}

/* The query's footprint (Alg. 1 l. 3-7). */
typedef struct {
  int smooth;  /* no usable footprint: the smooth Beckmann BRDF */
  real level0; /* floor(l) */
  real w1;     /* weight of level0 + 1 (Alg. 1 l. 7) */
  real major;  /* semi-axes (uv units) after the eccentricity clamp */
  real minor;
  real cos_t, sin_t; /* major-axis direction */
  real u, v;
} ChermainFootprint;

GLINT_FN ChermainFootprint chermain_footprint(ChermainParams p, real u, real v,
                                              const GLINT_PRIVATE real *fp) {
  ChermainFootprint f;
  real x1 = fp[0], y1 = fp[1], x2 = fp[2], y2 = fp[3];
  /* Covariance J J^T = [[A, B], [B, C]]; eigenvalues without cancellation:
   * the small one as det / large (models/binomial/binomial_count.h). */
  real A = x1 * x1 + x2 * x2, B = x1 * y1 + x2 * y2, C = y1 * y1 + y2 * y2;
  real half_diff = GLINT_R(0.5) * (A - C);
  real lambda1 = GLINT_R(0.5) * (A + C) + sqrt(half_diff * half_diff + B * B);
  real major = sqrt(fmax(lambda1, GLINT_R(0.0)));
  real minor = fabs(x1 * y2 - x2 * y1) / major;
  real theta = GLINT_R(0.5) * atan2(GLINT_R(2.0) * B, A - C);
  f.smooth = !(major > GLINT_R(0.0)) || !isfinite(major) || !isfinite(u) || !isfinite(v);
  /* Alg. 1 l. 4: clamp the eccentricity to gamma. */
  minor = fmax(minor, major / p.max_aniso);
  f.major = major;
  f.minor = minor;
  f.cos_t = cos(theta);
  f.sin_t = sin(theta);
  f.u = u;
  f.v = v;
  /* Alg. 1 l. 6-7. */
  real l = fmax(GLINT_R(0.0), GLINT_R(GLINT_CHERMAIN_LEVELS - 1) + log2(minor));
  f.level0 = floor(l);
  f.w1 = l - f.level0;
  if (f.smooth) {
    f.level0 = GLINT_R(0.0);
    f.w1 = GLINT_R(0.0);
  }
  return f;
}

/* Alg. 2: the footprint-weighted SDF of one hierarchy level at slope (sx, sy). */
GLINT_FN real3 chermain_level_sdf(const GLINT_GLOBAL float *table, ChermainParams p,
                                  ChermainFootprint f, real alpha_x, real alpha_y, uint seed_key,
                                  real level, real sx, real sy) {
  /* Cell units of this level: 1 cell = 2^(level - 15) uv. The semi-axes in
   * cells are kept in [1e-3, 2 gamma] (below 1e-3 of a cell the footprint is a
   * point and the fallback cell below takes over; the clamp keeps the
   * quadratic forms free of under- and overflow). */
  real to_cells = exp2(GLINT_R(GLINT_CHERMAIN_LEVELS - 1) - level);
  real b = fmax(f.minor * to_cells, GLINT_R(1e-3));
  real a = fmax(f.major * to_cells, b);
  real pu = f.u * to_cells, pv = f.v * to_cells;
  real iu = floor(pu), iv = floor(pv);
  real fu = pu - iu, fv = pv - iv; /* position inside the cell (iu, iv) */
  /* Covariance in cells: R diag(a^2, b^2) R^T. */
  real c = f.cos_t, s = f.sin_t;
  real syy = a * a * s * s + b * b * c * c;
  real sxy = (a * a - b * b) * c * s;
  real ey = sqrt(syy);
  real scale = exp2(level); /* coherent index s0 = cell * 2^level (Eq. 8) */
  real sum_w = GLINT_R(0.0);
  real3 sum = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  int cells = 0;
  real k_lo = -floor(-(fv - ey - GLINT_R(0.5))), k_hi = floor(fv + ey - GLINT_R(0.5));
  for (real ky = k_lo; ky <= k_hi && cells < GLINT_CHERMAIN_MAX_CELLS; ky += GLINT_R(1.0)) {
    real dy = ky + GLINT_R(0.5) - fv;
    real rem = syy - dy * dy;
    if (!(rem >= GLINT_R(0.0))) continue;
    /* The ellipse's chord at this row: centre sxy dy / syy, half-width
     * a b sqrt(syy - dy^2) / syy (solving d^T Sigma^-1 d = 1 for dx). */
    real cx = fu + sxy * dy / syy;
    real half_w = a * b * sqrt(rem) / syy;
    real j_lo = -floor(-(cx - half_w - GLINT_R(0.5))), j_hi = floor(cx + half_w - GLINT_R(0.5));
    for (real kx = j_lo; kx <= j_hi && cells < GLINT_CHERMAIN_MAX_CELLS; kx += GLINT_R(1.0)) {
      real dx = kx + GLINT_R(0.5) - fu;
      real da = c * dx + s * dy, db = -s * dx + c * dy;
      real r2 = da * da / (a * a) + db * db / (b * b);
      real w = exp(GLINT_R(-2.0) * r2) - GLINT_R(0.1353352832366127);
      ++cells;
      if (!(w > GLINT_R(0.0))) continue;
      uint key = rng_absorb(seed_key, rng_float_key((float)((iu + kx) * scale)));
      key = rng_absorb(key, rng_float_key((float)((iv + ky) * scale)));
      sum_w += w;
      sum = r3_add(sum,
                   r3_scale(chermain_cell_sdf(table, p, alpha_x, alpha_y, key, level, sx, sy), w));
    }
  }
  if (sum_w > GLINT_R(0.0)) return r3_scale(sum, GLINT_R(1.0) / sum_w);
  /* No cell centre inside the footprint: the cell that holds uv. */
  uint key = rng_absorb(seed_key, rng_float_key((float)(iu * scale)));
  key = rng_absorb(key, rng_float_key((float)(iv * scale)));
  return chermain_cell_sdf(table, p, alpha_x, alpha_y, key, level, sx, sy);
}

/* Alg. 1 l. 8 (Eq. 12): the footprint's P-SDF at slope (sx, sy), the lerp of
 * the two levels around its LOD; the target Beckmann SDF when the footprint is
 * unusable. */
GLINT_FN real3 chermain_pndf_sdf(const GLINT_GLOBAL float *table, ChermainParams p,
                                 ChermainFootprint f, real alpha_x, real alpha_y, uint seed_key,
                                 real sx, real sy) {
  if (f.smooth) {
    real t = chermain_target_sdf(sx, sy, alpha_x, alpha_y);
    return make_real3(t, t, t);
  }
  real3 sdf = chermain_level_sdf(table, p, f, alpha_x, alpha_y, seed_key, f.level0, sx, sy);
  if (f.w1 > GLINT_R(0.0)) {
    real3 up = chermain_level_sdf(table, p, f, alpha_x, alpha_y, seed_key, f.level0 + GLINT_R(1.0),
                                  sx, sy);
    sdf = r3_add(r3_scale(sdf, GLINT_R(1.0) - f.w1), r3_scale(up, f.w1));
  }
  return sdf;
}

/* f_P(wi, wo) cos_i (Eq. 14 times cos_i; Alg. 1), or the smooth Beckmann BRDF
 * with V-cavity G when the footprint is unusable. */
GLINT_FN real3 chermain_reflect_cos(const GLINT_GLOBAL float *table, ChermainParams p,
                                    ChermainFootprint f, SmoothMaterial m, uint seed_key, real3 wi,
                                    real3 wo) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 hs = r3_add(wi, wo);
  real h_len = r3_length(hs);
  if (!(wi.z > GLINT_R(0.0)) || !(wo.z > GLINT_R(0.0)) || !(h_len > GLINT_R(0.0))) return zero;
  real3 h = r3_div(hs, h_len);
  if (!(h.z > GLINT_R(0.0))) return zero;
  /* Alg. 1 l. 2 (Eq. 1): the half-vector's slope. */
  real3 sdf =
      chermain_pndf_sdf(table, p, f, m.alpha_x, m.alpha_y, seed_key, -h.x / h.z, -h.y / h.z);
  /* Alg. 1 l. 10 (Eq. 13); the colour table makes D_P an RGB value. */
  real hz2 = h.z * h.z;
  real hz4 = hz2 * hz2;
  real3 D = hz4 > GLINT_R(0.0) ? r3_scale(sdf, GLINT_R(1.0) / hz4)
                               : make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  /* Alg. 1 l. 11 times cos_i: F G1(wo, h) G1(wi, h) D / (4 cos_o). */
  real g2 = chermain_g1(wo, h) * chermain_g1(wi, h);
  real3 F = fresnel_eval(m.fresnel, r3_dot(wo, h));
  return r3_scale(r3_mul(F, D), g2 / (GLINT_R(4.0) * wo.z));
}

/* Reflected radiance towards wo (RGB) for query i: a BRDF probe, or the
 * directional and point lights (as delta lights: the paper shades point
 * lights; cone and sphere sizes are ignored). Polygon lights are refused by
 * the descriptor (chermain_model.cpp). */
GLINT_FN real3 chermain_query(EvalSpec spec, KernelInputs in, uint i) {
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  ChermainParams p = chermain_params_unpack(in.params);
  QueryInputs q = query_load(spec, in, i);
  ShadingPoint sp = shading_point(spec, q);
  real fp[4];
  for (int k = 0; k < 4; ++k) fp[k] = (real)in.footprint[4 * i + k];
  ChermainFootprint f = chermain_footprint(p, (real)in.uv[2 * i], (real)in.uv[2 * i + 1], fp);
  uint seed_key = rng_hash2(in.seed_lo, in.seed_hi);
  if (spec.probe) {
    real3 wi = shading_to_local(spec, sp, r3_normalize(q.wi));
    return chermain_reflect_cos(in.model_table, p, f, m, seed_key, wi, sp.wo);
  }
  uint n_lights = punctual_light_count(spec, in);
  for (uint l = 0; l < n_lights; ++l) {
    PunctualLight light = punctual_light(spec, in, sp, l);
    real3 fc = chermain_reflect_cos(in.model_table, p, f, m, seed_key, light.wi, sp.wo);
    radiance = r3_add(radiance, r3_mul(fc, light.irradiance));
  }
  return radiance;
}

#endif /* GLINT_CHERMAIN_EVAL_H */
