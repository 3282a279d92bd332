/* Polygonal area lights for the smooth microfacet BRDF by the O(1) analytic contour-integral
 * approximations of Lecocq, Sourimant, Marvie 2015, "Accurate Analytic Approximations for
 * Real-Time Specular Area Lighting" (SIGGRAPH Talks; here LSM15): LECOCQ (one Lorentzian per
 * edge) and LECOCQ_PEARSON (Lorentzian + Pearson VII per edge).
 *
 * LSM15 is a two-page talk without numbered equations; the equations below are numbered as in
 * tools/lecocq/README.md, which derives them and documents the fits and every departure from
 * the talk. In short:
 *  1. (LSM15 "Extension to other BRDFs") Change of variables to the half vector,
 *     h = normalize(wi + wo), dwi = 4 (wo.h) dh:
 *       int_P f cos_i dwi = int_{P_h} D(h) (h.z) W(h) dh,  W = F G2 (wo.h) / (cos_o h.z)  (H1)
 *     The polygon's edges are split into short pieces whose h-images are taken as great arcs
 *     (the talk's "edge splitting strategy"); pieces near wi = -wo, where the map is singular
 *     and a short piece's image sweeps half a great circle, are cut further (lecocq_subsplit).
 *  2. Anisotropy: GGX and Beckmann are slope-stretched families, so the linear map
 *     h' = normalize(sx h.x, sy h.y, h.z), s = sqrt(ax ay) / a{x,y}, turns D_aniso(h)(h.z)dh
 *     into D_iso(h')(h'.z)dh' with alpha = sqrt(ax ay), EXACTLY (H2); it keeps great arcs.
 *  3. Phong lobe: D_iso(h')(h'.z) ~ (N+1)/(2 pi) (h'.z)^N with N + 1 = kappa(alpha)/alpha^2
 *     fitted per NDF (H3, generated block).
 *  4. (LSM15 "Prior work", Arvo 1995 Sec. 5) Contour integral of the axial moment, valid for
 *     real N when the region lies in z >= 0 (README Eq. E1-E3):
 *       (N+1) int_{P'} (h.z)^N dh = sum_edges -s_e int_{t0}^{t1} I(t) dt,
 *       I(t) = (1 - x^(N+1)) / (1 - x^2), x = c cos t, s_e = n_e.z, c = sqrt(1 - s_e^2)
 *     (the talk's "geometric series ... reduced to a single function I").
 *  5. (LSM15 "Our approach") I is replaced by a peak function with the exact peak value I(0)
 *     ("one point evaluation") and an empirical width g(N, p), p = c^(N+1) (generated block):
 *     a Lorentzian in sin t (README Eq. L1-L2: one arctangent), or a mix of it with a Pearson
 *     VII (m = 2) whose weight matches I at the second point t = pi/2 (Eq. P1-P3).
 *  6. W at a representative half vector (README Eq. M1-M3, N2; DEPARTURE: LSM15 do not say
 *     how W is handled, the first version here used its lobe average, which fails for wide
 *     lobes and grazing views). The same contour sums give the lobe-weighted moments
 *     int (h.z)^N h dh of the region (z: Eq. E3 at exponent N + 1; x, y: Eq. M2, a single-
 *     power edge integral c^N int cos^N t dt, approximated by a Gaussian, Eq. M3); their
 *     direction h_P is the lobe-weighted mean half vector. The result is
 *       albedo(wo) * [W(h_P) tau(P)] / [W(h_H) tau(H)],
 *     tau = steps 4-5 on the polygon P and on the whole upper hemisphere H (same splitting and
 *     approximations), so that a light filling the hemisphere gives the albedo exactly and
 *     W(h_P) / W(h_H) carries the variation of F G2 (wo.h) / (cos_o h.z) across the lobe.
 *     W uses the exact Fresnel and the anisotropic G2. The albedo comes from the LTC table
 *     (slots 4-5, tools/ltc/README.md): Schlick exact, conductor/dielectric APPROXIMATED by
 *     Schlick through F(1), as area_ltc_polygon does; looked up at sqrt(ax ay) (APPROXIMATION).
 *     The result is clamped to the albedo (P lies in the hemisphere). The moments cost a second
 *     peak-function evaluation (exponent N + 1) and one erf pair per edge piece: still O(1).
 *
 * The edge splitting and the vertex compaction branch per query: GLINT_LANES == 1 only. */
