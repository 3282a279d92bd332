/* Importance sampling of the Kemppinen glinty BRDF (K25 Sec. 3.3.5,
 * Algorithm 2), with a pdf that is exact so the weight f cos_i / pdf is an
 * unbiased estimate of the albedo (kernels/sample.h).
 *
 * A one-sample mixture of two strategies, the smooth one with probability q in
 * [1/2, 0.95] (kemppinen_sample_smooth_fraction, from the query's footprint):
 *  - smooth: the base NDF's strategy (kernels/sample.h: GGX visible normals,
 *    Beckmann D cos). It covers the compensation part of D_star (Eq. 9-11),
 *    which K25 chooses not to sample ("only significant if the Gaussians are
 *    wide enough to sample the whole area roughly uniformly on their own").
 *  - glints, Algorithm 2 in U = the disk image of the NDF (kemppinen_ndf.h):
 *    1. the MIP level l in {floor, floor + 1} of lambda with probability its
 *       weight w_l (Alg. 2 lines 4-6);
 *    2. an angular cell of level l uniformly among the res_a^2 cells of the
 *       unit square (Alg. 2 line 2 draws x_a uniformly on the disk; we draw
 *       its cell, and cells' facets outside the disk carry no weight);
 *    3. one of the cell's facets in the 2x2 spatial block around x_s by
 *       reservoir sampling (Vitter 1985; Alg. 2 lines 9-15) with weights
 *       w = R(r, w_l) N(x_s - g_s; Sigma_s) Luminance(c) (Alg. 2 line 12,
 *       without the angular mass: the lobe is sampled within the cell below);
 *    4. x in the cell: with probability 1/2 the facet's Gaussian lobe (Eq. 4,
 *       its width at the facet's centre) by Box-Muller, else uniformly in the
 *       cell (so lobes wider than the cell are still covered); a Gaussian
 *       point outside the cell, or any point outside the disk, gives no
 *       sample (this replaces Alg. 2's truncated sampling "Sample(1_B N)",
 *       which needs an inverse erf, and keeps the pdf exact);
 *    5. h = T^-1(x), wi = reflect(wo, h).
 *    Its density in U at a point x, summed over the two levels l:
 *      p_U(x) = sum_l w_l res_a^-2 [ 1/2 sum_j (w_j / W) N(x; g_j, sigma_j)
 *                                    + 1/2 res_a^2 ]   (cell of x, W = sum w_j > 0)
 *    and in solid angle p_h(h) = p_U(T(h)) |J_T(h)|, p_wi = p_h / (4 wo.h).
 * The pdf returned is the mixture's, q p_smooth + (1 - q) p_glint, evaluated for
 * every sample whichever strategy drew it (the one-sample MIS balance form,
 * Veach 1997 Sec. 9.2.4), so the weight is f cos_i / pdf exactly.
 * Colours enter the facet choice through the mean of the facet's colour. */
#ifndef GLINT_KEMPPINEN_SAMPLE_H
#define GLINT_KEMPPINEN_SAMPLE_H

#include "kernels/sample.h"
#include "models/kemppinen/kemppinen_eval.h"

/* Bounds of q, the probability of the smooth strategy. q >= 1/2 bounds the
 * weight by twice the smooth sampler's (a defensive mixture, Hesterberg 1995),
 * so the second moment is at most twice the smooth lobe's wherever the glints
 * do not help; q <= 0.95 keeps sampling the glints where they are resolved. */
#define GLINT_KEMPPINEN_SAMPLE_SMOOTH_MIN 0.5f
#define GLINT_KEMPPINEN_SAMPLE_SMOOTH_MAX 0.95f

