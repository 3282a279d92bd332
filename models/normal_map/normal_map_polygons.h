/* Polygon lights for the NORMAL_MAP model (beyond Yan et al. 2014, who shade
 * point lights only). The quantity is
 *
 *   L_o = L int_P f(wi, wo) cos_i dwi = L int_{P_s} W(s) D(s) ds dt,
 *   W = F G (wo.h) / (wo.z h.z)
 *
 * (dwi = 4 (wo.h) dw_h, ds dt = h.z dw_h), the P-NDF integrated over the image
 * P_s of the light in slope space. D is a sum of sharp per-triangle Gaussians
 * (width sigma_r, often 0.01) and P_s may be small or large against it, so a
 * fixed quadrature either misses glints or costs (extent / sigma_r)^2 P-NDF
 * evaluations. We ESTIMATE the integral without bias by multiple importance
 * sampling (Veach 1997 Ch. 9, power heuristic, beta = 2) of two techniques,
 * area_samples (0 = 64) samples each, seeded (DESIGN.md "Determinism": keys
 * from the seed, the query's wo, position, uv and footprint, and the light's
 * index, never the query's index):
 *
 *  (L) directions uniform in the light's solid angle (kernels/area/
 *      area_monte_carlo.h: clipped, fan-triangulated, Arvo 1995), p_L = 1/Omega,
 *      each costing one P-NDF evaluation (good for small lights);
 *  (B) the P-NDF sampler of normal_map_sample.h, p_B = D h.z / (4 wo.h),
 *      reflected directions that hit the light (cheap; good for large lights
 *      and sharp glints). A hit costs one P-NDF evaluation, for its MIS weight.
 *
 * The estimate's error is the Monte Carlo standard error (it converges to the
 * integral of the evaluated P-NDF: p_B uses D pruned at cutoff_sigma, so it
 * differs from the density sampled by at most the pruning bound). Measured
 * against independent Monte Carlo of the probe path in
 * models/normal_map/tests/normal_map_polygon_test.cpp. One query per
 * work-item (GLINT_LANES == 1). */
#ifndef GLINT_NORMAL_MAP_POLYGONS_H
#define GLINT_NORMAL_MAP_POLYGONS_H

#include "kernels/area/area_lights.h"
#include "kernels/area/area_monte_carlo.h"
#include "models/normal_map/normal_map_sample.h"

/* f cos_i = F D G / (4 wo.z) (Eq. 1, normal_map_reflect_cos) from a known D at h. */
GLINT_FN real3 nm_reflect_cos_at(SmoothMaterial m, real3 wo, real3 wi, real3 h, real D) {
  real oh = r3_dot(wo, h);
  real g = fmin(GLINT_R(1.0), GLINT_R(2.0) * h.z * fmin(wo.z, wi.z) / oh);
  return r3_scale(fresnel_eval(m.fresnel, oh), D * g / (GLINT_R(4.0) * wo.z));
}