#ifndef GLINT_AREA_LECOCQ_H
#define GLINT_AREA_LECOCQ_H

/* Per-query branches (clipped vertex loops, sample loops, quadrature): one
 * query per work-item. The lane-safe LTC path is area_ltc.h. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES != 1
#error "kernels/area/area_lecocq.h needs GLINT_LANES == 1"
#endif

#include "kernels/area/ltc_lookup.h"
#include "kernels/area/polygon.h"
#include "kernels/compat.h"
#include "kernels/smooth_brdf.h"

/* Edge splitting (step 1): a polygon edge of angle theta (in wi space) is cut into
 * ceil(theta / GLINT_LECOCQ_SPLIT) pieces, at most GLINT_LECOCQ_MAX_SPLIT. */
#define GLINT_LECOCQ_SPLIT GLINT_R(0.19634954084936207) /* pi / 16 */
#define GLINT_LECOCQ_MAX_SPLIT 16
/* Half-vector sub-splitting (step 1, near the map's singular point wi = -wo; see
 * lecocq_subsplit): a piece whose h-image is predicted to turn by Psi > GLINT_LECOCQ_H_SPLIT is
 * cut into ceil(Psi / GLINT_LECOCQ_H_SPLIT) sub-pieces (Psi < pi: at most 8). With pi / 8 the
 * worst cases at 75-85 deg in tests/area/lecocq_test.cpp improve (max relative error 0.435 ->
 * 0.373, 0.516 -> 0.495, 0.320 -> 0.315 by alpha band) for <= 0.005 on the means; pi / 4 made
 * one worse (0.435 -> 0.501). Near the horizon (wo.z <= 0.01) every step from pi / 4 down to a
 * converged split (pi / 256 pieces, pi / 64 sub-pieces) gives the same errors to 0.01. */
#define GLINT_LECOCQ_H_SPLIT GLINT_R(0.39269908169872414) /* pi / 8 */
#define GLINT_LECOCQ_MAX_SUBSPLIT 8
/* Pearson mixing is blended in over N in [3, 5]: below, the fitted Lorentzian is the better
 * model of the nearly flat I (README "Edge integrand"). */
#define GLINT_LECOCQ_PEARSON_N0 GLINT_R(3.0)
#define GLINT_LECOCQ_PEARSON_N1 GLINT_R(5.0)

/* clang-format off */
/* BEGIN GENERATED (glint_fit_lecocq) */
/* Generated by tools/lecocq/fit_lecocq.cpp (glint_fit_lecocq --header kernels/area/area_lecocq.h). Do not edit.
 * g_L: worst sup-error of the edge integral 0.0369229 (mean 0.018702, best possible 0.0328865)
 * g_P: worst 0.0368025 (mean 0.0116316, best possible 0.00931325), N >= 4
 * kappa GGX: worst KS distance 0.101898, Beckmann 0.0716842 */
GLINT_FN real lecocq_width_lorentz(real N, real p) {
  real v = GLINT_R(1.0) / sqrt(N + GLINT_R(1.0));
  return GLINT_R(1.0) + p * (GLINT_R(0.296937501) + p * (GLINT_R(-0.267581437) + p * GLINT_R(0.140701114)) + v * (GLINT_R(0.207143391) + GLINT_R(-0.254562433) * p + GLINT_R(0.0665726972) * v));
}
GLINT_FN real lecocq_width_pearson(real N, real p) {
  real v = GLINT_R(1.0) / sqrt(N + GLINT_R(1.0));
  return GLINT_R(1.0) + p * (GLINT_R(2.30351549) + p * (GLINT_R(-3.6194184) + p * GLINT_R(2.09395572)) + v * (GLINT_R(1.63630817) + GLINT_R(-4.66045176) * p + GLINT_R(12.5433032) * v));
}
GLINT_FN real lecocq_kappa_ggx(real a) {
  return GLINT_R(1.06336013) + a * (GLINT_R(0.0105521804) + a * (GLINT_R(1.34550795) + a * GLINT_R(-0.421675772)));
}
GLINT_FN real lecocq_kappa_beckmann(real a) {
  return GLINT_R(2.00001067) + a * (GLINT_R(-0.00441659971) + a * (GLINT_R(1.40486755) + a * GLINT_R(-0.35508843)));
}
/* END GENERATED (glint_fit_lecocq) */
/* clang-format on */

