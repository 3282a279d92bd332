/* The Kemppinen et al. 2025 glint model ("K25") per query: the smooth
 * microfacet BRDF with D replaced by the glinty D_star = D S
 * (models/kemppinen/kemppinen_ndf.h, Eq. 11), i.e. Eq. 1 with the base
 * material's Smith G2 and Fresnel:
 *   f cos_i = F G2 D S / (4 cos_o) = smooth_reflect_cos(wi, wo) * S(x, h).
 *  - BRDF probes (wi) and directional / point lights: S at h = (wi + wo) / |.|.
 *    A light's cone (directional cone_half_angle_deg, point radius) is NOT
 *    used: the light is a delta direction and the facets' own lobes
 *    (microroughness) give the glints their angular size, as in the paper.
 *  - Polygon lights: models/kemppinen/kemppinen_polygons.h (a second pass).
 * The facets are the same for every light (hashes of seed, level and cell
 * only). Lane-agnostic like kemppinen_ndf.h: the 16-lane entry
 * models/kemppinen/kemppinen.cl runs kemppinen_shade on blocks of queries. */
#ifndef GLINT_KEMPPINEN_EVAL_H
#define GLINT_KEMPPINEN_EVAL_H

#include "kernels/compat.h"
#include "kernels/kernel_args.h"
#include "kernels/punctual_lights.h"
#include "kernels/query.h"
#include "kernels/smooth_brdf.h"
#include "models/kemppinen/kemppinen_ndf.h"

/* f(wi, wo) cos_i with D_star, times `radiance` (RGB), for a query's MIP
 * levels prepared once for all of its lights (kemppinen_query_levels). */
GLINT_FN real3 kemppinen_reflect_at(SmoothMaterial m, const GLINT_PRIVATE KemppinenParams *p,
                                    const GLINT_PRIVATE KemppinenQueryLevels *levels, real3 wi,
                                    real3 wo, real3 radiance) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  /* The smooth term's unit h and D(h) serve the glint factor too (they were computed a
   * second time per light; the same operations, so the same bits in every live lane). */
  SmoothReflect sr = smooth_reflect_cos_parts(m, wi, wo);
  real3 fc = sr.fc;
  real3 ls = r3_mul(fc, radiance);
  glint_mask live = ls.x + ls.y + ls.z > GLINT_R(0.0);
  if (!glint_any(live)) return zero; /* host: the early return; device: whole blocks */
  /* Dead lanes (a direction below the horizon, wi = -wo) compute on sr's finite h and its D,
   * which may be +Inf (kernels/smooth_brdf.h SmoothReflect); per lane only, and the select by
   * `live` below drops them. */
  real3 s = kemppinen_glint_factor_at(p, levels, m.ndf, sr.h, m.alpha_x, m.alpha_y, sr.D);
  /* (f cos D_star / D) radiance: the radiance last, so that a light whose smooth term overflows
   * to +Inf (fp32: 3e38 W/m^2 on a sharp lobe) meets the glint factor's exact zeros as 0, not
   * as Inf * 0 = NaN (found by the stability sweep); an Inf that remains saturates at store. */
  return r3_select(zero, r3_mul(r3_mul(fc, s), radiance), live);
}

/* kemppinen_reflect_at for two lights (wi_a, radiance_a) and (wi_b, radiance_b) of the query,
 * the two glint factors in one pass (kemppinen_glint_factor_at2): the same bits as two calls of
 * kemppinen_reflect_at, returned separately so the caller sums them in the same order. A light
 * that no lane sees (a block behind it) takes kemppinen_reflect_at's early return. */
GLINT_FN void kemppinen_reflect_at2(SmoothMaterial m, const GLINT_PRIVATE KemppinenParams *p,
                                    const GLINT_PRIVATE KemppinenQueryLevels *levels, real3 wi_a,
                                    real3 wi_b, real3 wo, real3 radiance_a, real3 radiance_b,
                                    GLINT_PRIVATE real3 *out_a, GLINT_PRIVATE real3 *out_b) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  SmoothReflect ra = smooth_reflect_cos_parts(m, wi_a, wo);
  SmoothReflect rb = smooth_reflect_cos_parts(m, wi_b, wo);
  real3 lsa = r3_mul(ra.fc, radiance_a), lsb = r3_mul(rb.fc, radiance_b);
  glint_mask live_a = lsa.x + lsa.y + lsa.z > GLINT_R(0.0);
  glint_mask live_b = lsb.x + lsb.y + lsb.z > GLINT_R(0.0);
  int any_a = glint_any(live_a), any_b = glint_any(live_b);
  if (!(any_a && any_b)) {
    *out_a = any_a ? kemppinen_reflect_at(m, p, levels, wi_a, wo, radiance_a) : zero;
    *out_b = any_b ? kemppinen_reflect_at(m, p, levels, wi_b, wo, radiance_b) : zero;
    return;
  }
  real3 sa, sb;
  kemppinen_glint_factor_at2(p, levels, m.ndf, ra.h, rb.h, m.alpha_x, m.alpha_y, ra.D, rb.D, &sa,
                             &sb);
  *out_a = r3_select(zero, r3_mul(r3_mul(ra.fc, sa), radiance_a), live_a);
  *out_b = r3_select(zero, r3_mul(r3_mul(rb.fc, sb), radiance_b), live_b);
}

