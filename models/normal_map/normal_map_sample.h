/* Sampling the NORMAL_MAP model's P-NDF (Yan et al. 2014, YHJ14 Sec. 6,
 * "the P-NDF can be importance sampled"): a normal drawn from D(s) is
 *
 *   1. a footprint point x ~ G_p (the same Gaussian, clamp included, as the
 *      P-NDF's: nm_footprint in normal_map_pndf.h; uniform over a period in
 *      its large-footprint limit),
 *   2. the triangulation's interpolated normal n(x) there (Sec. 5: (s, t)
 *      linear on each of a cell's two triangles, the same split as nm_cell),
 *   3. perturbed by G_r: s = n(x) + sigma_r z, z ~ N(0, I) (Eq. 6-7),
 *
 * so s has the density D(s) = int G_p(x) G_r(n(x) - s) dx of Eq. 6 exactly.
 * An s outside the unit disk (G_r's mass beyond the rim) has no normal: the
 * sample is null (wi = 0, pdf 0, weight 0), as kernels/sample.h allows, so the
 * pdf integrates to 1 minus that mass.
 *
 * With h = (s, t, sqrt(1 - s^2 - t^2)) and wi = reflect(wo, h): ds dt = h.z dw_h
 * and dw_i = 4 (wo.h) dw_h (Walter et al. 2007 Eq. 14), so
 *
 *   pdf(wi) = D(s) h.z / (4 wo.h),
 *   weight  = f cos_i / pdf = F(wo.h) G (wo.h) / (wo.z h.z)   (Eq. 1),
 *
 * and pdf is the evaluated P-NDF (nm_pndf_footprint), i.e. pruned at
 * cutoff_sigma: it differs from the density actually sampled by at most the
 * pruning bound of README "Tests" ((4 Phi(-c) + e^{-c^2/2}) / (2 pi sigma_r^2)
 * in D). The weight does not depend on D. */
#ifndef GLINT_NORMAL_MAP_SAMPLE_H
#define GLINT_NORMAL_MAP_SAMPLE_H

#include "kernels/sample.h"
#include "models/normal_map/normal_map_eval.h"

/* Two standard normal numbers from two uniforms in [0, 1) (Box-Muller). */
GLINT_FN void nm_gauss2(real u1, real u2, GLINT_PRIVATE real *z1, GLINT_PRIVATE real *z2) {
  real r = sqrt(GLINT_R(-2.0) * log(GLINT_R(1.0) - u1)); /* 1 - u1 in (0, 1] */
  real phi = GLINT_R(2.0) * GLINT_PI * u2;
  *z1 = r * cos(phi);
  *z2 = r * sin(phi);
}

/* The interpolated (s, t) at vertex coordinates (x, y) (periodic): cell
 * (i, j) = floor, lower triangle (v00, v10, v01) where fx + fy <= 1, upper
 * (v11, v01, v10) otherwise (nm_cell's split). */
GLINT_FN void nm_normal_at(const GLINT_GLOBAL float *table, uint W, uint H, real x, real y,
                           GLINT_PRIVATE real *s, GLINT_PRIVATE real *t) {
  real Wr = (real)W, Hr = (real)H;
  x -= floor(x / Wr) * Wr;
  y -= floor(y / Hr) * Hr;
  real fi = floor(x), fj = floor(y);
  real fx = x - fi, fy = y - fj;
  uint i = (uint)fi, j = (uint)fj;
  i = i >= W ? W - 1u : i; /* x rounded up to W */
  j = j >= H ? H - 1u : j;
  real s00, t00, s10, t10, s01, t01, s11, t11;
  nm_vertex(table, W, H, i, j, &s00, &t00);
  nm_vertex(table, W, H, i + 1u, j, &s10, &t10);
  nm_vertex(table, W, H, i, j + 1u, &s01, &t01);
  nm_vertex(table, W, H, i + 1u, j + 1u, &s11, &t11);
  if (fx + fy <= GLINT_R(1.0)) {
    *s = s00 + fx * (s10 - s00) + fy * (s01 - s00);
    *t = t00 + fx * (t10 - t00) + fy * (t01 - t00);
  } else {
    real a = GLINT_R(1.0) - fx, b = GLINT_R(1.0) - fy;
    *s = s11 + a * (s01 - s11) + b * (s10 - s11);
    *t = t11 + a * (t01 - t11) + b * (t10 - t11);
  }
}

