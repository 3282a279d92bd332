/* Importance sampling of a BRDF lobe (the Sample RPC): what every model's
 * sample pass shares.
 *
 *  - The kernel entry's argument list: the standard one (kernels/kernel_args.h)
 *    plus K = samples_per_query; `out` holds GLINT_SAMPLE_FLOATS per sample,
 *    sample k of query i at index i K + k (work-item i K + k).
 *  - The sample's random numbers: kernels/rng.h keyed by the seed, the query's
 *    own inputs and the sample index, never the query's index in the batch.
 *  - The smooth lobe's strategies, used by SMOOTH and as a component by the
 *    glint models: GGX visible normals (Heitz 2018), Beckmann D cos (Walter et
 *    al. 2007), each with its pdf at any direction (for mixtures).
 *
 * Directions are local (+z = normal) unit vectors; wi = reflect(wo, h). A
 * sample with no direction (a proposal outside its domain, h facing away from
 * wo, wo at or below the horizon) has wi = 0, pdf 0, weight 0: the estimator
 * stays unbiased and the pdf integrates to <= 1.
 *
 * Scalar code: sample passes run one sample per work-item (GLINT_LANES 1). */
#ifndef GLINT_SAMPLE_H
#define GLINT_SAMPLE_H

#include "kernels/compat.h"
#include "kernels/kernel_args.h"
#include "kernels/ndf.h"
#include "kernels/query.h"
#include "kernels/rng.h"
#include "kernels/smooth_brdf.h"

#if defined(__OPENCL_VERSION__) && GLINT_LANES != 1
#error "sample passes are scalar: GLINT_LANES must be 1"
#endif

/* Floats per sample in `out`: wi (3), pdf, weight (RGB). */
#define GLINT_SAMPLE_FLOATS 7

#ifdef __OPENCL_VERSION__
/* The standard arguments plus K; bound by server/device_engine.cpp
 * (DeviceEngine::Sample) as the argument after `out`. */
#define GLINT_SAMPLE_KERNEL_ARGS GLINT_KERNEL_ARGS, uint samples_per_query
#endif

typedef struct {
  real3 wi;     /* local frame (the entry stores it in the query's space) */
  real pdf;     /* solid angle */
  real3 weight; /* f cos_i / pdf */
} BrdfSample;

GLINT_FN BrdfSample sample_none(void) {
  BrdfSample s;
  s.wi = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  s.pdf = GLINT_R(0.0);
  s.weight = s.wi;
  return s;
}

/* ------------------------------------------------------------ random numbers */

/* The key of sample k of query i: the seed, then the query's own inputs (wo,
 * its frame when present, and uv + footprint for models that read them), then
 * k. Two equal queries get equal samples; the query's position in the batch
 * never enters. */
GLINT_FN uint sample_key(EvalSpec spec, KernelInputs in, uint i, uint k, int use_uv) {
  uint h = rng_absorb(rng_absorb(0x53616d70u /* "Samp" */, in.seed_lo), in.seed_hi);
  for (int c = 0; c < 3; ++c) h = rng_absorb(h, rng_float_key(in.wo[3 * i + c]));
  if (spec.has_frame) {
    for (int c = 0; c < 3; ++c) {
      h = rng_absorb(h, rng_float_key(in.position[3 * i + c]));
      h = rng_absorb(h, rng_float_key(in.normal[3 * i + c]));
      h = rng_absorb(h, rng_float_key(in.tangent[3 * i + c]));
    }
  }
  if (use_uv) {
    for (int c = 0; c < 2; ++c) h = rng_absorb(h, rng_float_key(in.uv[2 * i + c]));
    for (int c = 0; c < 4; ++c) h = rng_absorb(h, rng_float_key(in.footprint[4 * i + c]));
  }
  return rng_absorb(h, k);
}

/* Uniform number `dim` of the sample with key `key`, in [0, 1). */
GLINT_FN real sample_u(uint key, uint dim) {
  return rng_u01(rng_hash2(key, dim));
}

/* ------------------------------------------------------------- geometry */

/* Mirror reflection of wo about the unit normal h: 2 (wo.h) h - wo. */
GLINT_FN real3 sample_reflect(real3 wo, real3 h) {
  return r3_sub(r3_scale(h, GLINT_R(2.0) * r3_dot(wo, h)), wo);
}

/* The half-vector of (wi, wo), or (0, 0, 0) when wi = -wo. */
GLINT_FN real3 sample_half_vector(real3 wi, real3 wo) {
  real3 h = r3_add(wi, wo);
  real len = r3_length(h);
  return len > GLINT_R(0.0) ? r3_div(h, len) : make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
}

/* ---------------------------------------------------- the smooth lobe */

/* GGX visible normals: Heitz 2018, "Sampling the GGX Distribution of Visible
 * Normals" (JCGT 7(4)), Listing 1: stretch wo to the hemisphere
 * configuration, sample the projected half-disk, unstretch. The density of h
 * is D_wo(h) = G1(wo) max(0, wo.h) D(h) / cos_o (Heitz 2018 Eq. 3). wo.z > 0. */