/* The same from the footprint (one light; the sampler's weight). */
GLINT_FN real3 kemppinen_reflect(SmoothMaterial m, KemppinenParams p, KemppinenFootprint fp,
                                 real3 wi, real3 wo, real3 radiance) {
  KemppinenQueryLevels levels = kemppinen_query_levels(p, fp);
  return kemppinen_reflect_at(m, &p, &levels, wi, wo, radiance);
}

/* Reflected radiance towards wo (RGB) from the probe direction or the
 * directional and point lights, for one query or (16-lane entry) a block of
 * queries: q, uv and footprint hold the block's lanes. What does not depend
 * on the light (the footprint, both levels' spatial halves and cell hashes)
 * is computed once per query. */
GLINT_FN real3 kemppinen_shade(EvalSpec spec, KernelInputs in, QueryInputs q, real u, real v,
                               const GLINT_PRIVATE real *footprint) {
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  KemppinenParams p = kemppinen_params_unpack(in.params);
#if GLINT_FAST_ROOTS_ACTIVE
  /* wo (and a probe's wi) normalised by the reciprocal square root estimate (kernels/compat.h:
   * <= 3 2^-24 relative, no division; validation admits lengths within 1e-3 of 1), as the smooth
   * model's probe entry does; elsewhere the exact division of r3_normalize. */
  ShadingPoint sp = shading_point_unit(spec, q, r3_scale(q.wo, glint_rsqrt_nn(r3_dot(q.wo, q.wo))));
#else
  ShadingPoint sp = shading_point(spec, q);
#endif
  KemppinenFootprint fp = kemppinen_footprint(p, u, v, footprint, in.seed_lo, in.seed_hi);
  KemppinenQueryLevels levels;
  kemppinen_query_levels_into(p, fp, &levels); /* in place: no copy of ~2 KB per block */
  if (spec.probe) {
#if GLINT_FAST_ROOTS_ACTIVE
    real3 wi = shading_to_local(spec, sp, r3_scale(q.wi, glint_rsqrt_nn(r3_dot(q.wi, q.wi))));
#else
    real3 wi = shading_to_local(spec, sp, r3_normalize(q.wi));
#endif
    return kemppinen_reflect_at(m, &p, &levels, wi, sp.wo,
                                make_real3(GLINT_R(1.0), GLINT_R(1.0), GLINT_R(1.0)));
  }
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  uint n_lights = punctual_light_count(spec, in);
  uint l = 0;
  /* Lights in pairs (kemppinen_reflect_at2: the same bits, summed in the same order). */
  for (; l + 2u <= n_lights; l += 2u) {
    PunctualLight a = punctual_light(spec, in, sp, l);
    PunctualLight b = punctual_light(spec, in, sp, l + 1u);
    real3 ra, rb;
    kemppinen_reflect_at2(m, &p, &levels, a.wi, b.wi, sp.wo, a.irradiance, b.irradiance, &ra, &rb);
    radiance = r3_add(r3_add(radiance, ra), rb);
  }
  for (; l < n_lights; ++l) {
    PunctualLight light = punctual_light(spec, in, sp, l);
    radiance =
        r3_add(radiance, kemppinen_reflect_at(m, &p, &levels, light.wi, sp.wo, light.irradiance));
  }
  return radiance;
}

/* The footprint of query i (one query per work-item). */
GLINT_FN void kemppinen_load_footprint(KernelInputs in, uint i, GLINT_PRIVATE real *footprint) {
  for (int k = 0; k < 4; ++k) footprint[k] = (real)in.footprint[4 * i + k];
}

/* Probes, directional and point lights for query i (the host path; the device
 * runs kemppinen_shade on blocks of 16, models/kemppinen/kemppinen.cl). */
GLINT_FN real3 kemppinen_query(EvalSpec spec, KernelInputs in, uint i) {
  real footprint[4];
  kemppinen_load_footprint(in, i, footprint);
  return kemppinen_shade(spec, in, query_load(spec, in, i), (real)in.uv[2 * i],
                         (real)in.uv[2 * i + 1], footprint);
}

#endif /* GLINT_KEMPPINEN_EVAL_H */
