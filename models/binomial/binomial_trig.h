/* Sines and cosines without a library call, for the binomial model's rotations
 * (binomial_tetrahedral.h) and its arcsine count approximation (binomial_count.h). PoCL's sin and
 * cos (SLEEF) are out-of-line calls with a general range reduction: in the 16-lane kernel every
 * call also spills the live zmm registers (all caller-saved), and `perf` put 4% of the binomial
 * quad kernel's samples inside _cl_sin alone at N_P = 1e2 (models/binomial/README.md "Quad
 * throughput (session 17)"). These are a few FMA-free multiply-adds per lane, the same
 * arithmetic on host and device (FP_CONTRACT is off in the binomial kernels). */
#ifndef GLINT_BINOMIAL_TRIG_H
#define GLINT_BINOMIAL_TRIG_H

#include "kernels/compat.h"

/* cos(pi f) and sin(pi f) for f in [0, 1] with no library call: the rotation angles here are
 * pi f with f = bin / bins (exact, bins a power of two), so the reduction is exact too: f -> 1 - f
 * (cos changes sign), then g -> 1/2 - g (cos and sin swap) leave x = pi g in [0, pi/4], where
 * the Taylor series to x^16 and x^17 has a remainder below x^18 / 18! < 2e-18 (below half an
 * ulp in fp64). PoCL's sin and cos (SLEEF, with a general range reduction) were the trilinear
 * grids' largest single cost (models/binomial/README.md "Cost"); this is a few FMAs per lane and
 * the same arithmetic on host and device. */
GLINT_FN void binomial_cos_sin_pi(real f, GLINT_PRIVATE real *c, GLINT_PRIVATE real *s) {
  glint_mask upper = f > GLINT_R(0.5);
  real g = glint_select(f, GLINT_R(1.0) - f, upper);
  glint_mask swap = g > GLINT_R(0.25);
  g = glint_select(g, GLINT_R(0.5) - g, swap);
  real x = GLINT_PI * g, x2 = x * x;
  /* Horner in x^2: cos = sum (-1)^j x^2j / (2j)!, sin = x sum (-1)^j x^2j / (2j + 1)! */
  real cp = GLINT_R(4.779477332387385e-14);  /* 1 / 16! */
  real sp = GLINT_R(2.8114572543455206e-15); /* 1 / 17! */
  cp = cp * x2 - GLINT_R(1.1470745597729725e-11);
  sp = sp * x2 - GLINT_R(7.647163731819816e-13);
  cp = cp * x2 + GLINT_R(2.08767569878681e-09);
  sp = sp * x2 + GLINT_R(1.6059043836821613e-10);
  cp = cp * x2 - GLINT_R(2.755731922398589e-07);
  sp = sp * x2 - GLINT_R(2.505210838544172e-08);
  cp = cp * x2 + GLINT_R(2.48015873015873e-05);
  sp = sp * x2 + GLINT_R(2.7557319223985893e-06);
  cp = cp * x2 - GLINT_R(0.001388888888888889);
  sp = sp * x2 - GLINT_R(0.0001984126984126984);
  cp = cp * x2 + GLINT_R(0.041666666666666664);
  sp = sp * x2 + GLINT_R(0.008333333333333333);
  cp = cp * x2 - GLINT_R(0.5);
  sp = sp * x2 - GLINT_R(0.16666666666666666);
  cp = cp * x2 + GLINT_R(1.0);
  sp = (sp * x2 + GLINT_R(1.0)) * x;
  real co = glint_select(cp, sp, swap), si = glint_select(sp, cp, swap);
  *c = glint_select(co, -co, upper);
  *s = si;
}

/* sin(phi) for phi in [0, pi/2], non-decreasing in phi (the arcsine count,
 * binomial_arcsine_theta, must never fall as p grows). fp32: sin(pi f) of binomial_cos_sin_pi at
 * f = phi / pi, clamped to 1/2 (RN(RN(pi/2) RN(1/pi)) may round above 1/2, where the reduction
 * f -> 1 - f would turn the sine down). f is non-decreasing in phi (a product by a positive
 * constant, a clamp), the reductions to g in [0, 1/4] (sine) and 1/2 - g (cosine, exact by
 * Sterbenz) are exact, and the result was checked non-decreasing over every pair of consecutive
 * fp32 inputs in [0, pi/2], the switch at f = 1/4 included (BinomialTrig.SinQuarterTurn*, all of
 * them under GLINT_EXHAUSTIVE=1). Accuracy: f and x = pi g round once each, the Horner sums about
 * once: within 4 ulp of sin (the same test, against long double), far below the approximation's
 * own error (the count is rounded from n sin^2, and the arcsine law's total variation is ~1e-3).
 * fp64 keeps the library sin: the same Horner polynomial in double is NOT monotone at the ulp
 * level (3 falls in 2^20 sampled pairs), and fp64 speed is not what this is for, so fp64 counts
 * are unchanged. */
GLINT_FN real binomial_sin_quarter_turn(real phi) {
#if GLINT_USE_DOUBLE
  return sin(phi);
#else
  real c, s;
  binomial_cos_sin_pi(glint_fmin_nn(phi * GLINT_R(0.31830988618379067), GLINT_R(0.5)), &c, &s);
  return s;
#endif
}

#endif /* GLINT_BINOMIAL_TRIG_H */