/* q, a function of the query only (so sampling and the pdf agree): the
 * expected number of facets under one pixel filter and one facet lobe,
 *   N = K_P (4 pi sqrt(det Sigma_s)) (4 pi sigma_ax sigma_ay)
 * (the effective areas 1 / integral of N^2 of the two Gaussians; facets are
 * uniform with density K_P per unit uv x U area), with the lobe at the pole.
 * N << 1: isolated glints, q = 1/2; N >> 1: D_star is close to D (Eq. 2), the
 * smooth lobe is the better proposal, q -> N / (1 + N) up to the bound. */
GLINT_FN real kemppinen_sample_smooth_fraction(SmoothMaterial m, KemppinenParams p,
                                               KemppinenFootprint fp) {
  real3 pole = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  real Dn = ndf_D(m.ndf, pole, m.alpha_x, m.alpha_y);
  KemppinenAngular a =
      kemppinen_angular(p, kemppinen_to_disk(m.ndf, pole, m.alpha_x, m.alpha_y, Dn));
  real det = fmax(fp.sxx * fp.syy - fp.sxy * fp.sxy, GLINT_R(0.0));
  real n =
      p.density * (GLINT_R(4.0) * GLINT_PI * sqrt(det)) * (GLINT_R(4.0) * GLINT_PI * a.sx * a.sy);
  /* N / (1 + N) as 1 / (1 + 1 / N): N = inf gives 1, N = 0 gives 0. */
  real q = GLINT_R(1.0) / (GLINT_R(1.0) + GLINT_R(1.0) / n);
  return clamp(q, GLINT_R(GLINT_KEMPPINEN_SAMPLE_SMOOTH_MIN),
               GLINT_R(GLINT_KEMPPINEN_SAMPLE_SMOOTH_MAX));
}

/* The facet choice weight's spatial factor: the pixel filter N(x_s - g_s;
 * Sigma_s) up to its norm (the exponent of kemppinen_facet_lobe's spatial
 * part, in cells). */
GLINT_FN real kemppinen_spatial_filter(KemppinenBlocks b, real cx, real cy, KemppinenFacet g) {
  real dx = b.ts_x - cx - g.sx, dy = b.ts_y - cy - g.sy;
  return exp(-(b.qxx * dx * dx + b.qxy * dx * dy + b.qyy * dy * dy));
}

/* One facet of a level's angular cell as the glint strategy sees it. */
typedef struct {
  real w;      /* choice weight (0: rejected facet or dropped by the roulette) */
  real gx, gy; /* lobe centre in U */
  real sx, sy; /* lobe standard deviations in U */
} KemppinenSampleFacet;

GLINT_FN KemppinenSampleFacet kemppinen_sample_facet(SmoothMaterial m, KemppinenParams p,
                                                     KemppinenFootprint fp, KemppinenBlocks b,
                                                     real level, real wl, int j, real ix, real iy) {
  KemppinenSampleFacet s;
  real cx = b.bs_x + (real)(j & 1), cy = b.bs_y + (real)(j >> 1);
  KemppinenFacet g = kemppinen_facet(kemppinen_spatial_key(fp.seed_key, level, cx, cy), ix, iy);
  s.gx = (ix + g.ax) / b.res_a;
  s.gy = (iy + g.ay) / b.res_a;
  real ox = s.gx - GLINT_R(0.5), oy = s.gy - GLINT_R(0.5);
  real3 c = kemppinen_facet_color(p, g);
  real lum = (c.x + c.y + c.z) * GLINT_R(1.0 / 3.0);
  s.w = ox * ox + oy * oy < GLINT_R(0.25)
            ? kemppinen_roulette(g.r, wl) * kemppinen_spatial_filter(b, cx, cy, g) * lum
            : GLINT_R(0.0);
  /* The lobe's width at its centre (Eq. 4): sigma = alpha_star sqrt(|J_T(h_g)|). */
  real3 hg = kemppinen_from_disk(m.ndf, s.gx, s.gy, m.alpha_x, m.alpha_y);
  real Dg = ndf_D(m.ndf, hg, m.alpha_x, m.alpha_y);
  KemppinenAngular a = kemppinen_angular(p, kemppinen_to_disk(m.ndf, hg, m.alpha_x, m.alpha_y, Dg));
  s.sx = a.sx;
  s.sy = a.sy;
  return s;
}

