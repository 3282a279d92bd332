/* A polygon light's image in U, the unit square holding the disk image of the
 * NDF (models/kemppinen/kemppinen_ndf.h), for the Kemppinen model's polygon
 * lights (models/kemppinen/kemppinen_polygons.h); beyond K25, which has point
 * lights and environment maps only.
 *
 * A direction wi of the light reflects towards wo through the facet normal
 * h = (wi + wo) / |.|, which T maps to x = T(h) in U. The light's image R is
 * the set of these x: a facet whose Gaussian lobe (Eq. 4) is centred at g
 * reflects the light with the lobe's mass over R. Here R is approximated by a
 * polygon: each (horizon-clipped) edge of the light is split into
 * GLINT_KEMPPINEN_IMAGE_SUBDIV arcs and the arcs' ends mapped by T; straight
 * edges between them (the image of a great-circle arc curves).
 *
 * One query per work-item (GLINT_LANES == 1): clipping branches per query. */
#ifndef GLINT_KEMPPINEN_IMAGE_H
#define GLINT_KEMPPINEN_IMAGE_H

#include "kernels/area/area_lights.h"
#include "kernels/area/polygon.h"
#include "models/kemppinen/kemppinen_ndf.h"

#define GLINT_KEMPPINEN_IMAGE_SUBDIV 2
#define GLINT_KEMPPINEN_IMAGE_MAX (GLINT_KEMPPINEN_IMAGE_SUBDIV * GLINT_POLYGON_MAX_CLIPPED)
/* Clipping a convex polygon to a rectangle adds at most 4 vertices. */
#define GLINT_KEMPPINEN_IMAGE_CLIP_MAX (GLINT_KEMPPINEN_IMAGE_MAX + 4)

/* A polygon in U, counter-clockwise, with its area and centroid. */
typedef struct {
  int n;
  real x[GLINT_KEMPPINEN_IMAGE_CLIP_MAX], y[GLINT_KEMPPINEN_IMAGE_CLIP_MAX];
  real area, cx, cy;
  /* Every turn counter-clockwise (kemppinen_upoly_finish). Not always so: at
   * grazing views the images of a large light's edges bend inwards (16% of
   * the bench's 90-degree quad), and a test "beyond one edge's line, so
   * outside R" holds only for convex R. */
  int convex;
} KemppinenUPolygon;

/* Shoelace area and centroid; orders the vertices counter-clockwise. */
GLINT_FN void kemppinen_upoly_finish(GLINT_PRIVATE KemppinenUPolygon *P) {
  real a = GLINT_R(0.0), mx = GLINT_R(0.0), my = GLINT_R(0.0);
  for (int k = 0; k < P->n; ++k) {
    int j = (k + 1) % P->n;
    real c = P->x[k] * P->y[j] - P->x[j] * P->y[k];
    a += c;
    mx += (P->x[k] + P->x[j]) * c;
    my += (P->y[k] + P->y[j]) * c;
  }
  if (a < GLINT_R(0.0)) {
    for (int k = 0; k < P->n / 2; ++k) {
      int j = P->n - 1 - k;
      real tx = P->x[k], ty = P->y[k];
      P->x[k] = P->x[j];
      P->y[k] = P->y[j];
      P->x[j] = tx;
      P->y[j] = ty;
    }
  }
  P->convex = 1;
  for (int k = 0; k < P->n; ++k) {
    int j = (k + 1) % P->n, i = (k + 2) % P->n;
    real turn =
        (P->x[j] - P->x[k]) * (P->y[i] - P->y[j]) - (P->y[j] - P->y[k]) * (P->x[i] - P->x[j]);
    if (turn < GLINT_R(0.0)) P->convex = 0;
  }
  P->area = GLINT_R(0.5) * fabs(a);
  real ok = fabs(a) > GLINT_R(1e-30) ? GLINT_R(1.0) : GLINT_R(0.0);
  /* Degenerate (area 0): the vertex mean stands for the centroid. */
  real sx = GLINT_R(0.0), sy = GLINT_R(0.0);
  for (int k = 0; k < P->n; ++k) {
    sx += P->x[k];
    sy += P->y[k];
  }
  real inv_n = P->n > 0 ? GLINT_R(1.0) / (real)P->n : GLINT_R(0.0);
  P->cx = ok > GLINT_R(0.0) ? mx / (GLINT_R(3.0) * a) : sx * inv_n;
  P->cy = ok > GLINT_R(0.0) ? my / (GLINT_R(3.0) * a) : sy * inv_n;
}

