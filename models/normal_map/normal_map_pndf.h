/* The P-NDF of a normal map under a Gaussian pixel footprint, blurred by a
 * Gaussian intrinsic roughness: Yan, Hasan, Jakob, Lawrence, Marschner and
 * Ramamoorthi 2014, "Rendering glints on high-resolution normal-mapped
 * specular surfaces" (YHJ14, /work/shared/papers/yan2014-pndf-normal-maps.md):
 *
 *   D(s) = int G_p(u) G_r(n(u) - s) du                               (Eq. 6-7)
 *
 * over the triangulated map (table layout: normal_map_params.h), (s, t)
 * linear on each triangle (Sec. 5). Per triangle the integrand is one 2D
 * Gaussian (Eq. 8); we integrate it as Eq. 9-11 do, the inner integral in
 * closed form (erf), the outer one
 *
 *   int exp(-kappa x^2 / 2) erf(alpha x + gamma) dx                    (Eq. 11)
 *
 * NOT with the paper's piecewise-quadratic erf (Eq. 12) but exactly where erf
 * is saturated (|alpha x + gamma| >= 4: erf = +-1 to 1.5e-8, leaving a
 * Gaussian integral in closed form) and by 4-point Gauss-Legendre on pieces
 * at most one erf unit and one Gaussian standard deviation wide in between.
 * models/normal_map/README.md gives the error measured against brute-force
 * quadrature and compares erf approximations.
 *
 * Pruning (Sec. 6): the min-max quadtree of (s, t); a node, cell or triangle
 * is skipped when its box is beyond cutoff * sigma_r of s in s or t, or
 * beyond the footprint's cutoff box (cutoff * the standard deviation along
 * u and along v). The traversal is depth first with an explicit stack in
 * private memory whose bound is proven in normal_map_params.h
 * (GLINT_NM_STACK); the map tiles uv space and each period copy the
 * footprint's box touches is traversed once.
 *
 * Coordinates: x = u W - 1/2, y = v H - 1/2 ("vertex coordinates"): vertex
 * (i, j) sits at (i, j), cell (i, j) is [i, i + 1] x [j, j + 1]. G_p is
 * normalised in these coordinates, so D is a density over the projected disk
 * (s, t) that integrates to 1 (minus the mass G_r puts outside the disk).
 *
 * One query per work-item (GLINT_LANES == 1): the traversal branches per
 * query. */
#ifndef GLINT_NORMAL_MAP_PNDF_H
#define GLINT_NORMAL_MAP_PNDF_H

#include "kernels/compat.h"
#include "models/normal_map/normal_map_params.h"

/* erf saturation: |erf(z)| = 1 - erfc(4) = 1 - 1.5e-8 beyond |z| = 4. */
#define GLINT_NM_ERF_SATURATION 4.0f
/* The Gaussian factor of Eq. 11 is exp(-24.5) = 2.3e-11 of its peak at 7 sigma. */
#define GLINT_NM_GAUSS_RANGE 7.0f
/* The large-footprint limit's weight (nm_footprint): a Gaussian this many
 * periods wide, normalised over one period. */
#define GLINT_NM_WIDE_SIGMA 100.0f
/* Gauss-Legendre pieces per outer integral (their count is at most 8 where
 * erf limits them and 14 where the Gaussian does). */
#define GLINT_NM_MAX_PIECES 16

typedef struct {
  real cx, cy;        /* footprint centre, vertex coordinates, within one period */
  real sxx, sxy, syy; /* inverse covariance of G_p */
  real pxx, pxy, pyy; /* covariance of G_p (vertex coordinates) */
  real pdet;          /* its determinant, without cancellation */
  int uniform;        /* 1: the large-footprint limit (nm_footprint): G_p uniform over a period */
  real box_x, box_y;  /* cutoff half-widths of G_p along x and y */
  real norm;          /* 1 / (2 pi sqrt(det Sigma_p)) * 1 / (2 pi sigma_r^2) */
  real s, t;          /* the queried normal's (s, t) */
  real rho;           /* 1 / sigma_r^2 */
  real cut_r;         /* cutoff * sigma_r */
  uint W, H, levels;
} NmQuery;