/* Phong exponent N of the lobe (h.z)^N standing for D(h)(h.z) (step 3, README Eq. H3). */
GLINT_FN real lecocq_phong_exponent(int ndf, real alpha) {
  real a = clamp(alpha, GLINT_R(1e-4), GLINT_R(1.0));
  real kappa = ndf == GLINT_NDF_BECKMANN ? lecocq_kappa_beckmann(a) : lecocq_kappa_ggx(a);
  return fmax(kappa / (a * a) - GLINT_R(1.0), GLINT_R(1.0));
}

/* Peak-function integrals in t (README Eq. L2, P2), for t in [-pi/2, pi/2]:
 *   F1(t) = int_0^t dt / (1 + q sin^2)   = atan2(r sin t, cos t) / r,  r = sqrt(1 + q)
 *   F2(t) = int_0^t dt / (1 + q sin^2)^2 = (2+q)/(2(1+q)) F1 + q sin t cos t / (2(1+q)(1+q sin^2))
 */
GLINT_FN real lecocq_f1(real r, real st, real ct) {
  return atan2(r * st, ct) / r;
}
GLINT_FN real lecocq_f2(real q, real r, real st, real ct) {
  return (GLINT_R(2.0) + q) / (GLINT_R(2.0) * (GLINT_R(1.0) + q)) * lecocq_f1(r, st, ct) +
         q * st * ct / (GLINT_R(2.0) * (GLINT_R(1.0) + q) * (GLINT_R(1.0) + q * st * st));
}

/* int_{t0}^{t1} I(t) dt of README Eq. E3 with I replaced by LSM15's peak function (step 5):
 * s2 = s_e^2, N the Phong exponent, pearson_w in [0, 1] blends Lorentzian -> L + Pearson VII. */
GLINT_FN real lecocq_peak_integral(real s2, real N, real pearson_w, real st0, real ct0, real st1,
                                   real ct1) {
  /* Peak value I(0) = (1 - c^(N+1)) / s^2 (README Eq. E4), J0 = I(0) - 1; c^(N+1) by
   * exp/log1p so that s -> 0 (edge through the lobe axis) keeps its digits. */
  real hn = GLINT_R(0.5) * (N + GLINT_R(1.0));
  real one_minus_p = -expm1(hn * log1p(-s2));
  real A = s2 > GLINT_R(1e-30) ? one_minus_p / s2 : hn;
  A = fmax(A, GLINT_R(1.0));
  real J0 = A - GLINT_R(1.0);
  real p = GLINT_R(1.0) - one_minus_p; /* c^(N+1), the shape parameter of the width fits */
  /* Lorentzian in sin t, q = J0 / g^2 (README Eq. L1-L2). */
  real gl = lecocq_width_lorentz(N, p);
  real ql = J0 / (gl * gl);
  real rl = sqrt(GLINT_R(1.0) + ql);
  real lor = A * (lecocq_f1(rl, st1, ct1) - lecocq_f1(rl, st0, ct0));
  if (!(pearson_w > GLINT_R(0.0))) return lor;
  /* Lorentzian + Pearson VII, weight k from I(pi/2) = 1 (README Eq. P3). */
  real gp = lecocq_width_pearson(N, p);
  real qp = J0 / (gp * gp);
  real rp = sqrt(GLINT_R(1.0) + qp);
  real k = (GLINT_R(2.0) + qp - gp * gp) / A;
  real mix = A * (k * (lecocq_f1(rp, st1, ct1) - lecocq_f1(rp, st0, ct0)) +
                  (GLINT_R(1.0) - k) * (lecocq_f2(qp, rp, st1, ct1) - lecocq_f2(qp, rp, st0, ct0)));
  return (GLINT_R(1.0) - pearson_w) * lor + pearson_w * mix;
}

/* One great-arc edge a -> b (unit vectors, z >= 0) of the region in h' space. Adds to acc:
 *   acc[0] += -s_e int I_N dt       (README Eq. E3: the Phong-lobe mass, times N + 1)
 *   acc[1] += -s_e int I_(N+1) dt   (Eq. M1: the z moment, times N + 2)
 *   acc[2..3] += -n_e.{x,y} c^N int cos^N t dt  (Eq. M2: the x, y moments, times N + 2)
 * acc[1..3] give the lobe-weighted mean direction of the region (step 6). */