/* The level's blocks for the spatial part only (the angular query is unused). */
GLINT_FN KemppinenBlocks kemppinen_sample_blocks(KemppinenParams p, KemppinenFootprint fp,
                                                 real level) {
  KemppinenAngular a;
  a.x = GLINT_R(0.5);
  a.y = GLINT_R(0.5);
  a.sx = GLINT_R(1.0);
  a.sy = GLINT_R(1.0);
  return kemppinen_blocks(p, fp, a, level);
}

/* Level l's term of p_U at x (in U), given its MIP weight wl. */
GLINT_FN real kemppinen_glint_pdf_level(SmoothMaterial m, KemppinenParams p, KemppinenFootprint fp,
                                        real level, real wl, real x, real y) {
  if (!(wl > GLINT_R(0.0))) return GLINT_R(0.0);
  KemppinenBlocks b = kemppinen_sample_blocks(p, fp, level);
  real ix = clamp(glint_floor(x * b.res_a), GLINT_R(0.0), b.res_a - GLINT_R(1.0));
  real iy = clamp(glint_floor(y * b.res_a), GLINT_R(0.0), b.res_a - GLINT_R(1.0));
  real W = GLINT_R(0.0), lobes = GLINT_R(0.0);
  for (int j = 0; j < 4; ++j) {
    KemppinenSampleFacet f = kemppinen_sample_facet(m, p, fp, b, level, wl, j, ix, iy);
    real ux = (x - f.gx) / f.sx, uy = (y - f.gy) / f.sy;
    real n = exp(GLINT_R(-0.5) * (ux * ux + uy * uy)) / (GLINT_R(2.0) * GLINT_PI * f.sx * f.sy);
    W += f.w;
    lobes += f.w * n;
  }
  if (!(W > GLINT_R(0.0))) return GLINT_R(0.0);
  real cells = b.res_a * b.res_a;
  return wl / cells * (GLINT_R(0.5) * lobes / W + GLINT_R(0.5) * cells);
}

/* The glint strategy's pdf (solid angle) of wi. */
GLINT_FN real kemppinen_glint_pdf(SmoothMaterial m, KemppinenParams p, KemppinenFootprint fp,
                                  real3 wo, real3 wi) {
  real3 h = sample_half_vector(wi, wo);
  real woh = r3_dot(wo, h);
  if (!(h.z > GLINT_R(0.0)) || !(woh > GLINT_R(0.0))) return GLINT_R(0.0);
  real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
  DiskPoint d = kemppinen_to_disk(m.ndf, h, m.alpha_x, m.alpha_y, D);
  real lf = glint_floor(fp.lambda), w1 = fp.lambda - lf;
  real pu =
      kemppinen_glint_pdf_level(m, p, fp, lf, GLINT_R(1.0) - w1, d.x, d.y) +
      kemppinen_glint_pdf_level(
          m, p, fp, fmin(lf + GLINT_R(1.0), GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL)), w1, d.x, d.y);
  return pu * d.jac / (GLINT_R(4.0) * woh);
}