/* Counters of one evaluation (tests, benchmarks). */
typedef struct {
  uint triangles; /* integrated (not pruned) */
  uint nodes;     /* quadtree nodes visited */
  uint max_stack; /* deepest the stack got */
  uint overflow;  /* 1 if the stack bound were ever exceeded (never, by construction) */
} NmStats;

GLINT_FN uint nm_umin(uint a, uint b) {
  return a < b ? a : b;
}
GLINT_FN uint nm_umax(uint a, uint b) {
  return a > b ? a : b;
}

/* erf(b) - erf(a) for a <= b without cancellation in the tails. */
GLINT_FN real nm_erf_diff(real a, real b) {
  if (a > GLINT_R(0.0)) return erfc(a) - erfc(b);
  if (b < GLINT_R(0.0)) return erfc(-b) - erfc(-a);
  return erf(b) - erf(a);
}

/* int_a^b exp(-kappa x^2 / 2) dx */
GLINT_FN real nm_gauss_int(real kappa, real a, real b) {
  if (!(b > a)) return GLINT_R(0.0);
  real k = sqrt(GLINT_R(0.5) * kappa);
  return GLINT_SQRT_PI / (GLINT_R(2.0) * k) * nm_erf_diff(a * k, b * k);
}

/* Eq. 11: int_lo^hi exp(-kappa x^2 / 2) erf(alpha x + gamma) dx, with lo, hi
 * already inside the Gaussian's range. */
GLINT_FN real nm_exp_erf(real kappa, real alpha, real gamma, real lo, real hi) {
  if (!(hi > lo)) return GLINT_R(0.0);
  const real Z = GLINT_R(GLINT_NM_ERF_SATURATION);
  real sum = GLINT_R(0.0);
  real t0 = lo, t1 = hi; /* the transition interval, where |alpha x + gamma| < Z */
  real aa = fabs(alpha);
  if (aa > GLINT_R(1e-30)) {
    real xa = (-Z - gamma) / alpha, xb = (Z - gamma) / alpha;
    real za = fmin(xa, xb), zb = fmax(xa, xb);
    /* Left of the transition erf = -sign(alpha), right of it +sign(alpha). */
    real sgn = alpha > GLINT_R(0.0) ? GLINT_R(1.0) : GLINT_R(-1.0);
    sum -= sgn * nm_gauss_int(kappa, lo, fmin(hi, za));
    sum += sgn * nm_gauss_int(kappa, fmax(lo, zb), hi);
    t0 = fmax(lo, za);
    t1 = fmin(hi, zb);
  }
  if (!(t1 > t0)) return sum;
  /* Piece width: one erf unit (1 / |alpha|) and one Gaussian sigma (1 / sqrt(kappa)). */
  real width = fmin(GLINT_R(1.0) / fmax(aa, GLINT_R(1e-30)), GLINT_R(1.0) / sqrt(kappa));
  int pieces = (int)ceil((t1 - t0) / width);
  pieces = pieces < 1 ? 1 : (pieces > GLINT_NM_MAX_PIECES ? GLINT_NM_MAX_PIECES : pieces);
  real h = (t1 - t0) / (real)pieces;
  /* 4-point Gauss-Legendre on [-1, 1]. */
  const real n0 = GLINT_R(0.33998104358485626), n1 = GLINT_R(0.86113631159405258);
  const real w0 = GLINT_R(0.65214515486254614), w1 = GLINT_R(0.34785484513745386);
  for (int k = 0; k < pieces; ++k) {
    real mid = t0 + ((real)k + GLINT_R(0.5)) * h, hw = GLINT_R(0.5) * h;
    real acc = GLINT_R(0.0);
    real xs[4];
    xs[0] = mid - n1 * hw;
    xs[1] = mid - n0 * hw;
    xs[2] = mid + n0 * hw;
    xs[3] = mid + n1 * hw;
    for (int q = 0; q < 4; ++q) {
      real x = xs[q];
      real w = (q == 0 || q == 3) ? w1 : w0;
      acc += w * exp(GLINT_R(-0.5) * kappa * x * x) * erf(alpha * x + gamma);
    }
    sum += acc * hw;
  }
  return sum;
}

