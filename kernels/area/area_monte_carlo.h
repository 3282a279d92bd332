/* Polygonal area lights on the smooth model by Monte Carlo (the MONTE_CARLO
 * area method): an unbiased estimate of
 *   I = int_P f(wi, wo) cos(theta_i) dwi
 * per unit radiance, RGB, over the solid angle P of a convex polygon clipped to
 * the upper hemisphere: the quantity area_reference_polygon (area_lights.h)
 * computes by quadrature.
 *
 * Two sampling techniques, combined by multiple importance sampling (Veach
 * 1997, "Robust Monte Carlo Methods for Light Transport Simulation", Ch. 9;
 * Veach & Guibas 1995):
 *  (L) light: directions uniform in solid angle over the spherical polygon,
 *      fan triangulated, a triangle chosen with probability proportional to
 *      its solid angle, then Arvo's area-preserving map (Arvo 1995,
 *      "Stratified Sampling of Spherical Triangles", Sec. 2-3):
 *      p_L(wi) = 1 / Omega, Omega = solid angle of the clipped polygon.
 *  (B) lobe: a microfacet normal h, reflected: wi = 2 (wo.h) h - wo, with
 *      p_B(wi) = p_h(h) / (4 wo.h) (Walter et al. 2007 Eq. 14 for reflection).
 *      GGX: the distribution of visible normals (Heitz 2018, "Sampling the GGX
 *      Distribution of Visible Normals", JCGT 7(4), Listing 1), Eq. 17
 *      p_h = G1(wo) max(0, wo.h) D(h) / wo.z, hence
 *      p_B = D(h) G1(wo) / (4 wo.z) = D(h) / (4 (wo.z + wo.z Lambda(wo))).
 *      Beckmann: p_h = D(h) cos(theta_h), sampled in slope space where it is
 *      a Gaussian (Walter et al. 2007 Eq. 28-29, anisotropic form in Heitz
 *      2014 Eq. 84): slopes (ax r cos phi, ay r sin phi), r = sqrt(-ln(1-u1)),
 *      phi = 2 pi u2. A lobe sample counts only if wi lies inside the
 *      polygon's cone (mc_inside); the others estimate 0.
 * Both techniques are unbiased alone (p > 0 wherever f cos > 0 on P).
 *
 * Sample split and weights. Sample i (0 <= i < samples) draws its random
 * numbers from rng_hash3(key, i, dim) only, so the estimate is a pure function
 * of (inputs, samples, key). With samples >= 2, even i are light samples and
 * odd i lobe samples: n_L = ceil(samples / 2), n_B = floor(samples / 2), and
 * each sample is weighted by the power heuristic with beta = 2 (Veach 1997
 * Eq. 9.13; it beat the balance heuristic in our tests at low roughness, where
 * one technique is much better than the other):
 *   w_L = (n_L p_L)^2 / ((n_L p_L)^2 + (n_B p_B)^2), w_B = 1 - w_L,
 *   I ~= sum_L w_L f / (n_L p_L) + sum_B w_B f / (n_B p_B).
 * samples == 1 uses Veach's one-sample model (Sec. 9.2.4): the technique is
 * picked with probability 1/2 each and weighted by the balance heuristic,
 * I ~= f / (p_L / 2 + p_B / 2), optimal there.
 *
 * Random dimensions of sample i: 0 = triangle choice, 1 and 2 = the 2D
 * sample (Arvo's u1, u2 or the lobe's u1, u2), 3 = technique choice (samples
 * == 1 only).
 *
 * GLINT_LANES == 1 (clipping and the sample loop branch per query). Private
 * memory: one McPolygon (17 real3 + 19 real + int, ~290 bytes in float, ~560 in
 * double) on top of the caller's vertices. */
#ifndef GLINT_AREA_MONTE_CARLO_H
#define GLINT_AREA_MONTE_CARLO_H