/* A half-vector from the glint strategy, or h.z = 0 for no sample. */
GLINT_FN real3 kemppinen_glint_half_vector(SmoothMaterial m, KemppinenParams p,
                                           KemppinenFootprint fp, uint key) {
  real3 none = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  /* 1. The level (Alg. 2 lines 4-6). */
  real lf = glint_floor(fp.lambda), w1 = fp.lambda - lf;
  int upper = sample_u(key, 2u) < w1;
  real level = upper ? fmin(lf + GLINT_R(1.0), GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL)) : lf;
  real wl = upper ? w1 : GLINT_R(1.0) - w1;
  KemppinenBlocks b = kemppinen_sample_blocks(p, fp, level);
  /* 2. The angular cell. */
  real ix = fmin(glint_floor(sample_u(key, 3u) * b.res_a), b.res_a - GLINT_R(1.0));
  real iy = fmin(glint_floor(sample_u(key, 4u) * b.res_a), b.res_a - GLINT_R(1.0));
  /* 3. Reservoir over the cell's four facets: keep facet j with probability
   * w_j / (running sum), one uniform per candidate. */
  KemppinenSampleFacet chosen = kemppinen_sample_facet(m, p, fp, b, level, wl, 0, ix, iy);
  real W = chosen.w;
  for (int j = 1; j < 4; ++j) {
    KemppinenSampleFacet f = kemppinen_sample_facet(m, p, fp, b, level, wl, j, ix, iy);
    W += f.w;
    if (f.w > GLINT_R(0.0) && sample_u(key, 5u + (uint)j) * W < f.w) chosen = f;
  }
  if (!(W > GLINT_R(0.0))) return none;
  /* 4. A point of the cell: the facet's lobe or uniform. */
  real x, y;
  if (sample_u(key, 9u) < GLINT_R(0.5)) {
    /* Box-Muller; 1 - u in (0, 1] keeps the log finite. */
    real r = sqrt(GLINT_R(-2.0) * log(GLINT_R(1.0) - sample_u(key, 10u)));
    real phi = GLINT_R(2.0) * GLINT_PI * sample_u(key, 11u);
    x = chosen.gx + chosen.sx * r * cos(phi);
    y = chosen.gy + chosen.sy * r * sin(phi);
    real cx = x * b.res_a - ix, cy = y * b.res_a - iy;
    if (!(cx >= GLINT_R(0.0) && cx < GLINT_R(1.0) && cy >= GLINT_R(0.0) && cy < GLINT_R(1.0)))
      return none;
  } else {
    x = (ix + sample_u(key, 10u)) / b.res_a;
    y = (iy + sample_u(key, 11u)) / b.res_a;
  }
  /* 5. Back to a half-vector (outside the disk: none). */
  return kemppinen_from_disk(m.ndf, x, y, m.alpha_x, m.alpha_y);
}

/* Sample k of query i. */
GLINT_FN BrdfSample kemppinen_sample(EvalSpec spec, KernelInputs in, uint i, uint k) {
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  KemppinenParams p = kemppinen_params_unpack(in.params);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  if (!(sp.wo.z > GLINT_R(0.0))) return sample_none();
  real footprint[4];
  kemppinen_load_footprint(in, i, footprint);
  KemppinenFootprint fp = kemppinen_footprint(p, (real)in.uv[2 * i], (real)in.uv[2 * i + 1],
                                              footprint, in.seed_lo, in.seed_hi);
  uint key = sample_key(spec, in, i, k, 1);
  real q = kemppinen_sample_smooth_fraction(m, p, fp);
  real3 h = sample_u(key, 12u) < q
                ? smooth_sample_half_vector(m, sp.wo, sample_u(key, 0u), sample_u(key, 1u))
                : kemppinen_glint_half_vector(m, p, fp, key);
  if (!(r3_dot(sp.wo, h) > GLINT_R(0.0)) || !(h.z > GLINT_R(0.0))) return sample_none();
  BrdfSample b;
  b.wi = sample_reflect(sp.wo, h);
  b.pdf = q * smooth_sample_pdf(m, sp.wo, b.wi) +
          (GLINT_R(1.0) - q) * kemppinen_glint_pdf(m, p, fp, sp.wo, b.wi);
  real3 one = make_real3(GLINT_R(1.0), GLINT_R(1.0), GLINT_R(1.0));
  b.weight = sample_weight(kemppinen_reflect(m, p, fp, b.wi, sp.wo, one), b.pdf, b.wi);
  return sample_in_query_space(spec, sp, b);
}

#endif /* GLINT_KEMPPINEN_SAMPLE_H */
