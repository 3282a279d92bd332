/* A facet lobe's mass over the light's image R (kemppinen_image.h) and the
 * bounds that let the Kemppinen polygon pass (kemppinen_polygons.h) skip
 * most of its per-facet and per-level integrals. R's edges are kept as lines
 * in the lobe's whitened coordinates (x / sx, y / sy), built once per light.
 *
 * The mass of the standard normal (the whitened lobe, centred at g) over a
 * simple polygon is the sum over its edges (a, b) of the signed masses of the
 * triangles (g, a, b); with h the distance of g to the edge's line and ta,
 * tb the ends' positions along it from the foot of the perpendicular, each
 * triangle is the wedge atan(t / h) / (2 pi) minus Owen's T beyond the edge
 * (Owen 1956, the right-triangle decomposition):
 *   M(g) = sum_edges s [atan(tb / h) - atan(ta / h)] / (2 pi)
 *          - sum_edges s [Tc(h, tb) - Tc(h, ta)],  Tc(h, t) = sign(t) T(h, |t| / h),
 * s = +1 when g is inside the edge's half-plane. The first sum is the winding
 * number of R about g (1 inside, 0 outside), counted here by crossings
 * (Sunday 2001) with the same signed distances as s, so no atan2 at all. An
 * edge whose line is farther than FAR = GLINT_KEMPPINEN_FAR_SIGMAS from g has
 * |Tc| <= T(h, inf) = Q(h) / 2 <= 3.0e-9 and is dropped; an end farther than
 * FAR along the line has Tc = sign(t) Q(h) / 2 within Q(FAR) (T(h, inf) -
 * T(h, a) = int_a^inf, below Q(a h) / 2), one erfc. So a facet near one edge
 * costs one erfc, one at a corner two Owen's T per near edge, and the result
 * is exact up to n Q(FAR) (n edges; Q(5.7) = 6.0e-9), the erfc (A&S 7.1.26,
 * |error| <= 1.5e-7 / 2 per Q) and Owen's T (5-point Gauss-Legendre, 1.9e-8)
 * for convex and non-convex R alike. h and t come from the differences
 * x_k - gx (exact when g is close, Sterbenz), as in
 * kemppinen_image_mass_triangles, not from the line form a gx + b gy + c
 * (which cancels, |c| ~ |x| / sigma; only the rectangle bounds use it). On
 * R's boundary the winding number is undefined (the mass is the interior
 * angle / 2 pi: 1/2 on an edge), at a vertex so is t / h, and the crossing
 * rule's half-open rows need not agree with the side d > 0: a facet within
 * GLINT_KEMPPINEN_BOUNDARY_SIGMAS of an edge's line (a fraction ~1e-3 of
 * those near an edge) takes the triangle sum with its atan2 terms, robust
 * there (kemppinen_image_mass_triangles). Beyond it the sign of d is exact
 * (d from differences, relative error ~1e-7) and the winding number too.
 *
 * Bounds on rectangles (a cell, the explicit block): apart from R's bounding
 * box widened by FAR (no lobe centred there reaches R, any shape); from the
 * largest and smallest signed distance over them (at a corner):
 *  - inside every edge by more than FAR: the rectangle is in R's kernel (the
 *    intersection of the edges' inner half-planes, inside R whatever its
 *    shape), every lobe centred there has mass >= 1 - n Q(FAR);
 *  - R convex (R->convex; not always, see kemppinen_image.h) and beyond one
 *    edge by more than FAR: no lobe centred there reaches R (mass <= Q(FAR)).
 * models/kemppinen/tests/kemppinen_polygon_test.cpp holds these against
 * Monte Carlo and closed forms. */
#ifndef GLINT_KEMPPINEN_IMAGE_LINES_H
#define GLINT_KEMPPINEN_IMAGE_LINES_H

#include "models/kemppinen/kemppinen_image.h"