/* Steps 1-3 above from four uniforms: (s, t) ~ D. Returns 0 when s falls
 * outside the unit disk (no normal). */
GLINT_FN int nm_sample_slope(const GLINT_GLOBAL float *table, NmQuery fq, real sigma_r, real u1,
                             real u2, real u3, real u4, GLINT_PRIVATE real *s,
                             GLINT_PRIVATE real *t) {
  real z1, z2;
  nm_gauss2(u1, u2, &z1, &z2);
  /* x = c + L z with L L^T = Sigma_p: L = [a 0; b c], c from det (no cancellation). */
  real a = sqrt(fq.pxx);
  real x = fq.cx + a * z1;
  real y = fq.cy + (fq.pxy / a) * z1 + sqrt(fq.pdet / fq.pxx) * z2;
  /* The large-footprint limit: G_p is uniform over a period (to 2.5e-5). */
  if (fq.uniform) {
    x = u1 * (real)fq.W;
    y = u2 * (real)fq.H;
  }
  real ns, nt;
  nm_normal_at(table, fq.W, fq.H, x, y, &ns, &nt);
  nm_gauss2(u3, u4, &z1, &z2);
  *s = ns + sigma_r * z1;
  *t = nt + sigma_r * z2;
  return *s * *s + *t * *t < GLINT_R(1.0);
}

/* The half-vector of slope (s, t) inside the unit disk. */
GLINT_FN real3 nm_slope_normal(real s, real t) {
  return make_real3(s, t, sqrt(fmax(GLINT_R(1.0) - s * s - t * t, GLINT_R(0.0))));
}

/* f cos_i / pdf for a reflection about h (weight above): F G (wo.h) / (wo.z h.z). */
GLINT_FN real3 nm_sample_weight(SmoothMaterial m, real3 wo, real3 wi, real3 h) {
  real oh = r3_dot(wo, h);
  real g = fmin(GLINT_R(1.0), GLINT_R(2.0) * h.z * fmin(wo.z, wi.z) / oh);
  return r3_scale(fresnel_eval(m.fresnel, oh), g * oh / (wo.z * h.z));
}

/* Sample k of query i (the Sample RPC). Random dimensions: 0-1 the footprint
 * point, 2-3 the G_r perturbation. */
GLINT_FN BrdfSample normal_map_sample(EvalSpec spec, KernelInputs in, uint i, uint k) {
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  NormalMapParams p = normal_map_params_unpack(in.params);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  real3 wo = sp.wo;
  if (!(wo.z > GLINT_R(0.0))) return sample_none();
  real fp[4];
  for (int c = 0; c < 4; ++c) fp[c] = (real)in.footprint[4 * i + c];
  int kk[4];
  NmQuery fq =
      nm_footprint(in.model_table, (real)in.uv[2 * i], (real)in.uv[2 * i + 1], fp, p.cutoff, kk);
  uint key = sample_key(spec, in, i, k, 1);
  real s, t;
  if (!nm_sample_slope(in.model_table, fq, p.sigma_r, sample_u(key, 0u), sample_u(key, 1u),
                       sample_u(key, 2u), sample_u(key, 3u), &s, &t))
    return sample_none();
  real3 h = nm_slope_normal(s, t);
  real oh = r3_dot(wo, h);
  if (!(oh > GLINT_R(0.0)) || !(h.z > GLINT_R(0.0))) return sample_none();
  NmStats stats;
  stats.triangles = 0u;
  stats.nodes = 0u;
  stats.max_stack = 0u;
  stats.overflow = 0u;
  real D = nm_pndf_footprint(in.model_table, fq, kk, s, t, p.sigma_r, p.cutoff, &stats);
  BrdfSample b;
  b.wi = sample_reflect(wo, h);
  b.pdf = D * h.z / (GLINT_R(4.0) * oh);
  b.weight = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  if (b.wi.z > GLINT_R(0.0) && b.pdf > GLINT_R(0.0)) b.weight = nm_sample_weight(m, wo, b.wi, h);
  return sample_in_query_space(spec, sp, b);
}

#endif /* GLINT_NORMAL_MAP_SAMPLE_H */