/* Per-query branches (clipped vertex loops, sample loops, quadrature): one
 * query per work-item. The lane-safe LTC path is area_ltc.h. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES != 1
#error "kernels/area/area_monte_carlo.h needs GLINT_LANES == 1"
#endif

#include "kernels/area/polygon.h"
#include "kernels/area/spherical_triangle.h"
#include "kernels/compat.h"
#include "kernels/ndf.h"
#include "kernels/rng.h"
#include "kernels/smooth_brdf.h"

#define GLINT_MC_MAX_VERTICES GLINT_POLYGON_MAX_CLIPPED

/* The clipped polygon and what both techniques need. The vertices are kept
 * unnormalised (only rescaled when their length is extreme): edge vectors
 * v_j - v_i are then as accurate as the input, whereas differences of
 * normalised vertices lose everything in fp32 for lights below ~1e-4 rad
 * (a 1e-6 rad light's solid angle came out 600x too large that way). */
typedef struct {
  real3 v[GLINT_MC_MAX_VERTICES];  /* vertices, convex, z >= 0 */
  real cdf[GLINT_MC_MAX_VERTICES]; /* cumulative solid angle of fan triangles 1..i */
  int n;                           /* vertex count (>= 3 when omega > 0) */
  real orient;                     /* +1 counter-clockwise from the origin, -1 clockwise */
  real omega;                      /* total solid angle */
} McPolygon;

/* Clips to the horizon, fan triangulates. Returns 0 (omega = 0) when nothing
 * above the horizon subtends a solid angle. */
GLINT_FN int mc_polygon_setup(const GLINT_PRIVATE real3 *v, int n, GLINT_PRIVATE McPolygon *P) {
  P->omega = GLINT_R(0.0);
  P->orient = GLINT_R(1.0);
  P->n = polygon_clip_to_horizon(v, n, P->v);
  if (P->n < 3) return 0;
  real lmin = r3_length(P->v[0]), lmax = lmin;
  for (int i = 1; i < P->n; ++i) {
    real l = r3_length(P->v[i]);
    lmin = fmin(lmin, l);
    lmax = fmax(lmax, l);
  }
  /* A vertex at the shading point (the receiver lies on the light): degenerate. */
  if (!(lmin > GLINT_R(0.0)) || !isfinite(lmax)) return 0;
  /* Keep the products of three lengths below fp32 overflow / underflow.
   * Only outside what the shared loader passes unscaled (polygon_scale.h:
   * squared lengths summing to within [2^-60, 2^60], so 2^-33 < lmax <= 2^30
   * for up to 17 vertices after clipping), where (2^30)^3 and (2^-33)^3 are
   * still normal fp32: the division by lmax is inexact, and at the former
   * thresholds (1e8, 1e-8) it made lights between 1e8 and ~5e8 (and between
   * ~1e-9 and 1e-8) differ in the last bits from the same light at distance
   * ~1, which every other method matches bit for bit. Now it triggers only
   * for callers that bypass the loader, or when clipping to the horizon
   * leaves only vertices within 2^-33 of the shading point (then a copy of
   * the light scaled across that threshold may differ in the last bits). */
  if ((lmax > GLINT_R(1073741824.0)) | (lmax < GLINT_R(1.16415321826934814453125e-10))) {
    for (int i = 0; i < P->n; ++i) P->v[i] = r3_div(P->v[i], lmax);
  }
  real sum = GLINT_R(0.0), signed_sum = GLINT_R(0.0);
  P->cdf[0] = GLINT_R(0.0);
  for (int i = 1; i + 1 < P->n; ++i) {
    real3 a = P->v[0], b = P->v[i], c = P->v[i + 1];
    signed_sum += spherical_triple(a, b, c);
    sum += spherical_triangle_solid_angle(a, b, c);
    P->cdf[i] = sum;
  }
  P->omega = sum;
  P->orient = signed_sum >= GLINT_R(0.0) ? GLINT_R(1.0) : GLINT_R(-1.0);
  /* Below ~1e-20 sr the float geometry is noise (area_reference_triangle uses
   * the same cut-off); the contribution is below any float result anyway. */
  return isfinite(sum) && sum > GLINT_R(1e-20);
}