/* Edge k (from vertex k to k + 1): signed distance d_k(g) = a gx + b gy + c
 * (> 0 inside, R counter-clockwise) for the rectangle bounds; ea = |a| / 2,
 * eb = |b| / 2, the spread of d_k over a unit-size rectangle about its
 * centre; (ux, uy) the unit direction and len the length, whitened. A
 * zero-length edge has len = 0 and d = +1e30 (never near, never beyond). */
/* A facet this close to the line of one of R's edges (lobe standard
 * deviations) takes the triangle sum (header comment). */
#define GLINT_KEMPPINEN_BOUNDARY_SIGMAS 1e-3

typedef struct {
  int n;
  int convex; /* R's: the "beyond an edge" bound needs it */
  real isx, isy;
  real bx0, bx1, by0, by1; /* R's bounding box widened by FAR lobe sigmas */
  real ux[GLINT_KEMPPINEN_IMAGE_CLIP_MAX], uy[GLINT_KEMPPINEN_IMAGE_CLIP_MAX]; /* unit, whitened */
  real a[GLINT_KEMPPINEN_IMAGE_CLIP_MAX], b[GLINT_KEMPPINEN_IMAGE_CLIP_MAX],
      c[GLINT_KEMPPINEN_IMAGE_CLIP_MAX];
  real len[GLINT_KEMPPINEN_IMAGE_CLIP_MAX];
  real ea[GLINT_KEMPPINEN_IMAGE_CLIP_MAX], eb[GLINT_KEMPPINEN_IMAGE_CLIP_MAX];
} KemppinenULines;

GLINT_FN KemppinenULines kemppinen_image_lines(const GLINT_PRIVATE KemppinenUPolygon *R, real sx,
                                               real sy) {
  KemppinenULines L;
  L.n = R->n;
  L.convex = R->convex;
  real isx = GLINT_R(1.0) / sx, isy = GLINT_R(1.0) / sy;
  L.isx = isx;
  L.isy = isy;
  L.bx0 = L.bx1 = R->n > 0 ? R->x[0] : GLINT_R(0.0);
  L.by0 = L.by1 = R->n > 0 ? R->y[0] : GLINT_R(0.0);
  for (int k = 1; k < R->n; ++k) {
    L.bx0 = fmin(L.bx0, R->x[k]);
    L.bx1 = fmax(L.bx1, R->x[k]);
    L.by0 = fmin(L.by0, R->y[k]);
    L.by1 = fmax(L.by1, R->y[k]);
  }
  L.bx0 -= GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS) * sx;
  L.bx1 += GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS) * sx;
  L.by0 -= GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS) * sy;
  L.by1 += GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS) * sy;
  for (int k = 0; k < R->n; ++k) {
    int j = (k + 1) % R->n;
    real ex = (R->x[j] - R->x[k]) * isx, ey = (R->y[j] - R->y[k]) * isy;
    real len = sqrt(ex * ex + ey * ey);
    real ok = len > GLINT_R(0.0) ? GLINT_R(1.0) : GLINT_R(0.0);
    real il = ok > GLINT_R(0.0) ? GLINT_R(1.0) / len : GLINT_R(0.0);
    /* d = (ex (gy - y_k) / sy - ey (gx - x_k) / sx) / len */
    L.a[k] = -ey * isx * il;
    L.b[k] = ex * isy * il;
    L.c[k] = ok > GLINT_R(0.0) ? -(L.a[k] * R->x[k] + L.b[k] * R->y[k]) : GLINT_R(1e30);
    L.len[k] = len;
    L.ux[k] = ex * il;
    L.uy[k] = ey * il;
    L.ea[k] = GLINT_R(0.5) * fabs(L.a[k]);
    L.eb[k] = GLINT_R(0.5) * fabs(L.b[k]);
  }
  return L;
}

/* The rectangle [x0, x1] x [y0, y1] lies beyond one of R's edges by more
 * than FAR lobe standard deviations and R is convex: no lobe centred in it
 * reaches R. */
