/* atan2(y, x) for y >= 0, branch-free, for the edge terms of the LTC form
 * factor (polygon_wedge.h): in fp32 an odd polynomial, in fp64 libm's atan2.
 *
 * Why: the edge term theta = atan2(|a x b|, a . b) of each of the n + 2
 * pieces was the largest single cost of the 8-lane LTC pass (removing it
 * entirely sped a quad up 25-40%, bench/bench_ltc_cost, loaded machine);
 * PoCL's vector atan2 handles infinities, signs and both arguments' ranges.
 * Here: reduce to z = min(y, |x|) / max(y, |x|) in [0, 1], atan(z) = z P(z^2)
 * with P of degree 8 fitted by tools/ltc/fit_atan_poly.py (near-minimax in
 * relative error: 1.52e-8 in exact arithmetic, 1.66e-7 evaluated in float
 * by Horner), then atan2 = pi/2 - atan(z) when y > |x| and pi - that when
 * x < 0. fp64 keeps libm: 1.5e-8 would be visible there (the fp64 host and
 * device results are the references of the fp32 ones).
 * Bounded against std::atan2 in tests/area/polygon_wedge_test.cpp. */
#ifndef GLINT_ATAN_POLY_H
#define GLINT_ATAN_POLY_H

#include "kernels/compat.h"

GLINT_FN real atan2_nonneg(real y, real x) {
#if GLINT_USE_DOUBLE
  return atan2(y, x);
#else
  real ax = fabs(x);
  real hi = fmax(y, ax), lo = fmin(y, ax);
  /* y = x = 0: atan2 gives 0; z = 0 then (the 0/0 lane is not kept). */
  real z = glint_select(GLINT_R(0.0), lo / hi, hi > GLINT_R(0.0));
  real w = z * z;
  real p = GLINT_R(2.849888972e-03);
  p = p * w + GLINT_R(-1.606862636e-02);
  p = p * w + GLINT_R(4.269151503e-02);
  p = p * w + GLINT_R(-7.504294179e-02);
  p = p * w + GLINT_R(1.064093386e-01);
  p = p * w + GLINT_R(-1.420364442e-01);
  p = p * w + GLINT_R(1.999261939e-01);
  p = p * w + GLINT_R(-3.333307334e-01);
  p = p * w + GLINT_R(9.999999848e-01);
  real r = z * p;
  r = glint_select(r, GLINT_R(1.57079632679489662) - r, y > ax);
  return glint_select(r, GLINT_R(3.14159265358979324) - r, x < GLINT_R(0.0));
#endif
}

#endif /* GLINT_ATAN_POLY_H */