/* Is the unit direction d inside the convex cone spanned by the polygon?
 * Inside every edge plane, (v_i x v_{i+1}) . d = (v_i x (v_{i+1} - v_i)) . d
 * on the interior side; edges that collapsed to a point (clipping
 * duplicates) test 0 and pass. */
GLINT_FN int mc_inside(const GLINT_PRIVATE McPolygon *P, real3 d) {
  for (int i = 0; i < P->n; ++i) {
    real3 a = P->v[i];
    real3 b = P->v[i + 1 < P->n ? i + 1 : 0];
    if (P->orient * r3_dot(r3_cross(a, r3_sub(b, a)), d) < GLINT_R(0.0)) return 0;
  }
  return 1;
}

/* Technique L: a direction uniform in the polygon's solid angle. */
GLINT_FN real3 mc_sample_light(const GLINT_PRIVATE McPolygon *P, uint key, uint i) {
  real target = rng_u01(rng_hash3(key, i, 0u)) * P->omega;
  /* First fan triangle whose cumulative solid angle exceeds the target; zero-
   * area triangles are never chosen (strict <). Rounding falls back to the
   * last triangle with a non-zero solid angle. */
  int k = 1;
  for (int j = 1; j + 1 < P->n; ++j) {
    if (P->cdf[j] > P->cdf[j - 1]) k = j;
    if (target < P->cdf[j]) break;
  }
  real area = P->cdf[k] - P->cdf[k - 1];
  real u1 = rng_u01(rng_hash3(key, i, 1u));
  real u2 = rng_u01(rng_hash3(key, i, 2u));
  real3 a = r3_normalize(P->v[0]), b = r3_normalize(P->v[k]), c = r3_normalize(P->v[k + 1]);
  return arvo_point(arvo_arc(a, b, c, area, spherical_vertex_angle(a, b, c), u1), u2);
}