/* Eq. 8: int over the triangle P0 + a e1 + b e2 (a, b >= 0, a + b <= 1) of
 * G_p(x) G_r(n(x) - s) dx with n = n0 + a (n1 - n0) + b (n2 - n0), without
 * the normalisation constant (q.norm). Vertex coordinates are relative to the
 * footprint centre (d0 = P0 - c). */
GLINT_FN real nm_triangle(NmQuery q, real d0x, real d0y, real e1x, real e1y, real e2x, real e2y,
                          real n0s, real n0t, real n1s, real n1t, real n2s, real n2t) {
  /* Q(w) = (d0 + E w)^T S (d0 + E w) + rho |m0 + F w|^2, w = (a, b). */
  real m0s = n0s - q.s, m0t = n0t - q.t;
  real f1s = n1s - n0s, f1t = n1t - n0t, f2s = n2s - n0s, f2t = n2t - n0t;
  /* X = E^T S E */
  real Se1x = q.sxx * e1x + q.sxy * e1y, Se1y = q.sxy * e1x + q.syy * e1y;
  real Se2x = q.sxx * e2x + q.sxy * e2y, Se2y = q.sxy * e2x + q.syy * e2y;
  real x11 = e1x * Se1x + e1y * Se1y, x12 = e1x * Se2x + e1y * Se2y, x22 = e2x * Se2x + e2y * Se2y;
  /* Y = rho F^T F */
  real y11 = q.rho * (f1s * f1s + f1t * f1t), y12 = q.rho * (f1s * f2s + f1t * f2t),
       y22 = q.rho * (f2s * f2s + f2t * f2t);
  real p = x11 + y11, r = x12 + y12, qq = x22 + y22;
  /* det(X + Y) = det X + det Y + tr(adj(X) Y), each term without cancellation
   * between a large rank-1 Y (sigma_r small, normals varying in one direction)
   * and X: det E^2 det S, rho^2 det F^2 computed from their factors. */
  real detE = e1x * e2y - e1y * e2x, detF = f1s * f2t - f1t * f2s;
  real detS = q.sxx * q.syy - q.sxy * q.sxy;
  real detA = detE * detE * detS + q.rho * q.rho * detF * detF +
              (x22 * y11 - GLINT_R(2.0) * x12 * y12 + x11 * y22);
  if (!(detA > GLINT_R(0.0)) || !(p > GLINT_R(0.0))) return GLINT_R(0.0);
  /* g = E^T S d0 + rho F^T m0 */
  real g1 = Se1x * d0x + Se1y * d0y + q.rho * (f1s * m0s + f1t * m0t);
  real g2 = Se2x * d0x + Se2y * d0y + q.rho * (f2s * m0s + f2t * m0t);
  /* Minimum w* = -A^-1 g. */
  real wa = -(qq * g1 - r * g2) / detA, wb = -(p * g2 - r * g1) / detA;
  /* Q(w*) from its residuals (no cancellation of large terms). */
  real ux = d0x + e1x * wa + e2x * wb, uy = d0y + e1y * wa + e2y * wb;
  real ns = m0s + f1s * wa + f2s * wb, nt = m0t + f1t * wa + f2t * wb;
  real qmin =
      ux * (q.sxx * ux + q.sxy * uy) + uy * (q.sxy * ux + q.syy * uy) + q.rho * (ns * ns + nt * nt);
  /* The simplex is symmetric in (a, b): integrate the variable of larger
   * curvature innermost. */
  if (qq > p) {
    real tmp = p;
    p = qq;
    qq = tmp;
    tmp = wa;
    wa = wb;
    wb = tmp;
  }
  /* Q = p (a - a*(b))^2 + kappa (b - wb)^2 + qmin, a*(b) = wa - (r / p)(b - wb).
   * Inner (Eq. 9-10): int_0^{1-b} exp(-p (a - a*)^2 / 2) da
   *   = sqrt(pi / (2 p)) [erf(z1(b)) - erf(z0(b))], with x = b - wb:
   *   z1 = sqrt(p/2) ((1 - wa - wb) + (r/p - 1) x), z0 = sqrt(p/2) (-wa + (r/p) x). */
  real kappa = detA / p;
  real k2 = sqrt(GLINT_R(0.5) * p);
  real rp = r / p;
  real lo = -wb, hi = GLINT_R(1.0) - wb;
  real reach = GLINT_R(GLINT_NM_GAUSS_RANGE) / sqrt(kappa);
  lo = fmax(lo, -reach);
  hi = fmin(hi, reach);
  if (!(hi > lo)) return GLINT_R(0.0);
  real outer = nm_exp_erf(kappa, k2 * (rp - GLINT_R(1.0)), k2 * (GLINT_R(1.0) - wa - wb), lo, hi) -
               nm_exp_erf(kappa, k2 * rp, -k2 * wa, lo, hi);
  real value = exp(GLINT_R(-0.5) * qmin) * GLINT_SQRT_PI / (GLINT_R(2.0) * k2) * outer * fabs(detE);
  return fmax(value, GLINT_R(0.0));
}