GLINT_FN void lecocq_edge(real3 a, real3 b, real N, real pearson_w, GLINT_PRIVATE real *acc) {
  real3 cr = r3_cross(a, b);
  real len = r3_length(cr);
  if (!(len > GLINT_R(1e-20))) return; /* zero-length edge: no contribution */
  real theta = atan2(len, r3_dot(a, b));
  real3 n = r3_div(cr, len);
  real s = n.z;
  real s2 = fmin(s * s, GLINT_R(1.0));
  /* u(theta') = a cos + bp sin along the arc; z.u = c cos(theta' - phi). */
  real3 bp = r3_cross(n, a);
  real phi = atan2(bp.z, a.z);
  const real half_pi = GLINT_R(0.5) * GLINT_PI;
  real t0 = clamp(-phi, -half_pi, half_pi);
  real t1 = clamp(theta - phi, -half_pi, half_pi);
  real st0 = sin(t0), ct0 = cos(t0), st1 = sin(t1), ct1 = cos(t1);
  acc[0] -= s * lecocq_peak_integral(s2, N, pearson_w, st0, ct0, st1, ct1);
  acc[1] -= s * lecocq_peak_integral(s2, N + GLINT_R(1.0), pearson_w, st0, ct0, st1, ct1);
  /* int cos^N t dt ~ int exp(-a t^2 / 2) dt, a = N + 1/2 (README Eq. M3). */
  real ga = sqrt(GLINT_R(0.5) * (N + GLINT_R(0.5)));
  real cn =
      exp(GLINT_R(0.5) * N * log1p(-s2)) * GLINT_R(0.88622692545275801) / ga; /* sqrt(pi) / 2 */
  real j = cn * (erf(ga * t1) - erf(ga * t0));
  acc[2] -= n.x * j;
  acc[3] -= n.y * j;
}

/* Maps a wi-space direction (unit, z >= 0) to the stretched half-vector space (steps 1-2). */
GLINT_FN real3 lecocq_to_h(real3 wi, real3 wo, real sx, real sy) {
  real3 h = r3_add(wi, wo);
  return r3_normalize(make_real3(sx * h.x, sy * h.y, h.z));
}

/* Sub-splitting of one wi-space piece p -> q (unit, z >= 0) near the singular point c = -wo of
 * the half-vector map (DEPARTURE: LSM15 name an "edge splitting strategy" for the distortion
 * of the half-vector map but give no rule; the uniform pi/16 split in wi space alone fails at
 * grazing views). h = normalize(wi + wo) keeps the azimuth of wi about wo and halves its polar
 * angle, so as wi passes c at a small angular distance w, h sweeps through half a great circle
 * (the one perpendicular to wo, through the lobe) within |wi - c| ~ a few w. In the tangent
 * plane at c the piece's great circle is a line at distance w from c, and the direction of h
 * is that of wi - c: its angle is psi(theta) = atan((theta - theta_c) / w), theta the arc angle
 * from p and theta_c that of the point of the great circle nearest c. At grazing views
 * (wo.z -> 0; w = asin(wo.z) for the horizon) the uniform piece of the hemisphere's horizon
 * edge that holds theta_c has h-images of its ends nearly antipodal, and the great arc between
 * them (lecocq_edge) runs round the far side of the sphere instead of through the lobe: the
 * hemisphere normaliser tau(H) lost up to half the lobe, results went up to 24x REFERENCE, and
 * a light split in two triangles gave 2.2x the quad (both clamped to the albedo; the session 9
 * probe's known issue). Here such a piece is cut at equal steps of psi, theta_j = theta_c +
 * w tan(psi_j), so that no sub-piece's image turns by more than GLINT_LECOCQ_H_SPLIT. Returns
 * the number of sub-pieces m (1: the piece as it is, same arithmetic as before) and the
 * parameters of the cut: e (unit, in the piece's plane, perpendicular to p), theta_c, w, psi_0
 * and the step of psi. */