GLINT_FN int kemppinen_lines_rect_outside(const GLINT_PRIVATE KemppinenULines *L, real x0, real x1,
                                          real y0, real y1) {
  if (!L->convex) return 0;
  real mx = GLINT_R(0.5) * (x0 + x1), my = GLINT_R(0.5) * (y0 + y1);
  real w = x1 - x0, h = y1 - y0;
  for (int k = 0; k < L->n; ++k) {
    real hi = L->a[k] * mx + L->b[k] * my + L->c[k] + L->ea[k] * w + L->eb[k] * h;
    if (hi < -GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS)) return 1;
  }
  return 0;
}

/* The rectangle misses R's bounding box widened by FAR lobe sigmas (any
 * shape of R): no lobe centred in it reaches R. Four comparisons, for the
 * per-cell test before a facet's hash. */
GLINT_FN int kemppinen_lines_rect_apart(const GLINT_PRIVATE KemppinenULines *L, real x0, real x1,
                                        real y0, real y1) {
  return x1 < L->bx0 || x0 > L->bx1 || y1 < L->by0 || y0 > L->by1;
}

/* The rectangle lies inside every edge by more than FAR (every lobe centred
 * in it has its whole mass on R, whatever R's shape). */
GLINT_FN int kemppinen_lines_rect_inside(const GLINT_PRIVATE KemppinenULines *L, real x0, real x1,
                                         real y0, real y1) {
  real mx = GLINT_R(0.5) * (x0 + x1), my = GLINT_R(0.5) * (y0 + y1);
  real w = x1 - x0, h = y1 - y0;
  for (int k = 0; k < L->n; ++k) {
    real lo = L->a[k] * mx + L->b[k] * my + L->c[k] - L->ea[k] * w - L->eb[k] * h;
    if (!(lo > GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS))) return 0;
  }
  return 1;
}

/* Tc(h, t) = sign(t) T(h, |t| / h) (header comment); qh = Q(h). h is floored
 * at 1e-30 so g on the edge's line gives T(0, inf) = 1/4 without 0 / 0. */
GLINT_FN real kemppinen_lines_tc(real h, real t, real qh) {
  real at = fabs(t);
  real T = at > GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS)
               ? GLINT_R(0.5) * qh
               : kemppinen_owen_t_q(h, at / fmax(h, GLINT_R(1e-30)), qh);
  return t < GLINT_R(0.0) ? -T : T;
}

/* The mass over R of the facet lobe N(x - g; diag(sx^2, sy^2)) (header
 * comment): the winding number of R about g plus the Owen's T terms of the
 * edges within FAR. R's raw vertices give the crossings' rows. */