/* T(h(wi)) for a light direction d (any length) seen from wo. */
GLINT_FN DiskPoint kemppinen_image_point(int ndf, real ax, real ay, real3 wo, real3 d) {
  real3 up = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  real3 h = area_safe_normalize(r3_add(area_safe_normalize(d, up), wo), up);
  return kemppinen_to_disk(ndf, h, ax, ay, ndf_D(ndf, h, ax, ay));
}

/* The light's image R (see the header comment) from its vertices v (local
 * frame, relative to the shading point); n = 0 when the light lies below the
 * horizon. */
GLINT_FN KemppinenUPolygon kemppinen_image(int ndf, real ax, real ay, real3 wo,
                                           const GLINT_PRIVATE real3 *v, int nv) {
  KemppinenUPolygon P;
  real3 w[GLINT_POLYGON_MAX_CLIPPED];
  int nc = polygon_clip_to_horizon(v, nv, w);
  P.n = 0;
  real3 up = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  for (int k = 0; k < nc; ++k) {
    real3 a = area_safe_normalize(w[k], up), b = area_safe_normalize(w[(k + 1) % nc], up);
    for (int s = 0; s < GLINT_KEMPPINEN_IMAGE_SUBDIV; ++s) {
      /* A point of the arc a -> b (a itself for s = 0). */
      real t = (real)s / (real)GLINT_KEMPPINEN_IMAGE_SUBDIV;
      real3 d = r3_add(r3_scale(a, GLINT_R(1.0) - t), r3_scale(b, t));
      DiskPoint x = kemppinen_image_point(ndf, ax, ay, wo, d);
      P.x[P.n] = x.x;
      P.y[P.n] = x.y;
      ++P.n;
    }
  }
  kemppinen_upoly_finish(&P);
  if (nc < 3) {
    P.n = 0;
    P.area = GLINT_R(0.0);
  }
  return P;
}

/* Sutherland-Hodgman clip of P to the half-plane s * coord <= s * bound
 * (coord = x for axis 0, y for axis 1; s = +1 or -1), in place. */
GLINT_FN void kemppinen_upoly_clip(GLINT_PRIVATE KemppinenUPolygon *P, int axis, real bound,
                                   real s) {
  real ox[GLINT_KEMPPINEN_IMAGE_CLIP_MAX], oy[GLINT_KEMPPINEN_IMAGE_CLIP_MAX];
  int m = 0;
  for (int k = 0; k < P->n; ++k) {
    int j = (k + 1) % P->n;
    real ca = axis == 0 ? P->x[k] : P->y[k], cb = axis == 0 ? P->x[j] : P->y[j];
    real da = s * (bound - ca), db = s * (bound - cb); /* >= 0 inside */
    if (da >= GLINT_R(0.0) && m < GLINT_KEMPPINEN_IMAGE_CLIP_MAX) {
      ox[m] = P->x[k];
      oy[m] = P->y[k];
      ++m;
    }
    if ((da >= GLINT_R(0.0)) != (db >= GLINT_R(0.0)) && m < GLINT_KEMPPINEN_IMAGE_CLIP_MAX) {
      real t = da / (da - db);
      ox[m] = P->x[k] + t * (P->x[j] - P->x[k]);
      oy[m] = P->y[k] + t * (P->y[j] - P->y[k]);
      ++m;
    }
  }
  P->n = m;
  for (int k = 0; k < m; ++k) {
    P->x[k] = ox[k];
    P->y[k] = oy[k];
  }
}