/* (s, t) of vertex (i, j) (indices taken mod W, H). */
GLINT_FN void nm_vertex(const GLINT_GLOBAL float *table, uint W, uint H, uint i, uint j, real *s,
                        real *t) {
  uint ii = i >= W ? i - W : i, jj = j >= H ? j - H : j;
  const GLINT_GLOBAL float *v = table + GLINT_NM_HEADER_FLOATS + 2u * (jj * W + ii);
  *s = (real)v[0];
  *t = (real)v[1];
}

/* Is the box [lo, hi] of s and t beyond the cutoff of G_r around (q.s, q.t)? */
GLINT_FN int nm_normal_culled(NmQuery q, real smin, real smax, real tmin, real tmax) {
  return (q.s < smin - q.cut_r) | (q.s > smax + q.cut_r) | (q.t < tmin - q.cut_r) |
         (q.t > tmax + q.cut_r);
}

/* Is the rectangle [x0, x1] x [y0, y1] beyond the footprint's cutoff box? */
GLINT_FN int nm_space_culled(NmQuery q, real x0, real x1, real y0, real y1) {
  return (x1 < q.cx - q.box_x) | (x0 > q.cx + q.box_x) | (y1 < q.cy - q.box_y) |
         (y0 > q.cy + q.box_y);
}

/* The two triangles of cell (i, j): lower (v00, v10, v01), upper (v11, v01, v10). */
GLINT_FN real nm_cell(const GLINT_GLOBAL float *table, NmQuery q, uint i, uint j,
                      GLINT_PRIVATE NmStats *stats) {
  real s00, t00, s10, t10, s01, t01, s11, t11;
  nm_vertex(table, q.W, q.H, i, j, &s00, &t00);
  nm_vertex(table, q.W, q.H, i + 1u, j, &s10, &t10);
  nm_vertex(table, q.W, q.H, i, j + 1u, &s01, &t01);
  nm_vertex(table, q.W, q.H, i + 1u, j + 1u, &s11, &t11);
  real x = (real)i - q.cx, y = (real)j - q.cy;
  real sum = GLINT_R(0.0);
  real smin = fmin(s00, fmin(s10, s01)), smax = fmax(s00, fmax(s10, s01));
  real tmin = fmin(t00, fmin(t10, t01)), tmax = fmax(t00, fmax(t10, t01));
  if (!nm_normal_culled(q, smin, smax, tmin, tmax)) {
    stats->triangles += 1u;
    sum += nm_triangle(q, x, y, GLINT_R(1.0), GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0), s00, t00,
                       s10, t10, s01, t01);
  }
  smin = fmin(s11, fmin(s10, s01));
  smax = fmax(s11, fmax(s10, s01));
  tmin = fmin(t11, fmin(t10, t01));
  tmax = fmax(t11, fmax(t10, t01));
  if (!nm_normal_culled(q, smin, smax, tmin, tmax)) {
    stats->triangles += 1u;
    sum += nm_triangle(q, x + GLINT_R(1.0), y + GLINT_R(1.0), GLINT_R(-1.0), GLINT_R(0.0),
                       GLINT_R(0.0), GLINT_R(-1.0), s11, t11, s01, t01, s10, t10);
  }
  return sum;
}

