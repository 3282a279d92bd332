/* The smooth model's sample pass (the Sample RPC, kernels/sample.h): GGX by
 * its visible normals (Heitz 2018), Beckmann by D cos (Walter et al. 2007),
 * reflected about the sampled h; weight = f cos_i / pdf with f the model's
 * own BRDF (kernels/smooth_brdf.h). Entry: models/smooth/smooth_sample.cl. */
#ifndef GLINT_SMOOTH_SAMPLE_H
#define GLINT_SMOOTH_SAMPLE_H

#include "kernels/sample.h"

/* Sample k of query i. */
GLINT_FN BrdfSample smooth_sample(EvalSpec spec, KernelInputs in, uint i, uint k) {
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  if (!(sp.wo.z > GLINT_R(0.0))) return sample_none();
  /* The smooth BRDF reads no uv, so uv is not part of sample_key's inputs
   * here; but samples are keyed by every documented query input (README
   * "Determinism"), so two queries differing only in uv (a flat surface under
   * an orthographic view) get independent samples. Queries without uv keep
   * the key they always had. */
  uint key = sample_key(spec, in, i, k, 0);
  if (spec.sample_uv) {
    key = rng_absorb(key, rng_float_key(in.uv[2 * i]));
    key = rng_absorb(key, rng_float_key(in.uv[2 * i + 1]));
  }
  real3 h = smooth_sample_half_vector(m, sp.wo, sample_u(key, 0u), sample_u(key, 1u));
  if (!(r3_dot(sp.wo, h) > GLINT_R(0.0)) || !(h.z > GLINT_R(0.0))) return sample_none();
  BrdfSample b;
  b.wi = sample_reflect(sp.wo, h);
  b.pdf = smooth_sample_pdf(m, sp.wo, b.wi);
  b.weight = sample_weight(smooth_reflect_cos(m, b.wi, sp.wo), b.pdf, b.wi);
  return sample_in_query_space(spec, sp, b);
}

#endif /* GLINT_SMOOTH_SAMPLE_H */
