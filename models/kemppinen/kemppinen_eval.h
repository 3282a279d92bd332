/* The Kemppinen et al. 2025 glint model ("K25") for one query: the smooth
 * microfacet BRDF with D replaced by the glinty D_star = D S
 * (models/kemppinen/kemppinen_ndf.h, Eq. 11), i.e. Eq. 1 with the base
 * material's Smith G2 and Fresnel:
 *   f cos_i = F G2 D S / (4 cos_o) = smooth_reflect_cos(wi, wo) * S(x, h).
 *  - BRDF probes (wi) and directional / point lights: S at h = (wi + wo) / |.|.
 *    A light's cone (directional cone_half_angle_deg, point radius) is NOT
 *    used: the light is a delta direction and the facets' own lobes
 *    (microroughness) give the glints their angular size, as in the paper.
 *  - Polygon lights, APPROXIMATION (beyond the paper, which has point lights
 *    and environment maps only): the smooth area integral of the request's
 *    area method times S at the half-vector of the polygon's centroid
 *    direction. The expectation over uv is exact away from the disk edge (E[S]
 *    = 1); the glint pattern of a large light is that of its centre (one glint
 *    value per light instead of each facet's lobe integrated over the light).
 * The facets are the same for every light (hashes of seed, level and cell
 * only). */
#ifndef GLINT_KEMPPINEN_EVAL_H
#define GLINT_KEMPPINEN_EVAL_H

#include "kernels/area/area_lights.h"
#include "kernels/kernel_args.h"
#include "kernels/punctual_lights.h"
#include "kernels/query.h"
#include "kernels/smooth_brdf.h"
#include "models/kemppinen/kemppinen_ndf.h"

/* f(wi, wo) cos_i with D_star, times `radiance` (RGB). */
GLINT_FN real3 kemppinen_reflect(SmoothMaterial m, KemppinenParams p, KemppinenFootprint fp,
                                 real3 wi, real3 wo, real3 radiance) {
  real3 zero = make_real3(R(0.0), R(0.0), R(0.0));
  real3 ls = r3_mul(smooth_reflect_cos(m, wi, wo), radiance);
  if (!(ls.x + ls.y + ls.z > R(0.0))) return zero;
  real3 h = r3_normalize(r3_add(wi, wo));
  real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
  return r3_scale(ls, kemppinen_glint_factor(p, fp, m.ndf, h, m.alpha_x, m.alpha_y, D));
}

/* Reflected radiance towards wo (RGB) of the Kemppinen model for query i. */
GLINT_FN real3 kemppinen_query(EvalSpec spec, KernelInputs in, uint i) {
  real3 radiance = make_real3(R(0.0), R(0.0), R(0.0));
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  KemppinenParams p = kemppinen_params_unpack(in.params);
  QueryInputs q = query_load(spec, in, i);
  ShadingPoint sp = shading_point(spec, q);
  real3 wo = sp.wo;
  if (!(wo.z > R(0.0))) return radiance;
  real footprint[4];
  for (int k = 0; k < 4; ++k) footprint[k] = (real)in.footprint[4 * i + k];
  KemppinenFootprint fp = kemppinen_footprint(p, (real)in.uv[2 * i], (real)in.uv[2 * i + 1],
                                              footprint, in.seed_lo, in.seed_hi);
  real3 one = make_real3(R(1.0), R(1.0), R(1.0));

  if (spec.probe) {
    real3 wi = shading_to_local(spec, sp, r3_normalize(q.wi));
    return kemppinen_reflect(m, p, fp, wi, wo, one);
  }

  uint n_lights = punctual_light_count(spec, in);
  for (uint l = 0; l < n_lights; ++l) {
    PunctualLight light = punctual_light(spec, in, sp, l);
    radiance = r3_add(radiance, kemppinen_reflect(m, p, fp, light.wi, wo, light.irradiance));
  }

  real alpha = sqrt(m.alpha_x * m.alpha_y);
  uint area_key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                                 spec.has_frame ? in.position + 3 * i : 0);
  for (uint l = 0; l < in.n_polygon; ++l) {
    const GLINT_GLOBAL float *rec = in.polygons + GLINT_POLYGON_FLOATS * l;
    real3 v[GLINT_POLYGON_MAX_VERTICES];
    int n = area_polygon_load(rec, spec.has_frame, sp.frame, sp.p, v);
    if (area_polygon_weight(v, n, rec[1] != 0.0f) == R(0.0)) continue;
    real3 L = make_real3((real)rec[2], (real)rec[3], (real)rec[4]);
    real el[GLINT_LTC_ENTRY];
    real ff = area_ltc_form_factor(in.ltc_table, alpha, wo, v, n, el);
    real3 unit = in.area_method == GLINT_AREA_LTC
                     ? r3_scale(area_ltc_albedo(m, el), ff)
                     : area_polygon_integral(m, in.ltc_table, in.area_method, in.area_samples, wo,
                                             v, n, rng_absorb(area_key, l));
    real3 ls = r3_mul(unit, L);
    if (!(ls.x + ls.y + ls.z > R(0.0))) continue;
    real3 c = make_real3(R(0.0), R(0.0), R(0.0));
    for (int k = 0; k < n; ++k) c = r3_add(c, area_safe_normalize(v[k], v[k]));
    real3 up = make_real3(R(0.0), R(0.0), R(1.0));
    real3 wc = area_safe_normalize(c, up);
    real3 h = area_safe_normalize(r3_add(wc, wo), up);
    real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
    radiance = r3_add(
        radiance, r3_scale(ls, kemppinen_glint_factor(p, fp, m.ndf, h, m.alpha_x, m.alpha_y, D)));
  }
  return radiance;
}

#endif /* GLINT_KEMPPINEN_EVAL_H */