GLINT_FN int lecocq_subsplit(real3 p, real3 q, real3 wo, GLINT_PRIVATE real3 *e,
                             GLINT_PRIVATE real *par) {
  /* Early out, exact with respect to the rule below: on the sphere the distance from c to a
   * point of the piece is at most sqrt(w^2 + (theta - theta_c)^2) (a spherical right triangle's
   * hypotenuse is shorter than the planar one's) and dpsi/dtheta <= 1 / that, so Psi <= delta /
   * min |wi - c| <= delta / (|p - c| - delta) (chords <= arcs), with delta <= SPLIT (an edge of
   * at most pi is cut into ceil(theta / SPLIT) pieces; 1.01 covers the 1e-3 tolerance of that
   * ceil). So Psi <= H_SPLIT whenever |p + wo| >= 1.01 SPLIT (1 + 1 / H_SPLIT) = 0.70: a piece
   * of the upper hemisphere is that far from c for every view below ~48 deg, where the
   * arithmetic is the uniform split's, bit for bit. */
  const real far =
      GLINT_R(1.01) * GLINT_LECOCQ_SPLIT * (GLINT_R(1.0) + GLINT_R(1.0) / GLINT_LECOCQ_H_SPLIT);
  real3 pc = r3_add(p, wo);
  if (r3_dot(pc, pc) >= far * far) return 1;
  real3 cr = r3_cross(p, q);
  real len = r3_length(cr);
  if (!(len > GLINT_R(1e-20))) return 1;
  real3 n = r3_div(cr, len);
  *e = r3_cross(n, p);
  real delta = atan2(len, r3_dot(p, q));
  real cp = -r3_dot(wo, p), ce = -r3_dot(wo, *e);
  real w = atan2(fabs(r3_dot(wo, n)), sqrt(cp * cp + ce * ce));
  real tc = atan2(ce, cp);
  real psi0 = atan2(-tc, w), psi1 = atan2(delta - tc, w);
  real turn = psi1 - psi0;
  if (!(turn > GLINT_LECOCQ_H_SPLIT)) return 1;
  int m = (int)(turn / GLINT_LECOCQ_H_SPLIT) + 1;
  m = m > GLINT_LECOCQ_MAX_SUBSPLIT ? GLINT_LECOCQ_MAX_SUBSPLIT : m;
  par[0] = tc;
  par[1] = w;
  par[2] = psi0;
  par[3] = turn / (real)m;
  return m;
}

/* lecocq_edge summed over the h'-image of a spherical polygon in wi space (unit vertices,
 * z >= 0), each edge split into pieces of at most GLINT_LECOCQ_SPLIT (step 1), and a piece
 * near wi = -wo further by lecocq_subsplit. */
GLINT_FN void lecocq_region(const GLINT_PRIVATE real3 *w, int n, real3 wo, real sx, real sy, real N,
                            real pearson_w, GLINT_PRIVATE real *acc) {
  for (int k = 0; k < 4; ++k) acc[k] = GLINT_R(0.0);
  for (int i = 0; i < n; ++i) {
    real3 a = w[i];
    real3 b = w[(i + 1) % n];
    real theta = atan2(r3_length(r3_cross(a, b)), r3_dot(a, b));
    /* ceil(theta / SPLIT), with a tolerance: the hemisphere's edges (pi / 4 each) are exactly
     * 4 splits long, and floor + 1 there gave 4 or 5 pieces depending on the last ulp of
     * cos/sin/atan2 (host vs device libm, float vs double), which changes tau(H) and W(h_H) by
     * up to a few % at grazing views. (int) truncates towards zero: theta ~ 0 gives 1 piece. */
    int pieces = (int)(theta / GLINT_LECOCQ_SPLIT - GLINT_R(1e-3)) + 1;
    pieces = pieces > GLINT_LECOCQ_MAX_SPLIT ? GLINT_LECOCQ_MAX_SPLIT : pieces;
    real3 prev_w = a;
    real3 prev = lecocq_to_h(a, wo, sx, sy);
    for (int k = 1; k <= pieces; ++k) {
      /* A point of the chord a-b, normalised, lies on the great arc a-b. */
      real u = (real)k / (real)pieces;
      real3 wk = r3_normalize(r3_add(r3_scale(a, GLINT_R(1.0) - u), r3_scale(b, u)));
      real3 e = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
      real par[4] = {GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0)};
      int m = lecocq_subsplit(prev_w, wk, wo, &e, par);
      for (int j = 1; j < m; ++j) {
        real psi = par[2] + (real)j * par[3]; /* in (-pi/2, pi/2): cos > 0 */
        real t = par[0] + par[1] * sin(psi) / cos(psi);
        real3 wj = r3_add(r3_scale(prev_w, cos(t)), r3_scale(e, sin(t)));
        real3 hj = lecocq_to_h(wj, wo, sx, sy);
        lecocq_edge(prev, hj, N, pearson_w, acc);
        prev = hj;
      }
      real3 next = lecocq_to_h(wk, wo, sx, sy);
      lecocq_edge(prev, next, N, pearson_w, acc);
      prev = next;
      prev_w = wk;
    }
  }
}