/* Sec. 6: depth-first traversal of the min-max quadtree for one period copy
 * (q.cx, q.cy already shifted into it). */
GLINT_FN real nm_traverse(const GLINT_GLOBAL float *table, NmQuery q,
                          GLINT_PRIVATE NmStats *stats) {
  uint W = q.W, H = q.H, levels = q.levels;
  if (levels <= 1u) { /* a single cell */
    stats->nodes += 1u;
    if (nm_space_culled(q, GLINT_R(0.0), GLINT_R(1.0), GLINT_R(0.0), GLINT_R(1.0)))
      return GLINT_R(0.0);
    return nm_cell(table, q, 0u, 0u, stats);
  }
  /* Level offsets (level 1 first, after the vertices). */
  uint level_offset[GLINT_NM_MAX_LEVELS];
  uint offset = GLINT_NM_HEADER_FLOATS + 2u * W * H;
  for (uint k = 1u; k < levels; ++k) {
    level_offset[k] = offset;
    uint nw = (W + (1u << k) - 1u) >> k, nh = (H + (1u << k) - 1u) >> k;
    offset += 4u * nw * nh;
  }
  /* Stack entries: x, and y | level << 24 (y < 2^24, level < 32). */
  uint stack_x[GLINT_NM_STACK];
  uint stack_yk[GLINT_NM_STACK];
  uint sp = 0u;
  stack_x[0] = 0u;
  stack_yk[0] = (levels - 1u) << 24;
  sp = 1u;
  real sum = GLINT_R(0.0);
  while (sp > 0u) {
    sp -= 1u;
    uint x = stack_x[sp], k = stack_yk[sp] >> 24, y = stack_yk[sp] & 0xffffffu;
    stats->nodes += 1u;
    uint nw = (W + (1u << k) - 1u) >> k;
    const GLINT_GLOBAL float *b = table + level_offset[k] + 4u * (y * nw + x);
    real x0 = (real)(x << k), y0 = (real)(y << k);
    real x1 = (real)nm_umin((x + 1u) << k, W), y1 = (real)nm_umin((y + 1u) << k, H);
    if (nm_space_culled(q, x0, x1, y0, y1) |
        nm_normal_culled(q, (real)b[0], (real)b[1], (real)b[2], (real)b[3]))
      continue;
    uint cw = (W + (1u << (k - 1u)) - 1u) >> (k - 1u), ch = (H + (1u << (k - 1u)) - 1u) >> (k - 1u);
    for (uint c = 0u; c < 4u; ++c) {
      uint chx = 2u * x + (c & 1u), chy = 2u * y + (c >> 1);
      if (chx >= cw || chy >= ch) continue;
      if (k == 1u) { /* children are cells */
        if (nm_space_culled(q, (real)chx, (real)chx + GLINT_R(1.0), (real)chy,
                            (real)chy + GLINT_R(1.0)))
          continue;
        sum += nm_cell(table, q, chx, chy, stats);
      } else if (sp < GLINT_NM_STACK) {
        stack_x[sp] = chx;
        stack_yk[sp] = chy | ((k - 1u) << 24);
        sp += 1u;
        stats->max_stack = nm_umax(stats->max_stack, sp);
      } else {
        stats->overflow = 1u;
      }
    }
  }
  return sum;
}

/* The footprint part of a query: G_p of the footprint at uv with Jacobian
 * fp = (du/dx, dv/dx, du/dy, dv/dy) in vertex coordinates (its covariance,
 * inverse covariance and cut-off box, clamped to GLINT_NM_MAX_PERIODS
 * periods), the map's size, and the period copies k[0..3] = (kx0, kx1, ky0,
 * ky1) the cut-off box touches. q.norm holds G_p's normalisation only. Shared
 * by the P-NDF (nm_pndf) and its sampler (normal_map_sample.h), so both see
 * the same G_p. */
