/* Importance sampling of the Chermain et al. 2020 glint BRDF (the Sample
 * RPC, kernels/sample.h): the smooth Beckmann lobe the P-NDF converges to,
 * h ~ D(h) cos(theta_h) (kernels/sample.h sample_beckmann_normal), reflected
 * about h; the pdf is that smooth one and the weight carries the glint BRDF,
 * f_P(wi, wo) cos_i / pdf (chermain_reflect_cos). Unbiased: the pdf is > 0
 * wherever f_P is (h above the surface, wo.h > 0: the V-cavity G1(wo, h)
 * vanishes otherwise). Not the marginal-CDF sampling of Chermain et al. 2021,
 * so the weights of a sparse glint pattern have a high variance. */
#ifndef GLINT_CHERMAIN_SAMPLE_H
#define GLINT_CHERMAIN_SAMPLE_H

#include "kernels/sample.h"
#include "models/chermain/chermain_eval.h"

/* Sample k of query i. */
GLINT_FN BrdfSample chermain_sample(EvalSpec spec, KernelInputs in, uint i, uint k) {
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  ChermainParams p = chermain_params_unpack(in.params);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  if (!(sp.wo.z > GLINT_R(0.0))) return sample_none();
  real fp[4];
  for (int c = 0; c < 4; ++c) fp[c] = (real)in.footprint[4 * i + c];
  ChermainFootprint f = chermain_footprint(p, (real)in.uv[2 * i], (real)in.uv[2 * i + 1], fp);
  uint key = sample_key(spec, in, i, k, 1);
  real3 h = smooth_sample_half_vector(m, sp.wo, sample_u(key, 0u), sample_u(key, 1u));
  if (!(r3_dot(sp.wo, h) > GLINT_R(0.0)) || !(h.z > GLINT_R(0.0))) return sample_none();
  BrdfSample b;
  b.wi = sample_reflect(sp.wo, h);
  b.pdf = smooth_sample_pdf(m, sp.wo, b.wi);
  /* The same seed key as the evaluation (chermain_query), so the weight sees
   * the glints Evaluate shows. */
  real3 fc =
      chermain_reflect_cos(in.model_table, p, f, m, rng_hash2(in.seed_lo, in.seed_hi), b.wi, sp.wo);
  b.weight = sample_weight(fc, b.pdf, b.wi);
  return sample_in_query_space(spec, sp, b);
}

#endif /* GLINT_CHERMAIN_SAMPLE_H */