/* W(h) = F G2 (wo.h) / (cos_o h.z) of Eq. H1 at the mean direction of region acc (h' space,
 * unstretched here; ax, ay clamped as in area_lecocq_polygon), RGB.
 * hz_min: a lower bound on h'.z over the region (0 for the hemisphere). The exact lobe-weighted
 * mean direction of a region in z >= 0 is a normalised mean of its unit vectors, so its z is at
 * least the region's lowest h'.z. The moments' peak-function approximation (M1) can violate that
 * when the region holds only the lobe's tail: its error then exceeds the tiny moments, and the z
 * moment can even change sign while the mass does not. Without the bound the mean direction fell
 * to the horizon, h.z was clamped to 1e-6 and W (~1 / h.z) reached 1e4-1e5, which the albedo
 * clamp turned into ~albedo: GGX alpha 0.72, wo.z 1e-4, a light at 20-30 deg elevation (AUTO
 * training set, MakeConfigs(1, 1000, 8, GGX)[676] view 7) gave 0.995 for a truth of 0.0028.
 * With the bound, the direction keeps the moments' azimuth and is lifted to hz_min. */
GLINT_FN real3 lecocq_weight(SmoothMaterial m, real ax, real ay, real3 wo,
                             const GLINT_PRIVATE real *acc, real hz_min) {
  real alpha = sqrt(ax * ay), sx = alpha / ax, sy = alpha / ay;
  real sg = acc[0] < GLINT_R(0.0) ? GLINT_R(-1.0) : GLINT_R(1.0);
  real3 hp = make_real3(sg * acc[2], sg * acc[3], fmax(sg * acc[1], GLINT_R(0.0)));
  real lp = r3_length(hp);
  if (hz_min > GLINT_R(0.0) && !(hp.z >= hz_min * lp)) {
    real lxy = sqrt(hp.x * hp.x + hp.y * hp.y);
    real sxy = lxy > GLINT_R(0.0) ? sqrt(fmax(GLINT_R(1.0) - hz_min * hz_min, GLINT_R(0.0))) / lxy
                                  : GLINT_R(0.0);
    hp = lxy > GLINT_R(0.0) ? make_real3(hp.x * sxy, hp.y * sxy, hz_min)
                            : make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  }
  real3 h = make_real3(hp.x / sx, hp.y / sy, hp.z);
  real l = r3_length(h);
  h = l > GLINT_R(0.0) ? r3_div(h, l) : make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  h.z = fmax(h.z, GLINT_R(1e-6));
  real oh = fmax(r3_dot(wo, h), GLINT_R(0.0));
  real3 wi = r3_sub(r3_scale(h, GLINT_R(2.0) * oh), wo);
  wi.z = fmax(wi.z, GLINT_R(1e-6));
  real v = smith_visibility_cos_i(m.ndf, wo, wi, ax, ay);
  return r3_scale(fresnel_eval(m.fresnel, oh), GLINT_R(4.0) * v * oh / h.z);
}

/* int_P f(wi, wo) cos(theta_i) dwi per unit radiance, RGB, by LSM15 (steps 1-6 above).
 * pearson = 0: LECOCQ (Lorentzian); 1: LECOCQ_PEARSON (Lorentzian + Pearson VII). `table` is
 * the LTC table of m.ndf (used for the albedo only). v: polygon vertices relative to the
 * shading point in the local frame, n in [3, 16], convex. */