GLINT_FN real kemppinen_lines_mass(const GLINT_PRIVATE KemppinenUPolygon *R,
                                   const GLINT_PRIVATE KemppinenULines *L, real gx, real gy,
                                   real sx, real sy) {
  if (L->convex) {
    /* Convex R is the intersection of the half-planes d_k >= 0: beyond one
     * edge by FAR gives 0, inside all by FAR 1, near exactly one edge (the
     * others > FAR) the half-plane's mass Phi(d) within (n - 1) Q(FAR) (the
     * sum below with wn = [d > 0] and both ends beyond FAR: 1 - Q(d) or
     * Q(-d)). Only near a corner does it take the sum. */
    int near = 0;
    real dn = GLINT_R(0.0);
    for (int k = 0; k < L->n; ++k) {
      if (!(L->len[k] > GLINT_R(0.0))) continue;
      real d = (R->x[k] - gx) * L->isx * L->uy[k] - (R->y[k] - gy) * L->isy * L->ux[k];
      if (d < -GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS)) return GLINT_R(0.0);
      if (!(d > GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS))) {
        ++near;
        dn = d;
      }
    }
    if (near == 0) return GLINT_R(1.0);
    if (near == 1) {
      real tail = GLINT_R(0.5) * kemppinen_erfc_abs(dn);
      return dn > GLINT_R(0.0) ? GLINT_R(1.0) - tail : tail;
    }
  }
  int wn = 0;
  real corr = GLINT_R(0.0);
  for (int k = 0; k < L->n; ++k) {
    if (!(L->len[k] > GLINT_R(0.0))) continue; /* a point: no crossing, no mass */
    /* g's distance d to the edge's line and position ta along it, from the
     * differences to the vertex (header comment). */
    real ax = (R->x[k] - gx) * L->isx, ay = (R->y[k] - gy) * L->isy;
    real d = ax * L->uy[k] - ay * L->ux[k];
    /* Convex R: beyond one edge's line is outside R (mass <= Q(FAR)). */
    if (d < -GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS) && L->convex) return GLINT_R(0.0);
    int j = k + 1 < L->n ? k + 1 : 0;
    /* Winding number (Sunday): an upward crossing of g's row with g on
     * the left (d > 0) counts +1, a downward one with g on the right -1.
     * g on the edge's line (d = 0) counts as outside it, as s below does,
     * so the pair is the limit d -> 0- (on the edge: 0 + 1/2 or 1 - 1/2). */
    int up = R->y[k] <= gy && R->y[j] > gy, down = R->y[j] <= gy && R->y[k] > gy;
    wn += (up && d > GLINT_R(0.0)) ? 1 : 0;
    wn -= (down && !(d > GLINT_R(0.0))) ? 1 : 0;
    real h = fabs(d);
    if (h > GLINT_R(GLINT_KEMPPINEN_FAR_SIGMAS)) continue;
    real ta = ax * L->ux[k] + ay * L->uy[k], tb = ta + L->len[k];
    if (h < GLINT_R(GLINT_KEMPPINEN_BOUNDARY_SIGMAS))
      return kemppinen_image_mass_triangles(R, gx, gy, sx, sy);
    /* Q(h) enters only through an end beyond h along the line (Owen's
     * identity, or T(h, inf) beyond FAR >= h): one erfc, skipped otherwise. */
    real qh = fmax(fabs(ta), fabs(tb)) > h ? GLINT_R(0.5) * kemppinen_erfc_abs(h) : GLINT_R(0.0);
    real s = d > GLINT_R(0.0) ? GLINT_R(1.0) : GLINT_R(-1.0);
    corr -= s * (kemppinen_lines_tc(h, tb, qh) - kemppinen_lines_tc(h, ta, qh));
  }
  return clamp((real)wn + corr, GLINT_R(0.0), GLINT_R(1.0));
}

/* The same for one facet without precomputed lines (tests, one-off uses). */
GLINT_FN real kemppinen_image_mass(const GLINT_PRIVATE KemppinenUPolygon *R, real gx, real gy,
                                   real sx, real sy) {
  KemppinenULines L = kemppinen_image_lines(R, sx, sy);
  return kemppinen_lines_mass(R, &L, gx, gy, sx, sy);
}

/* E = int_R Q_B(x) dx (kemppinen_image_block_mass) for the block B =
 * [bx0, bx1] x [by0, by1]: B deep inside R gives B's area (by symmetry E =
 * int_B M(g) dg and M = 1 there), B beyond an edge of a convex R 0; else the
 * line integral. */
GLINT_FN real kemppinen_lines_block_mass(const GLINT_PRIVATE KemppinenUPolygon *R,
                                         const GLINT_PRIVATE KemppinenULines *L, real bx0, real bx1,
                                         real by0, real by1, real sx, real sy) {
  if (kemppinen_lines_rect_outside(L, bx0, bx1, by0, by1)) return GLINT_R(0.0);
  if (kemppinen_lines_rect_inside(L, bx0, bx1, by0, by1)) return (bx1 - bx0) * (by1 - by0);
  return kemppinen_image_block_mass(R, bx0, bx1, by0, by1, sx, sy);
}

#endif /* GLINT_KEMPPINEN_IMAGE_LINES_H */