/* R intersected with the rectangle [x0, x1] x [y0, y1] (area and centroid). */
GLINT_FN KemppinenUPolygon kemppinen_image_clip_rect(KemppinenUPolygon R, real x0, real x1, real y0,
                                                     real y1) {
  KemppinenUPolygon P = R;
  kemppinen_upoly_clip(&P, 0, x0, GLINT_R(-1.0));
  kemppinen_upoly_clip(&P, 0, x1, GLINT_R(1.0));
  kemppinen_upoly_clip(&P, 1, y0, GLINT_R(-1.0));
  kemppinen_upoly_clip(&P, 1, y1, GLINT_R(1.0));
  kemppinen_upoly_finish(&P);
  if (P.n < 3) P.area = GLINT_R(0.0);
  return P;
}

/* Lobe standard deviations beyond which a Gaussian tail is dropped:
 * exp(-5.7^2 / 2) / 2 = 4e-8, below the fp32 resolution of a mass ~1. */
#define GLINT_KEMPPINEN_FAR_SIGMAS 5.7

/* Longest piece (lobe standard deviations) of the block mass's line integral
 * that one 8-point Gauss-Legendre rule takes (kemppinen_image_block_mass):
 * one side of a transition, GLINT_KEMPPINEN_FAR_SIGMAS. */
#define GLINT_KEMPPINEN_GL_SPAN 5.7

/* 8-point Gauss-Legendre on [-1, 1] (Abramowitz & Stegun Table 25.4). */
GLINT_FN real kemppinen_gl8_node(int k) {
  const real x[4] = {GLINT_R(0.1834346424956498), GLINT_R(0.5255324099163290),
                     GLINT_R(0.7966664774136267), GLINT_R(0.9602898564975363)};
  return k < 4 ? -x[3 - k] : x[k - 4];
}
GLINT_FN real kemppinen_gl8_weight(int k) {
  const real w[4] = {GLINT_R(0.3626837833783620), GLINT_R(0.3137066458778873),
                     GLINT_R(0.2223810344533745), GLINT_R(0.1012285362903763)};
  return k < 4 ? w[3 - k] : w[k - 4];
}

/* Owen's T function (Owen 1956) for h >= 0, 0 <= a <= 1:
 *   T(h, a) = 1/(2 pi) int_0^a exp(-h^2 (1 + x^2) / 2) / (1 + x^2) dx,
 * by 5-point Gauss-Legendre (A&S Table 25.4). The integrand is smooth on
 * [0, 1]: its width in x is ~1/h, and for h > 5.7 the whole integral is below
 * exp(-h^2 / 2) / 4 = 4e-8. Against a 64-panel 20-point Gauss-Legendre
 * reference in long double on the grid h = 0 (0.05) 5.7, a = 0.01 (0.01) 1
 * the largest absolute error of n points is 7.7e-7 (n = 4), 1.9e-8 (5),
 * 2.0e-9 (6), 2.8e-12 (8), at a = 1, h ~ 1-3 (where the integrand is neither
 * flat nor negligible): 5 points are below the A&S erfc's 1.5e-7 that the
 * same masses carry (kemppinen_image_lines.h), for 5 exps instead of 8 (the
 * polygon pass's largest cost for lights whose image is a few lobes wide). */
GLINT_FN real kemppinen_owen_t_small(real h, real a) {
  /* T(h, a) <= exp(-h^2 / 2) / 4 (a <= 1): below 4e-8 beyond h = 5.7. */
  if (h > GLINT_R(5.7)) return GLINT_R(0.0);
  const real xn[3] = {GLINT_R(0.0), GLINT_R(0.5384693101056830910), GLINT_R(0.9061798459386639928)};
  const real wn[3] = {GLINT_R(0.5688888888888888889), GLINT_R(0.4786286704993664680),
                      GLINT_R(0.2369268850561890875)};
  real hh = GLINT_R(-0.5) * h * h, ha = GLINT_R(0.5) * a;
  real q0 = GLINT_R(1.0) + ha * ha;
  real sum = wn[0] * exp(hh * q0) / q0;
  for (int k = 1; k < 3; ++k) {
    real xl = ha * (GLINT_R(1.0) - xn[k]), xh = ha * (GLINT_R(1.0) + xn[k]);
    real ql = GLINT_R(1.0) + xl * xl, qh = GLINT_R(1.0) + xh * xh;
    sum += wn[k] * (exp(hh * ql) / ql + exp(hh * qh) / qh);
  }
  return sum * ha * GLINT_R(0.15915494309189533577);
}

