/* The NORMAL_MAP model (Yan et al. 2014, YHJ14) for one query: the
 * microfacet BRDF of Eq. 1 with the footprint's P-NDF (normal_map_pndf.h),
 *
 *   f(i, o) = F(i.h) G(i, o, h) D(h) / (4 (i.n) (o.n))                 (Eq. 1)
 *
 * D over the projected disk (s, t) = (h.x, h.y) is already the density in
 * solid-angle measure that Eq. 1 needs: ds dt = (h.n) dw_h, so
 * int D(h) (h.n) dw_h = int D ds dt (YHJ14 Sec. 3 "NDFs": "no cosines need to
 * be worried about"). G is only there to keep grazing angles finite (Sec. 4):
 * we use the Cook-Torrance V-cavity term with the macro normal,
 * G = min(1, 2 (n.h)(n.o) / (o.h), 2 (n.h)(n.i) / (o.h)), which bounds
 * f cos_i by F D (n.h) / (2 (o.h)) as cos_o -> 0.
 *
 * Lights: BRDF probes, directional and point lights as delta lights (the
 * paper's setting: point lights; cone and sphere sizes are ignored). Polygon
 * lights are refused by the descriptor (normal_map_model.cpp).
 *
 * Written for GLINT_LANES == 1 (per-query traversal). */
#ifndef GLINT_NORMAL_MAP_EVAL_H
#define GLINT_NORMAL_MAP_EVAL_H

#include "kernels/compat.h"
#include "kernels/fresnel.h"
#include "kernels/kernel_args.h"
#include "kernels/punctual_lights.h"
#include "kernels/query.h"
#include "kernels/smooth_brdf.h"
#include "models/normal_map/normal_map_params.h"
#include "models/normal_map/normal_map_pndf.h"

typedef struct {
  real sigma_r, cutoff;
} NormalMapParams;

GLINT_FN NormalMapParams normal_map_params_unpack(const GLINT_GLOBAL float *p) {
  NormalMapParams r;
  r.sigma_r = (real)p[0];
  r.cutoff = (real)p[1];
  return r;
}

/* f(i, o) cos_i (Eq. 1 times cos_i), 0 below either horizon. */
GLINT_FN real3 normal_map_reflect_cos(const GLINT_GLOBAL float *table, NormalMapParams p,
                                      SmoothMaterial m, real u, real v, const real *fp, real3 wi,
                                      real3 wo) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 hs = r3_add(wi, wo);
  real h_len = r3_length(hs);
  if (!(wi.z > GLINT_R(0.0)) || !(wo.z > GLINT_R(0.0)) || !(h_len > GLINT_R(0.0))) return zero;
  real3 h = r3_div(hs, h_len);
  real oh = r3_dot(wo, h);
  /* wi ~ -wo (grazing back-scatter): rounding can leave h below the surface or facing away
   * from wo; no facet reflects there. */
  if (!(oh > GLINT_R(0.0)) || !(h.z > GLINT_R(0.0))) return zero;
  NmStats stats;
  stats.triangles = 0u;
  stats.nodes = 0u;
  stats.max_stack = 0u;
  stats.overflow = 0u;
  real D = nm_pndf(table, u, v, fp, h.x, h.y, p.sigma_r, p.cutoff, &stats);
  real g = fmin(GLINT_R(1.0), GLINT_R(2.0) * h.z * fmin(wo.z, wi.z) / oh);
  real3 F = fresnel_eval(m.fresnel, oh);
  return r3_scale(F, D * g / (GLINT_R(4.0) * wo.z));
}

GLINT_FN real3 normal_map_query(EvalSpec spec, KernelInputs in, uint i) {
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  NormalMapParams p = normal_map_params_unpack(in.params);
  QueryInputs q = query_load(spec, in, i);
  ShadingPoint sp = shading_point(spec, q);
  real fp[4];
  for (int k = 0; k < 4; ++k) fp[k] = (real)in.footprint[4 * i + k];
  real u = (real)in.uv[2 * i], v = (real)in.uv[2 * i + 1];
  if (spec.probe) {
    real3 wi = shading_to_local(spec, sp, r3_normalize(q.wi));
    return normal_map_reflect_cos(in.model_table, p, m, u, v, fp, wi, sp.wo);
  }
  uint n_lights = punctual_light_count(spec, in);
  for (uint l = 0; l < n_lights; ++l) {
    PunctualLight light = punctual_light(spec, in, sp, l);
    real3 fc = normal_map_reflect_cos(in.model_table, p, m, u, v, fp, light.wi, sp.wo);
    radiance = r3_add(radiance, r3_mul(fc, light.irradiance));
  }
  return radiance;
}

#endif /* GLINT_NORMAL_MAP_EVAL_H */