/* int_P f cos_i dwi per unit radiance for one clipped light P (RGB). */
GLINT_FN real3 nm_polygon_integral(const GLINT_GLOBAL float *table, NmQuery fq, const int *kk,
                                   NormalMapParams p, SmoothMaterial m, real3 wo,
                                   const GLINT_PRIVATE McPolygon *P, int samples, uint key) {
  real3 acc = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real nL = (real)samples, nB = (real)samples;
  real pL = GLINT_R(1.0) / P->omega;
  NmStats stats;
  stats.triangles = 0u;
  stats.nodes = 0u;
  stats.max_stack = 0u;
  stats.overflow = 0u;
  uint keyL = rng_absorb(key, 0x4c696768u /* "Ligh" */);
  uint keyB = rng_absorb(key, 0x4e6d6170u /* "Nmap" */);
  for (int i = 0; i < samples; ++i) {
    /* (L) */
    real3 wi = r3_normalize(mc_sample_light(P, keyL, (uint)i));
    real3 hv = r3_add(wi, wo);
    real len = r3_length(hv);
    if (wi.z > GLINT_R(0.0) && len > GLINT_R(0.0)) {
      real3 h = r3_div(hv, len);
      real oh = r3_dot(wo, h);
      if (oh > GLINT_R(0.0) && h.z > GLINT_R(0.0)) {
        real D = nm_pndf_footprint(table, fq, kk, h.x, h.y, p.sigma_r, p.cutoff, &stats);
        real pB = D * h.z / (GLINT_R(4.0) * oh);
        real a = nL * pL, b = nB * pB;
        real w = a * a / (a * a + b * b);
        acc = r3_add(acc, r3_scale(nm_reflect_cos_at(m, wo, wi, h, D), w / a));
      }
    }
    /* (B) */
    real s, t;
    if (!nm_sample_slope(table, fq, p.sigma_r, rng_u01(rng_hash3(keyB, (uint)i, 0u)),
                         rng_u01(rng_hash3(keyB, (uint)i, 1u)),
                         rng_u01(rng_hash3(keyB, (uint)i, 2u)),
                         rng_u01(rng_hash3(keyB, (uint)i, 3u)), &s, &t))
      continue;
    real3 h = nm_slope_normal(s, t);
    real oh = r3_dot(wo, h);
    if (!(oh > GLINT_R(0.0)) || !(h.z > GLINT_R(0.0))) continue;
    real3 wb = sample_reflect(wo, h);
    if (!(wb.z > GLINT_R(0.0)) || !mc_inside(P, wb)) continue;
    real D = nm_pndf_footprint(table, fq, kk, s, t, p.sigma_r, p.cutoff, &stats);
    real pB = D * h.z / (GLINT_R(4.0) * oh);
    if (!(pB > GLINT_R(0.0))) continue; /* pruned: technique L covers it (w_L = 1) */
    real a = nL * pL, b = nB * pB;
    real w = b * b / (a * a + b * b);
    /* f cos / (nB pB) = weight / nB */
    acc = r3_add(acc, r3_scale(nm_sample_weight(m, wo, wb, h), w / nB));
  }
  return acc;
}

/* Polygon lights for query i. */
GLINT_FN real3 normal_map_polygons_query(EvalSpec spec, KernelInputs in, uint i) {
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  NormalMapParams p = normal_map_params_unpack(in.params);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  real3 wo = sp.wo;
  if (!(wo.z > GLINT_R(0.0))) return radiance;
  real fp[4];
  for (int c = 0; c < 4; ++c) fp[c] = (real)in.footprint[4 * i + c];
  int kk[4];
  NmQuery fq =
      nm_footprint(in.model_table, (real)in.uv[2 * i], (real)in.uv[2 * i + 1], fp, p.cutoff, kk);
  uint key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                            spec.has_frame ? in.position + 3 * i : 0);
  for (int c = 0; c < 2; ++c) key = rng_absorb(key, rng_float_key(in.uv[2 * i + c]));
  for (int c = 0; c < 4; ++c) key = rng_absorb(key, rng_float_key(in.footprint[4 * i + c]));
  int samples = in.area_samples > 0 ? in.area_samples : 64;
  for (uint l = 0; l < in.n_polygon; ++l) {
    const GLINT_GLOBAL float *rec = in.polygons + GLINT_POLYGON_FLOATS * l;
    real3 v[GLINT_POLYGON_MAX_VERTICES];
    int n = area_polygon_load(rec, spec.has_frame, sp.frame, sp.p, v);
    if (area_polygon_weight(v, n, rec[1] != 0.0f) == GLINT_R(0.0)) continue;
    McPolygon P;
    if (!mc_polygon_setup(v, n, &P)) continue;
    real3 L = make_real3((real)rec[2], (real)rec[3], (real)rec[4]);
    real3 g =
        nm_polygon_integral(in.model_table, fq, kk, p, m, wo, &P, samples, rng_absorb(key, l));
    radiance = r3_add(radiance, r3_mul(g, L));
  }
  return radiance;
}

#endif /* GLINT_NORMAL_MAP_POLYGONS_H */