/* Owen's T for h >= 0, a >= 0; a > 1 by Owen's identity
 *   T(h, a) + T(a h, 1/a) = (Phi(h) Q(a h) + Phi(a h) Q(h)) / 2,  Q = 1 - Phi,
 * written with tails (Q from erfc) so nothing cancels; qh = Q(h), which the
 * polygon pass has once per edge for both ends (kemppinen_lines_tc). */
GLINT_FN real kemppinen_owen_t_q(real h, real a, real qh) {
  if (a <= GLINT_R(1.0)) return kemppinen_owen_t_small(h, a);
  real qah = GLINT_R(0.5) * kemppinen_erfc_abs(a * h);
  return GLINT_R(0.5) * ((GLINT_R(1.0) - qh) * qah + (GLINT_R(1.0) - qah) * qh) -
         kemppinen_owen_t_small(a * h, GLINT_R(1.0) / a);
}

/* Owen's T without Q(h) at hand. */
GLINT_FN real kemppinen_owen_t(real h, real a) {
  return kemppinen_owen_t_q(h, a, GLINT_R(0.5) * kemppinen_erfc_abs(h));
}

/* Standard normal mass of the right triangle with the apex at the origin,
 * the right angle at distance h > 0 and the other leg t (signed: the mass is
 * odd in t): atan(|t| / h) / (2 pi) - T(h, |t| / h) (the wedge below the
 * hypotenuse minus its part beyond the leg x = h). */
GLINT_FN real kemppinen_right_triangle_mass(real h, real t) {
  real at = fabs(t);
  if (!(at > GLINT_R(0.0))) return GLINT_R(0.0);
  real m = atan2(at, h) * GLINT_R(0.15915494309189533577) - kemppinen_owen_t(h, at / h);
  return t < GLINT_R(0.0) ? -m : m;
}

/* The mass over R of the facet lobe N(x - g; diag(sx^2, sy^2)): in whitened
 * coordinates (the lobe the standard normal at the origin) the sum over R's
 * edges (a, b) of the signed masses of the triangles (origin, a, b), each the
 * difference of two right triangles at the foot of the perpendicular
 * (kemppinen_right_triangle_mass). For an edge farther than
 * GLINT_KEMPPINEN_FAR_SIGMAS the Owen's T parts are below exp(-FAR^2 / 2) / 2
 * and the triangle's mass is its angle / 2 pi (atan2, no T). Exact up to the quadrature of Owen's T
 * (tested against Monte Carlo), and g on R's boundary gives the interior angle / 2 pi (1/2 on an
 * edge): a facet costs an atan2 per far edge and two T per near edge. The polygon pass uses the
 * cheaper kemppinen_lines_mass (kemppinen_image_lines.h), which falls back on this sum for a
 * facet at one of R's vertices. */