GLINT_FN real3 area_lecocq_polygon(SmoothMaterial m, const GLINT_GLOBAL float *table, real3 wo,
                                   const GLINT_PRIVATE real3 *v, int n, int pearson) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  if (!(wo.z > GLINT_R(0.0))) return zero; /* as smooth_reflect_cos: no transmission */
  real3 w[GLINT_POLYGON_MAX_CLIPPED];
  int nc = polygon_clip_to_horizon(v, n, w);
  if (nc < 3) return zero;
  /* Unit vertices. A vertex at the shading point (the polygon touches the receiver, or an edge
   * through it was clipped at the horizon) has no direction and is dropped, as in
   * polygon_form_factor: such a polygon is seen edge-on (its plane contains the shading
   * point). Replacing it by the normal, as before, integrated a triangle up to the zenith. */
  int kept = 0;
  for (int i = 0; i < nc; ++i) {
    real l = r3_length(w[i]);
    if (l > GLINT_R(0.0)) w[kept++] = r3_div(w[i], l);
  }
  nc = kept;
  if (nc < 3) return zero;
  /* Step 2: isotropic alpha and the stretch that maps the anisotropic lobe onto it (Eq. H2). */
  real ax = clamp(m.alpha_x, GLINT_R(1e-4), GLINT_R(1.0)),
       ay = clamp(m.alpha_y, GLINT_R(1e-4), GLINT_R(1.0));
  real alpha = sqrt(ax * ay);
  real sx = alpha / ax, sy = alpha / ay;
  real N = lecocq_phong_exponent(m.ndf, alpha);
  real pw = pearson ? clamp((N - GLINT_LECOCQ_PEARSON_N0) /
                                (GLINT_LECOCQ_PEARSON_N1 - GLINT_LECOCQ_PEARSON_N0),
                            GLINT_R(0.0), GLINT_R(1.0))
                    : GLINT_R(0.0);

  /* Steps 4-5 on the polygon and on the upper hemisphere (8 vertices on the horizon, whose
   * edges are the horizon itself; Eq. N2). */
  real accp[4], acch[4];
  lecocq_region(w, nc, wo, sx, sy, N, pw, accp);
  real3 hemi[8];
  for (int k = 0; k < 8; ++k) {
    real ang = (real)k * GLINT_R(0.78539816339744831); /* pi / 4 */
    hemi[k] = make_real3(cos(ang), sin(ang), GLINT_R(0.0));
  }
  lecocq_region(hemi, 8, wo, sx, sy, N, pw, acch);
  real tau_p = fabs(accp[0]), tau_h = fabs(acch[0]);
  real ratio =
      tau_h > GLINT_R(0.0) ? clamp(tau_p / tau_h, GLINT_R(0.0), GLINT_R(1.0)) : GLINT_R(0.0);

  /* Step 6 (README Eq. N2): albedo(wo) * [W(h_P) tau(P)] / [W(h_H) tau(H)], W (Eq. H1) at the
   * lobe-weighted mean half vectors h_P, h_H of the polygon and of the hemisphere (Eq. M1-M3).
   * The result cannot exceed the albedo (P lies in the hemisphere). */
  /* The bound of lecocq_weight: the lowest h'.z of the vertices' images. APPROXIMATION: the
   * region's lowest point is on its boundary (z is concave on great arcs in z >= 0), and the
   * image of an edge is a curve, not the great arc between its ends, which can dip below its
   * ends where it passes near wi = -wo; the vertices alone then overstate the minimum and lift a
   * direction the moments had put lower. Measured effect on the AUTO fingerprint's ordinary views
   * (GGX, training queries 4 and 5): LECOCQ's error 0.024 -> 0.007, PEARSON's 0.011 -> 0.006;
   * tests/area/lecocq_test.cpp's regression guards hold. */
  real hz_min = GLINT_R(1.0);
  for (int i = 0; i < nc; ++i) hz_min = fmin(hz_min, lecocq_to_h(w[i], wo, sx, sy).z);
  real3 wp = lecocq_weight(m, ax, ay, wo, accp, fmax(hz_min, GLINT_R(0.0)));
  real3 wh = lecocq_weight(m, ax, ay, wo, acch, GLINT_R(0.0));
  real e[GLINT_LTC_ENTRY];
  area_ltc_lookup(table, alpha, wo.z, e);
  real3 alb = area_ltc_albedo(m, e);
  return make_real3(wh.x > GLINT_R(0.0) ? fmin(alb.x * ratio * wp.x / wh.x, alb.x) : GLINT_R(0.0),
                    wh.y > GLINT_R(0.0) ? fmin(alb.y * ratio * wp.y / wh.y, alb.y) : GLINT_R(0.0),
                    wh.z > GLINT_R(0.0) ? fmin(alb.z * ratio * wp.z / wh.z, alb.z) : GLINT_R(0.0));
}

#endif /* GLINT_AREA_LECOCQ_H */