GLINT_FN real3 sample_ggx_visible_normal(real3 wo, real ax, real ay, real u1, real u2) {
  real3 vh = r3_normalize(make_real3(ax * wo.x, ay * wo.y, wo.z));
  real lensq = vh.x * vh.x + vh.y * vh.y;
  real3 t1 = lensq > GLINT_R(0.0)
                 ? r3_scale(make_real3(-vh.y, vh.x, GLINT_R(0.0)), GLINT_R(1.0) / sqrt(lensq))
                 : make_real3(GLINT_R(1.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 t2 = r3_cross(vh, t1);
  real r = sqrt(u1);
  real phi = GLINT_R(2.0) * GLINT_PI * u2;
  real p1 = r * cos(phi);
  real p2 = r * sin(phi);
  real s = GLINT_R(0.5) * (GLINT_R(1.0) + vh.z);
  p2 = (GLINT_R(1.0) - s) * sqrt(fmax(GLINT_R(1.0) - p1 * p1, GLINT_R(0.0))) + s * p2;
  real pz = sqrt(fmax(GLINT_R(1.0) - p1 * p1 - p2 * p2, GLINT_R(0.0)));
  real3 nh = r3_add(r3_add(r3_scale(t1, p1), r3_scale(t2, p2)), r3_scale(vh, pz));
  return r3_normalize(make_real3(ax * nh.x, ay * nh.y, fmax(nh.z, GLINT_R(0.0))));
}

/* Beckmann D(h) cos(theta_h): the slope is Gaussian, |t|^2 exponential
 * (Walter et al. 2007 Eq. 28-29 with the anisotropic alphas): t =
 * sqrt(-ln(1 - u1)) (cos 2 pi u2, sin 2 pi u2), slope = (ax tx, ay ty). The
 * density of h is D(h) cos(theta_h). (Not the visible normals: Heitz & d'Eon
 * 2014's Beckmann sampler needs an inverse erf the OpenCL builtins lack.) */
GLINT_FN real3 sample_beckmann_normal(real ax, real ay, real u1, real u2) {
  real r = sqrt(-log1p(-u1));
  real phi = GLINT_R(2.0) * GLINT_PI * u2;
  return r3_normalize(make_real3(ax * r * cos(phi), ay * r * sin(phi), GLINT_R(1.0)));
}

/* The smooth strategy's pdf (solid angle) of wi for the view wo (both local):
 * GGX pdf_wi = D_wo(h) / (4 wo.h) = D(h) / (4 (cos_o + cos_o Lambda(wo)))
 * (Heitz 2018 Eq. 3 with G1 = 1 / (1 + Lambda) and the reflection Jacobian
 * 1 / (4 wo.h), Walter et al. 2007 Eq. 14); Beckmann D(h) cos_h / (4 wo.h).
 * 0 where the strategy cannot produce wi (h below the surface or facing away
 * from wo, wo at or below the horizon). */
GLINT_FN real smooth_sample_pdf(SmoothMaterial m, real3 wo, real3 wi) {
  real3 h = sample_half_vector(wi, wo);
  real woh = r3_dot(wo, h);
  if (!(wo.z > GLINT_R(0.0)) || !(h.z > GLINT_R(0.0)) || !(woh > GLINT_R(0.0))) return GLINT_R(0.0);
  real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
  if (m.ndf == GLINT_NDF_BECKMANN) return D * h.z / (GLINT_R(4.0) * woh);
  real zlo = ndf_z_lambda(m.ndf, wo, m.alpha_x, m.alpha_y);
  return D / (GLINT_R(4.0) * (wo.z + zlo));
}

/* A half-vector from the smooth strategy (wo.z > 0). */
GLINT_FN real3 smooth_sample_half_vector(SmoothMaterial m, real3 wo, real u1, real u2) {
  return m.ndf == GLINT_NDF_BECKMANN ? sample_beckmann_normal(m.alpha_x, m.alpha_y, u1, u2)
                                     : sample_ggx_visible_normal(wo, m.alpha_x, m.alpha_y, u1, u2);
}

/* ------------------------------------------------------------ the result */

/* The sample with wi moved to the query's space (world when the query carries
 * a frame, kernels/frame.h: local = (t, b, n) coordinates). */
GLINT_FN BrdfSample sample_in_query_space(EvalSpec spec, ShadingPoint sp, BrdfSample b) {
  if (spec.has_frame)
    b.wi = r3_add(r3_add(r3_scale(sp.frame.t, b.wi.x), r3_scale(sp.frame.b, b.wi.y)),
                  r3_scale(sp.frame.n, b.wi.z));
  return b;
}

#ifdef __OPENCL_VERSION__
/* Sample s's wi, pdf and weight, saturated like radiance (kernel_args.h); the
 * host loop stores the same (server/host_pass.h RunHostSample). */
GLINT_FN void sample_store(__global float *out, uint s, BrdfSample b) {
  __global float *o = out + GLINT_SAMPLE_FLOATS * s;
  float v[GLINT_SAMPLE_FLOATS] = {(float)b.wi.x,    (float)b.wi.y,     (float)b.wi.z,
                                  (float)b.pdf,     (float)b.weight.x, (float)b.weight.y,
                                  (float)b.weight.z};
  for (int c = 0; c < GLINT_SAMPLE_FLOATS; ++c) o[c] = GLINT_SATURATE_FLOAT(v[c]);
}
#endif

/* The weight f cos_i / pdf, 0 below the horizon or where pdf is 0. */
GLINT_FN real3 sample_weight(real3 f_cos, real pdf, real3 wi) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  if (!(wi.z > GLINT_R(0.0)) || !(pdf > GLINT_R(0.0))) return zero;
  return r3_div(f_cos, pdf);
}

#endif /* GLINT_SAMPLE_H */