GLINT_FN real kemppinen_image_mass_triangles(const GLINT_PRIVATE KemppinenUPolygon *R, real gx,
                                             real gy, real sx, real sy) {
  real isx = GLINT_R(1.0) / sx, isy = GLINT_R(1.0) / sy;
  /* Far inside every edge (in R's kernel, the intersection of the edges'
   * inner half-planes, inside R whatever its shape) or, R convex, far beyond
   * one: 1 or 0 (the rest below exp(-FAR^2 / 2) / 2 per edge) without the
   * sum. */
  real dmin = GLINT_R(1e30);
  for (int k = 0; k < R->n; ++k) {
    int j = (k + 1) % R->n;
    real ex = (R->x[j] - R->x[k]) * isx, ey = (R->y[j] - R->y[k]) * isy;
    real len = sqrt(ex * ex + ey * ey);
    if (!(len > GLINT_R(0.0))) continue;
    real d = (ex * (gy - R->y[k]) * isy - ey * (gx - R->x[k]) * isx) / len;
    if (d < -GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS) && R->convex) return GLINT_R(0.0);
    dmin = fmin(dmin, d);
  }
  if (dmin > GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS)) return GLINT_R(1.0);
  real mass = GLINT_R(0.0);
  for (int k = 0; k < R->n; ++k) {
    int j = (k + 1) % R->n;
    real ax = (R->x[k] - gx) * isx, ay = (R->y[k] - gy) * isy;
    real bx = (R->x[j] - gx) * isx, by = (R->y[j] - gy) * isy;
    real ex = bx - ax, ey = by - ay;
    real len = sqrt(ex * ex + ey * ey);
    if (!(len > GLINT_R(0.0))) continue;
    ex /= len;
    ey /= len;
    /* Signed distance of g to the edge's line, > 0 inside (R is ccw):
     * (a - g) x e, also the orientation of the triangle (g, a, b). */
    real d = ax * ey - ay * ex;
    real h = fabs(d);
    if (!(h > GLINT_R(1e-20))) continue; /* g on the edge's line: a degenerate triangle */
    real m;
    if (h > GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS)) {
      m = atan2(fabs(ax * by - ay * bx), ax * bx + ay * by) * GLINT_R(0.15915494309189533577);
    } else {
      real ta = ax * ex + ay * ey, tb = bx * ex + by * ey; /* along the line from the foot */
      m = kemppinen_right_triangle_mass(h, tb) - kemppinen_right_triangle_mass(h, ta);
    }
    mass += d >= GLINT_R(0.0) ? m : -m;
  }
  return clamp(mass, GLINT_R(0.0), GLINT_R(1.0));
}

/* psi(z) = z Phi(z) + phi(z), the antiderivative of the standard normal CDF,
 * from the tail Phi(-|z|) so that psi(z) -> z (z >> 0) and -> 0 (z << 0)
 * without cancellation in the tail. */
/* Phi(-|z|) and phi(z) from one exp (kemppinen_erfc_abs_poly). */
typedef struct {
  real tail, phi;
} KemppinenNormal;

GLINT_FN KemppinenNormal kemppinen_normal(real z) {
  real y = fabs(z) * GLINT_R(0.70710678118654752440);
  real g = exp(-y * y);
  KemppinenNormal r;
  r.tail = GLINT_R(0.5) * kemppinen_erfc_abs_poly(z) * g;
  r.phi = GLINT_R(0.39894228040143267794) * g;
  return r;
}

GLINT_FN real kemppinen_psi(real z) {
  KemppinenNormal n = kemppinen_normal(z);
  return (z >= GLINT_R(0.0) ? z * (GLINT_R(1.0) - n.tail) : z * n.tail) + n.phi;
}

/* Antiderivatives for the closed-form pieces of kemppinen_image_block_mass,
 * with Phi from its tail on the far side of 0 (as kemppinen_psi):
 *   chi(z) = int z Phi(z) dz = ((z^2 - 1) Phi(z) + z phi(z)) / 2,
 *   ups(z) = int psi(z) dz   = ((z^2 + 1) Phi(z) + z phi(z)) / 2
 * (differentiate: z Phi + (z^2 -+ 1) phi / 2 +- phi / 2 - z^2 phi / 2). */
GLINT_FN real kemppinen_chi(real z) {
  KemppinenNormal n = kemppinen_normal(z);
  real Phi = z >= GLINT_R(0.0) ? GLINT_R(1.0) - n.tail : n.tail;
  return GLINT_R(0.5) * ((z * z - GLINT_R(1.0)) * Phi + z * n.phi);
}
GLINT_FN real kemppinen_ups(real z) {
  KemppinenNormal n = kemppinen_normal(z);
  real Phi = z >= GLINT_R(0.0) ? GLINT_R(1.0) - n.tail : n.tail;
  return GLINT_R(0.5) * ((z * z + GLINT_R(1.0)) * Phi + z * n.phi);
}

/* int (q0 + r (y - ym)) Phi((c - y) / s) dy at y (an antiderivative): with
 * z = (c - y) / s, y - ym = (c - ym) - s z, dy = -s dz,
 *   = -s q0 psi(z) - s r (c - ym) psi(z) + s^2 r chi(z). */