GLINT_FN NmQuery nm_footprint(const GLINT_GLOBAL float *table, real u, real v, const real *fp,
                              real cutoff, GLINT_PRIVATE int *k) {
  uint W = (uint)table[0], H = (uint)table[1];
  NmQuery q;
  q.W = W;
  q.H = H;
  q.levels = (uint)table[2];
  /* G_p: covariance sigma_pix^2 J J^T in uv (J's columns: d(uv)/dx, d(uv)/dy),
   * scaled to vertex coordinates, plus a floor that keeps it proper. */
  real Wr = (real)W, Hr = (real)H;
  real sp2 = GLINT_R(GLINT_NM_PIXEL_SIGMA) * GLINT_R(GLINT_NM_PIXEL_SIGMA);
  real ax = fp[0] * Wr, ay = fp[1] * Hr, bx = fp[2] * Wr, by = fp[3] * Hr;
  real floor2 = GLINT_R(GLINT_NM_MIN_FOOTPRINT_SIGMA) * GLINT_R(GLINT_NM_MIN_FOOTPRINT_SIGMA);
  real c0xx = sp2 * (ax * ax + bx * bx), c0yy = sp2 * (ay * ay + by * by);
  real cxy = sp2 * (ax * ay + bx * by);
  /* det(C0 + f I) = det C0 + f tr C0 + f^2 with det C0 = sp2^2 det(J)^2: no
   * cancellation for thin (rank-1) footprints. */
  real detJ = ax * by - ay * bx;
  real det = sp2 * sp2 * detJ * detJ + floor2 * (c0xx + c0yy) + floor2 * floor2;
  real cxx = c0xx + floor2, cyy = c0yy + floor2;
  /* Not finite (NaN or overflowing footprints): the large-footprint limit. */
  int bad = !(isfinite(cxx) & isfinite(cyy) & isfinite(cxy) & isfinite(det));
  cxx = bad ? Wr * Wr : cxx;
  cyy = bad ? Hr * Hr : cyy;
  cxy = bad ? GLINT_R(0.0) : cxy;
  det = bad ? Wr * Wr * Hr * Hr : det;
  q.uniform = 0;
  /* The large-footprint limit: a Gaussian at least one period wide along both
   * axes (sigma_x >= W, sigma_y >= H vertex spacings) wrapped onto the periodic
   * map is uniform to within sum_{m != 0} exp(-2 pi^2 m^2 sigma^2 / W^2)
   * <= 2 e^{-2 pi^2} / (1 - e^{-6 pi^2}) = 5.4e-9 per axis (its Fourier series),
   * so D is the map's global NDF convolved with G_r: one traversal of one period
   * weighted uniformly. The weight is a Gaussian GLINT_NM_WIDE_SIGMA periods wide
   * about the period's centre, normalised over the period in closed form, so
   * the triangle integrals stay those of Eq. 8-11; it varies by at most
   * 1 - exp(-(1/4 + 1/4) / (2 GLINT_NM_WIDE_SIGMA^2)) = 2.5e-5 across the period.
   * Narrower footprints keep the clamp below (shape kept). */
  if (cxx >= Wr * Wr && cyy >= Hr * Hr) {
    real sb = GLINT_R(GLINT_NM_WIDE_SIGMA) * fmax(Wr, Hr);
    q.uniform = 1;
    q.pxx = sb * sb;
    q.pyy = sb * sb;
    q.pxy = GLINT_R(0.0);
    q.pdet = q.pxx * q.pyy;
    q.sxx = GLINT_R(1.0) / q.pxx;
    q.syy = q.sxx;
    q.sxy = GLINT_R(0.0);
    q.cx = GLINT_R(0.5) * Wr;
    q.cy = GLINT_R(0.5) * Hr;
    q.box_x = GLINT_R(0.5) * Wr + GLINT_R(1.0);
    q.box_y = GLINT_R(0.5) * Hr + GLINT_R(1.0);
    /* int over the period of exp(-|x - c|^2 / (2 sb^2)) dx */
    real zx = GLINT_R(0.5) * Wr / (sb * GLINT_R(1.41421356237309504880)),
         zy = GLINT_R(0.5) * Hr / (sb * GLINT_R(1.41421356237309504880));
    q.norm = GLINT_R(1.0) / (GLINT_R(2.0) * GLINT_PI * sb * sb * erf(zx) * erf(zy));
    k[0] = 0;
    k[1] = 0;
    k[2] = 0;
    k[3] = 0;
    return q;
  }
  /* At most GLINT_NM_MAX_PERIODS periods inside the cutoff box: shrink the
   * covariance (shape kept) where the box would be wider. */
  real lim = GLINT_R(0.5) * GLINT_R(GLINT_NM_MAX_PERIODS) / cutoff;
  real shrink = fmin(GLINT_R(1.0), fmin(lim * lim * Wr * Wr / cxx, lim * lim * Hr * Hr / cyy));
  cxx *= shrink;
  cyy *= shrink;
  cxy *= shrink;
  det *= shrink * shrink;
  q.pxx = cxx;
  q.pyy = cyy;
  q.pxy = cxy;
  q.pdet = det;
  q.sxx = cyy / det;
  q.syy = cxx / det;
  q.sxy = -cxy / det;
  q.box_x = cutoff * sqrt(cxx);
  q.box_y = cutoff * sqrt(cyy);
  q.norm = GLINT_R(1.0) / (GLINT_R(2.0) * GLINT_PI * sqrt(det));
  /* uv of 1e7 and beyond: keep the fraction (the map tiles uv space). */
  real fu = u - floor(u), fv = v - floor(v);
  q.cx = fu * Wr - GLINT_R(0.5);
  q.cy = fv * Hr - GLINT_R(0.5);
  k[0] = (int)floor((q.cx - q.box_x) / Wr);
  k[1] = (int)floor((q.cx + q.box_x) / Wr);
  k[2] = (int)floor((q.cy - q.box_y) / Hr);
  k[3] = (int)floor((q.cy + q.box_y) / Hr);
  return q;
}