/* GGX visible normal for view wo (Heitz 2018, Listing 1), anisotropic. */
GLINT_FN real3 mc_sample_ggx_vndf(real3 wo, real ax, real ay, real u1, real u2) {
  /* Sec. 3.2: the view in the hemisphere configuration (alpha = 1). */
  real3 vh = r3_normalize(make_real3(ax * wo.x, ay * wo.y, wo.z));
  /* Sec. 4.1: orthonormal basis, T1 = (1, 0, 0) at normal view. */
  real lensq = vh.x * vh.x + vh.y * vh.y;
  real inv = lensq > GLINT_R(0.0) ? GLINT_R(1.0) / sqrt(lensq) : GLINT_R(0.0);
  real3 t1v = lensq > GLINT_R(0.0) ? make_real3(-vh.y * inv, vh.x * inv, GLINT_R(0.0))
                                   : make_real3(GLINT_R(1.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 t2v = r3_cross(vh, t1v);
  /* Sec. 4.2: uniform on the projected disk, warped to the visible half. */
  real r = sqrt(u1);
  real phi = GLINT_R(2.0) * GLINT_PI * u2;
  real t1 = r * cos(phi);
  real t2 = r * sin(phi);
  real s = GLINT_R(0.5) * (GLINT_R(1.0) + vh.z);
  t2 = (GLINT_R(1.0) - s) * sqrt(fmax(GLINT_R(1.0) - t1 * t1, GLINT_R(0.0))) + s * t2;
  /* Sec. 4.3: reprojection onto the hemisphere. */
  real3 nh = r3_add(r3_add(r3_scale(t1v, t1), r3_scale(t2v, t2)),
                    r3_scale(vh, sqrt(fmax(GLINT_R(1.0) - t1 * t1 - t2 * t2, GLINT_R(0.0)))));
  /* Sec. 3.4: back to the ellipsoid configuration. */
  return r3_normalize(make_real3(ax * nh.x, ay * nh.y, fmax(nh.z, GLINT_R(0.0))));
}

/* Beckmann normal with density D(h) cos(theta_h): the slope (-hx/hz, -hy/hz)
 * is a centred Gaussian with standard deviations ax / sqrt(2), ay / sqrt(2)
 * (Heitz 2014 Eq. 84 is that Gaussian divided by cos^4), inverted in polar
 * form (Box-Muller; Walter et al. 2007 Eq. 28-29 for ax = ay). */
GLINT_FN real3 mc_sample_beckmann(real ax, real ay, real u1, real u2) {
  real r = sqrt(-log(GLINT_R(1.0) - u1)); /* u1 < 1: finite */
  real phi = GLINT_R(2.0) * GLINT_PI * u2;
  real sx = ax * r * cos(phi), sy = ay * r * sin(phi);
  return r3_normalize(make_real3(sx, sy, GLINT_R(1.0)));
}

/* Technique B. Returns the reflected direction; *ok = 0 when the sampled
 * normal cannot reflect wo (wo.h <= 0, possible for Beckmann) or wi is at or
 * below the horizon: such samples estimate 0. */
GLINT_FN real3 mc_sample_lobe(SmoothMaterial m, real3 wo, uint key, uint i, GLINT_PRIVATE int *ok) {
  real u1 = rng_u01(rng_hash3(key, i, 1u));
  real u2 = rng_u01(rng_hash3(key, i, 2u));
  real3 h = m.ndf == GLINT_NDF_BECKMANN ? mc_sample_beckmann(m.alpha_x, m.alpha_y, u1, u2)
                                        : mc_sample_ggx_vndf(wo, m.alpha_x, m.alpha_y, u1, u2);
  real oh = r3_dot(wo, h);
  real3 wi = r3_sub(r3_scale(h, GLINT_R(2.0) * oh), wo);
  *ok = (oh > GLINT_R(0.0)) & (wi.z > GLINT_R(0.0));
  return wi;
}

/* p_B(wi), the solid-angle density of technique B at wi (0 if unreachable),
 * through h = (wi + wo) / |wi + wo|, where wo.h = |wi + wo| / 2 exactly for
 * unit vectors (no cancellation at grazing angles). */
GLINT_FN real mc_lobe_pdf(SmoothMaterial m, real3 wo, real3 wi) {
  real3 hv = r3_add(wi, wo);
  real len = r3_length(hv);
  if (!(len > GLINT_R(0.0)) | !(wi.z > GLINT_R(0.0))) return GLINT_R(0.0);
  real3 h = r3_div(hv, len);
  real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
  if (m.ndf == GLINT_NDF_BECKMANN) {
    /* p_h = D cos(theta_h), / (4 wo.h) with wo.h = len / 2. */
    return D * h.z / (GLINT_R(2.0) * len);
  }
  /* Heitz 2018 Eq. 17 over 4 wo.h: D G1(wo) / (4 wo.z), G1 = wo.z / (wo.z + wo.z Lambda). */
  real zl = ndf_z_lambda(m.ndf, wo, m.alpha_x, m.alpha_y);
  return D / (GLINT_R(4.0) * (wo.z + zl));
}

/* Power heuristic (beta = 2) weight of a technique with density-times-count a
 * against the other's b: a^2 / (a^2 + b^2), written so that huge ratios give
 * 0 or 1 rather than inf / inf. */
GLINT_FN real mc_power_weight(real a, real b) {
  if (!(a > GLINT_R(0.0))) return GLINT_R(0.0);
  real r = b / a;
  return GLINT_R(1.0) / (GLINT_R(1.0) + r * r);
}

/* Adds f * s to acc when s is a finite non-negative factor (guards the rare
 * 0 * inf of densities that under- or overflowed in fp32). */
GLINT_FN real3 mc_accumulate(real3 acc, real3 f, real s) {
  return isfinite(s) && s >= GLINT_R(0.0) ? r3_add(acc, r3_scale(f, s)) : acc;
}

/* The MIS estimate with an explicit split: n_light samples of technique L and
 * n_lobe of technique B (either may be 0: that technique alone). Light sample
 * j uses random index 2j, lobe sample j index 2j + 1. area_mc_polygon is the
 * entry point; the split form exists for tests and benchmarks. */
GLINT_FN real3 area_mc_polygon_split(SmoothMaterial m, real3 wo, const GLINT_PRIVATE real3 *v,
                                     int n, int n_light, int n_lobe, uint key) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  if (!(wo.z > GLINT_R(0.0)) || n_light + n_lobe < 1) return zero;
  McPolygon P;
  if (!mc_polygon_setup(v, n, &P)) return zero;
  real nl = (real)n_light, nb = (real)n_lobe;
  real a = nl / P.omega; /* n_L p_L, the same for every direction in P */
  real3 acc = zero;
  for (int j = 0; j < n_light; ++j) {
    real3 wi = mc_sample_light(&P, key, (uint)(2 * j));
    real3 f = smooth_reflect_cos(m, wi, wo);
    real b = nb * mc_lobe_pdf(m, wo, wi);
    /* w_L f / (n_L p_L) */
    acc = mc_accumulate(acc, f, mc_power_weight(a, b) / a);
  }
  for (int j = 0; j < n_lobe; ++j) {
    int ok;
    real3 wi = mc_sample_lobe(m, wo, key, (uint)(2 * j + 1), &ok);
    if (!ok) continue;
    wi = r3_normalize(wi); /* unit up to rounding already */
    if (!mc_inside(&P, wi)) continue;
    real3 f = smooth_reflect_cos(m, wi, wo);
    real b = nb * mc_lobe_pdf(m, wo, wi);
    if (!(b > GLINT_R(0.0))) continue;
    /* w_B f / (n_B p_B) */
    acc = mc_accumulate(acc, f, mc_power_weight(b, a) / b);
  }
  return acc;
}

/* int_P f cos_i dwi per unit radiance, RGB, unbiased, from `samples` samples
 * keyed by `key` (see the header comment for the split and the weights).
 * v: n (3..16) vertices of a convex polygon relative to the shading point,
 * local frame. 0 when wo.z <= 0 or the polygon is below the horizon. */
GLINT_FN real3 area_mc_polygon(SmoothMaterial m, real3 wo, const GLINT_PRIVATE real3 *v, int n,
                               int samples, uint key) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  if (samples >= 2) return area_mc_polygon_split(m, wo, v, n, (samples + 1) / 2, samples / 2, key);
  if (!(wo.z > GLINT_R(0.0)) || samples < 1) return zero;
  /* One-sample MIS (Veach 1997 Sec. 9.2.4), c_L = c_B = 1/2, balance
   * heuristic: f / (p_L / 2 + p_B / 2) = 2 f omega / (1 + p_B omega). */
  McPolygon P;
  if (!mc_polygon_setup(v, n, &P)) return zero;
  real3 wi;
  if (rng_u01(rng_hash3(key, 0u, 3u)) < GLINT_R(0.5)) {
    wi = mc_sample_light(&P, key, 0u);
  } else {
    int ok;
    wi = mc_sample_lobe(m, wo, key, 0u, &ok);
    if (!ok) return zero;
    wi = r3_normalize(wi);
    if (!mc_inside(&P, wi)) return zero;
  }
  real3 f = smooth_reflect_cos(m, wi, wo);
  real pb_omega = mc_lobe_pdf(m, wo, wi) * P.omega;
  return mc_accumulate(zero, f, GLINT_R(2.0) * P.omega / (GLINT_R(1.0) + pb_omega));
}

#endif /* GLINT_AREA_MONTE_CARLO_H */