GLINT_FN real kemppinen_lin_phi_int(real q0, real r, real ym, real c, real s, real y) {
  real z = (c - y) / s;
  return -s * (q0 + r * (c - ym)) * kemppinen_psi(z) + s * s * r * kemppinen_chi(z);
}

/* The expected number of explicit facets' lobe mass over R per unit density:
 *   E = int_R Q_B(x) dx,  Q_B(x) = P(x + (sx Z1, sy Z2) in B),
 * B = [bx0, bx1] x [by0, by1] the explicit block (facets uniform in it, each
 * with the lobe N(. - g; diag(sx^2, sy^2)); by symmetry E = int_B M(g) dg,
 * the mean over the block of kemppinen_image_mass times its area). Q_B is a
 * product qx(x) qy(y) of interval masses, so by Green's theorem
 *   E = closed int_dR Qx(x) qy(y) dy,
 *   Qx(x) = sx [psi((bx0 - x) / sx) - psi((bx1 - x) / sx)]  (dQx/dx = qx),
 * integrated per edge by 8-point Gauss-Legendre over the edge's part within
 * GLINT_KEMPPINEN_FAR_SIGMAS sy of the block's rows (qy below 4e-8 beyond),
 * in pieces split where the edge crosses the transitions of qy and Qx (and
 * into GLINT_KEMPPINEN_GL_SPAN-sigma sub-pieces within a transition);
 * R far inside or outside the block gives its area or 0 directly. Exact as R shrinks (A Q_B(c))
 * and as sigma -> 0 (area of R in B); tested against Monte Carlo. */