/* D(s, t) of the footprint query fq (nm_footprint, with its period copies
 * k): Eq. 6 over every period copy of the map the footprint's cutoff box
 * touches. */
GLINT_FN real nm_pndf_footprint(const GLINT_GLOBAL float *table, NmQuery fq, const int *k, real s,
                                real t, real sigma_r, real cutoff, GLINT_PRIVATE NmStats *stats) {
  NmQuery q = fq;
  q.s = s;
  q.t = t;
  q.rho = GLINT_R(1.0) / (sigma_r * sigma_r);
  q.cut_r = cutoff * sigma_r;
  q.norm = fq.norm / (GLINT_R(2.0) * GLINT_PI * sigma_r * sigma_r);
  real Wr = (real)q.W, Hr = (real)q.H;
  real sum = GLINT_R(0.0);
  for (int ky = k[2]; ky <= k[3]; ++ky) {
    for (int kx = k[0]; kx <= k[1]; ++kx) {
      q.cx = fq.cx - (real)kx * Wr;
      q.cy = fq.cy - (real)ky * Hr;
      sum += nm_traverse(table, q, stats);
    }
  }
  return sum * q.norm;
}

/* D(s, t) for the footprint at uv with Jacobian fp = (du/dx, dv/dx, du/dy,
 * dv/dy). */
GLINT_FN real nm_pndf(const GLINT_GLOBAL float *table, real u, real v, const real *fp, real s,
                      real t, real sigma_r, real cutoff, GLINT_PRIVATE NmStats *stats) {
  int k[4];
  NmQuery q = nm_footprint(table, u, v, fp, cutoff, k);
  return nm_pndf_footprint(table, q, k, s, t, sigma_r, cutoff, stats);
}

#endif /* GLINT_NORMAL_MAP_PNDF_H */