GLINT_FN real kemppinen_image_block_mass(const GLINT_PRIVATE KemppinenUPolygon *R, real bx0,
                                         real bx1, real by0, real by1, real sx, real sy) {
  /* R far inside the block: Q_B = 1 over R; far outside: 0. */
  real far = GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS);
  real rx0 = R->x[0], rx1 = R->x[0], ry0 = R->y[0], ry1 = R->y[0];
  for (int k = 1; k < R->n; ++k) {
    rx0 = fmin(rx0, R->x[k]);
    rx1 = fmax(rx1, R->x[k]);
    ry0 = fmin(ry0, R->y[k]);
    ry1 = fmax(ry1, R->y[k]);
  }
  if (rx0 - bx0 > far * sx && bx1 - rx1 > far * sx && ry0 - by0 > far * sy && by1 - ry1 > far * sy)
    return R->area;
  if (bx0 - rx1 > far * sx || rx0 - bx1 > far * sx || by0 - ry1 > far * sy || ry0 - by1 > far * sy)
    return GLINT_R(0.0);
  real lo = by0 - far * sy, hi = by1 + far * sy;
  real sum = GLINT_R(0.0);
  for (int k = 0; k < R->n; ++k) {
    int j = (k + 1) % R->n;
    real x0 = R->x[k], y0 = R->y[k], x1 = R->x[j], y1 = R->y[j];
    real dy = y1 - y0;
    if (dy == GLINT_R(0.0)) continue; /* horizontal: dy = 0 along it */
    /* The part of the edge inside the strip lo <= y <= hi, as t in [t0, t1]. */
    real ta = (lo - y0) / dy, tb = (hi - y0) / dy;
    real t0 = fmax(fmin(ta, tb), GLINT_R(0.0)), t1 = fmin(fmax(ta, tb), GLINT_R(1.0));
    if (!(t1 > t0)) continue;
    /* Pieces between the places where the edge enters or leaves the
     * transitions of qy (rows by0, by1) and of Qx (columns bx0, bx1), each
     * +-GLINT_KEMPPINEN_FAR_SIGMAS wide: Gauss-Legendre then integrates
     * smooth pieces (nearly constant, or within transitions, there in
     * sub-pieces: 8 nodes are not enough for an erf times psi over ~11
     * sigma, see GLINT_KEMPPINEN_GL_SPAN). */
    real tt[10];
    int nt = 0;
    tt[nt++] = t0;
    tt[nt++] = t1;
    real dx = x1 - x0;
    for (int c = 0; c < 8; ++c) {
      real edge = (c & 2) ? ((c & 4) ? bx1 : bx0) : ((c & 4) ? by1 : by0);
      edge += (c & 1) ? far * ((c & 2) ? sx : sy) : -far * ((c & 2) ? sx : sy);
      real den = (c & 2) ? dx : dy, org = (c & 2) ? x0 : y0;
      if (den == GLINT_R(0.0)) continue;
      real t = (edge - org) / den;
      if (t > t0 && t < t1) tt[nt++] = t;
    }
    for (int i = 1; i < nt; ++i) /* insertion sort, at most 10 values */
      for (int k2 = i; k2 > 0 && tt[k2 - 1] > tt[k2]; --k2) {
        real tmp = tt[k2];
        tt[k2] = tt[k2 - 1];
        tt[k2 - 1] = tmp;
      }
    for (int piece = 0; piece + 1 < nt; ++piece) {
      real pa = tt[piece], pb = tt[piece + 1];
      if (!(pb > pa)) continue;
      /* A piece away from every transition (they are the split points, so
       * its midpoint tells): Qx is bx0 - bx1 left of the block, x - bx1 in
       * its columns, 0 right of it, qy 1 in its rows, 0 outside, each within
       * phi(FAR) = 8.5e-8 (psi(z) - z for z >> 0, the tails of Phi); the
       * integrand is linear in t and the midpoint rule exact, no exp. */
      real tm = GLINT_R(0.5) * (pa + pb), xm = x0 + tm * dx, ym = y0 + tm * dy;
      int band_x = fabs(xm - bx0) < far * sx || fabs(xm - bx1) < far * sx;
      int band_y = fabs(ym - by0) < far * sy || fabs(ym - by1) < far * sy;
      real Qxm = xm < bx0 ? bx0 - bx1 : (xm < bx1 ? xm - bx1 : GLINT_R(0.0));
      real qym = (ym > by0 && ym < by1) ? GLINT_R(1.0) : GLINT_R(0.0);
      if (!band_x && !band_y) {
        sum += Qxm * qym * (pb - pa) * dy;
        continue;
      }
      /* One factor in a transition, the other linear (same bounds): closed
       * forms instead of 8 nodes, for edges not steeper than 45 degrees
       * against the varying factor's axis (the linear factor's slope
       * |dx / dy| or |dy / dx| <= 1, so nothing large cancels). */
      if ((!band_x && Qxm == GLINT_R(0.0)) || (!band_y && qym == GLINT_R(0.0))) continue;
      if ((!band_x && fabs(dx) <= fabs(dy)) || dx == GLINT_R(0.0)) {
        /* Qx = Qxm + r (y - ym), r = dx / dy, x - bx1 in the columns (slope
         * 1 in x) and constant left of them; qy = Phi((by1 - y) / sy) -
         * Phi((by0 - y) / sy). A vertical edge has Qx constant in any
         * transition: its exact value. */
        real r = xm < bx0 ? GLINT_R(0.0) : dx / dy;
        if (dx == GLINT_R(0.0)) {
          r = GLINT_R(0.0);
          Qxm = sx * (kemppinen_psi((bx0 - xm) / sx) - kemppinen_psi((bx1 - xm) / sx));
        }
        real ya = y0 + pa * dy, yb = y0 + pb * dy;
        sum += (kemppinen_lin_phi_int(Qxm, r, ym, by1, sy, yb) -
                kemppinen_lin_phi_int(Qxm, r, ym, by0, sy, yb)) -
               (kemppinen_lin_phi_int(Qxm, r, ym, by1, sy, ya) -
                kemppinen_lin_phi_int(Qxm, r, ym, by0, sy, ya));
        continue;
      }
      if (!band_y && fabs(dy) <= fabs(dx)) {
        /* qy = 1 (0 skipped above): int Qx dy = (dy / dx) int Qx dx, and
         * int psi((c - x) / s) dx = -s ups((c - x) / s). */
        real xa = x0 + pa * dx, xb = x0 + pb * dx;
        real ia = kemppinen_ups((bx0 - xa) / sx) - kemppinen_ups((bx1 - xa) / sx);
        real ib = kemppinen_ups((bx0 - xb) / sx) - kemppinen_ups((bx1 - xb) / sx);
        sum += -sx * sx * (ib - ia) * (dy / dx);
        continue;
      }
      /* Gauss-Legendre, with only the transitions the piece lies in (the
       * split points bound them, so the midpoint tells): a column's psi(z)
       * beyond FAR is its asymptote max(z, 0) within phi(FAR) / FAR^2 =
       * 2.6e-9, a row's Phi(z) is 0 or 1 within Q(FAR) = 6.0e-9, both below
       * the A&S erfc's 7.5e-8 that the active terms carry (and the midpoint
       * pieces above drop the same tails). A corner piece then takes one psi
       * and one Phi per node instead of two and two: half the exps. */
      int act_x0 = fabs(xm - bx0) < far * sx, act_x1 = fabs(xm - bx1) < far * sx;
      int act_y0 = fabs(ym - by0) < far * sy, act_y1 = fabs(ym - by1) < far * sy;
      real isx = GLINT_R(1.0) / sx, isy = GLINT_R(1.0) / sy;
      /* Sub-pieces of at most GLINT_KEMPPINEN_GL_SPAN standard deviations
       * in the coordinates that vary in a transition. Worst error of 8
       * nodes on psi(z) Phi(c + r z) over a span (random offsets and slopes
       * against composite Gauss-Legendre, in units of sx sy): 1.3e-9 over 3
       * sigma, 9.3e-8 over 4, 2.2e-5 over 5.7, 4.2e-2 over 11.4 (a piece
       * across both sides of one transition, which the split points allow):
       * E was off by 2.3e-7 (3.3e-4 of it) for a block 17 x 12 sigma wide,
       * now 7e-10 (the rotated-square test's wide cases). */
      real span = fmax((act_x0 || act_x1) ? fabs(dx) * isx : GLINT_R(0.0),
                       (act_y0 || act_y1) ? fabs(dy) * isy : GLINT_R(0.0)) *
                  (pb - pa);
      int nsub = (int)fmax(ceil(span * GLINT_R(1.0 / GLINT_KEMPPINEN_GL_SPAN)), GLINT_R(1.0));
      real hs = (pb - pa) / (real)nsub;
      real part = GLINT_R(0.0);
      for (int q = 0; q < 8 * nsub; ++q) {
        int sub = q >> 3;
        real t = pa + hs * ((real)sub + GLINT_R(0.5) * (GLINT_R(1.0) + kemppinen_gl8_node(q & 7)));
        real x = x0 + t * dx, y = y0 + t * dy;
        real z0 = (bx0 - x) * isx, z1 = (bx1 - x) * isx;
        real p0 = act_x0 ? kemppinen_psi(z0) : fmax(z0, GLINT_R(0.0));
        real p1 = act_x1 ? kemppinen_psi(z1) : fmax(z1, GLINT_R(0.0));
        real Qx = sx * (p0 - p1);
        real c0 = (by0 - y) * isy, c1 = (by1 - y) * isy;
        real qy;
        if (act_y0 && act_y1) {
          qy = kemppinen_mass(c0, c1);
        } else if (act_y0) {
          /* Phi(c1) = 1: qy = 1 - Phi(c0) = Phi(-c0), from the tail. */
          real tail = GLINT_R(0.5) * kemppinen_erfc_abs(c0);
          qy = c0 >= GLINT_R(0.0) ? tail : GLINT_R(1.0) - tail;
        } else if (act_y1) {
          /* Phi(c0) = 0: qy = Phi(c1). */
          real tail = GLINT_R(0.5) * kemppinen_erfc_abs(c1);
          qy = c1 >= GLINT_R(0.0) ? GLINT_R(1.0) - tail : tail;
        } else {
          qy = qym;
        }
        part += kemppinen_gl8_weight(q & 7) * Qx * qy;
      }
      sum += part * GLINT_R(0.5) * hs * dy;
    }
  }
  return fmax(sum, GLINT_R(0.0));
}

#endif /* GLINT_KEMPPINEN_IMAGE_H */
