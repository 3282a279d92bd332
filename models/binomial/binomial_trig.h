/* The two transcendental functions of the arcsine count (binomial_count.h, binomial_arcsine_theta):
 * theta = asin(sqrt(p)) for p in [0, 1] and sin(phi) for phi in [0, pi/2], in fp32 as short
 * polynomials of our own; fp64 keeps libm's (device and host), as before.
 *
 * Why our own: the count n sin^2(theta + d) must never fall as p grows (binomial_count.h, the
 * comment above binomial_arcsine_theta), so both functions must be non-decreasing on every fp32
 * input. With PoCL's out-of-line `sin` and `asin` that was a property of a library (checked on
 * the device, but owned by nobody here), and the calls were costly: `sin` alone ~6.5% of the
 * fp32 quad kernel's perf samples (a large-argument test per lane, a three-part Cody-Waite
 * reduction, a sine and a cosine polynomial, the live zmm registers spilled around the call;
 * models/binomial/README.md "Quad throughput (session 18)"). Both arguments here are 1-D and
 * bounded, so they can be checked input by input. On the device every fp32 input is checked for
 * a fall, as the 16-lane kernels and as the one-query kernel (binomial.cl) compile them, and 2^20
 * inputs each give the host's bits (BinomialTrigDevice). On the host (BinomialTrig in
 * binomial_test.cpp) every fp32 input from 2^-30 up is checked for a fall, below 2^-30 one in 509
 * (there both functions are their leading term x or sqrt(p) exactly, which the test's comment
 * argues), and the error against long double on a sample (every input with GLINT_EXHAUSTIVE=1).
 * The host runs the same IEEE
 * operations in the same order (FP_CONTRACT is off in the binomial kernels, and the host's
 * baseline ISA has no FMA), so host and device give the same bits, subnormals included.
 *
 * Monotone by construction where that can be had, and with a margin where it cannot:
 *  - a correctly rounded operation (+, -, *, sqrt) is non-decreasing in an operand that grows
 *    (for a product: both factors >= 0), so a chain of them on growing non-negative values never
 *    falls. asin's Taylor series has only positive coefficients, and so has the polynomial fitted
 *    to it below: binomial_asin_sqrt is non-decreasing on each of its three pieces by that
 *    argument alone; the checks add the two switches between them;
 *  - sin's and cos's series alternate, so the sine's polynomial part is not monotone by
 *    construction. Its result is RN(x + T) (RN(1 - t) from 1) with x exact, and RN is monotone,
 *    so it suffices that the exact sum x + T never falls: T's rounding errors must stay below the
 *    slack cos(x) dx of the true increment. The host test checks this stronger property, which
 *    does not depend on where a rounding boundary happens to lie, on every fp32 x from 2^-30 up:
 *    the exact sum's rise from the previous input, formed exactly in sign, is never negative
 *    (the proof needs no more: RN(S') >= RN(S) whenever S' >= S). On its accuracy sample (every
 *    61st input and those near 1 and pi/2) the rise is also >= 0.41 cos(x) dx below x = 1.5,
 *    printed, not asserted (0.413 at x = 0.92 on every input with GLINT_EXHAUSTIVE=1). Below
 *    2^-30 the sum rounds to x (|T| < 2^-62 x). */
#ifndef GLINT_BINOMIAL_TRIG_H
#define GLINT_BINOMIAL_TRIG_H

#include "kernels/compat.h"

/* pi/2 and pi/4 in two fp32 parts (Cody and Waite 1980, "Software manual for the elementary
 * functions", ch. 8): the high parts are fp32(pi/2) = 0x3fc90fdb and fp32(pi/4) = 0x3f490fdb (both
 * above the true values), the low parts the fp32-rounded remainders. */
#define GLINT_BINOMIAL_PIO2_HI GLINT_R(1.5707963705062866)
#define GLINT_BINOMIAL_PIO2_LO GLINT_R(-4.371138828673793e-08)
#define GLINT_BINOMIAL_PIO4_HI GLINT_R(0.7853981852531433)
#define GLINT_BINOMIAL_PIO4_LO GLINT_R(-2.1855694143368964e-08)

/* sin(x) for x in [0, pi/2] (in fp32 up to 0x3fc90fdb, the float just above pi/2; the clamp of
 * binomial_arcsine_theta gives no other input). Two pieces, each computed when a lane of the
 * work-item needs it (a mask-register test; the same bits as computing both and selecting, and
 * -1.7% of the binomial kernel's perf samples at N_P = 1e2 with one quad against that):
 *  - x < 1: x + x (w P(w)), w = x^2, P(w) ~ (sin x - x) / x^3 of degree 3;
 *  - x >= 1: cos(y) = 1 - v Q(v), y = pi/2 - x = (PIO2_HI - x) + PIO2_LO, v = y^2, Q(v) ~
 *    (1 - cos y) / y^2 of degree 2. PIO2_HI - x is exact (Sterbenz: x in [PIO2_HI / 2,
 *    2 PIO2_HI]), and adding PIO2_LO shifts every y of a binade by the same rounding, so y falls
 *    by the input's step; near pi/2, where sin is flat, the whole variation is in the small
 *    t = v Q(v) and no rounding of x's size enters.
 * P and Q: tools/binomial/fit_trig_poly.py (near-minimax in the sine's relative error; 4.4e-10
 * and 5.3e-9 before the fp32 roundings). The switch at 1 is where both forms keep slack: in a
 * Python emulation of these fp32 operations the exact sum rises by >= 0.41 of the true increment
 * cos(x) dx on [0.9, 1.05] in either form (the cosine form's stands still at some steps below
 * 0.9 and falls below 0.675, the sine form's stands still above 1.125). Error against long double:
 * <= 1.03 ulp on every fp32 input (1.021 ulp at x = 1.0486; BinomialTrig with GLINT_EXHAUSTIVE=1;
 * OpenCL asks <= 4 ulp of `sin`). The constants' digits are the fp32 values exactly, so C++ (a
 * double literal cast to float) and OpenCL C (-cl-single-precision-constant) read the same
 * floats. */
#if !GLINT_USE_DOUBLE
/* The sine as head + tail before its last rounding (x and T below 1, 1 and -t from 1), so that a
 * test can form the exact sum; binomial_sin_quadrant rounds it once. */
typedef struct {
  real head, tail;
} BinomialSinTerms;

GLINT_FN BinomialSinTerms binomial_sin_terms(real x) {
  glint_mask from_one = x >= GLINT_R(1.0);
  BinomialSinTerms st;
  st.head = glint_select(x, GLINT_R(1.0), from_one);
  st.tail = GLINT_R(0.0);
  if (glint_any_by_mask(!from_one)) {
    real w = x * x;
    real p = GLINT_R(2.7283927011012565e-06);
    p = p * w + GLINT_R(-0.0001984269911190495);
    p = p * w + GLINT_R(0.008333355188369751);
    p = p * w + GLINT_R(-0.1666666716337204);
    st.tail = x * (w * p);
  }
  if (glint_any_by_mask(from_one)) {
    real y = (GLINT_BINOMIAL_PIO2_HI - x) + GLINT_BINOMIAL_PIO2_LO;
    real v = y * y;
    real q = GLINT_R(0.0013763507595285773);
    q = q * v + GLINT_R(-0.041665155440568924);
    q = q * v + GLINT_R(0.5);
    st.tail = glint_select(st.tail, -(v * q), from_one);
  }
  return st;
}
#endif

GLINT_FN real binomial_sin_quadrant(real x) {
#if GLINT_USE_DOUBLE
  return sin(x);
#else
  BinomialSinTerms st = binomial_sin_terms(x);
  return st.head + st.tail;
#endif
}

/* theta = asin(sqrt(p)) for p in [0, 1], the arcsine count's angle. With a = min(p, 1 - p) and
 * the odd series asin(s) = s (1 + s^2 R(s^2)), R(t) ~ (asin(sqrt t) / sqrt t - 1) / t on
 * t in [0, 1/4] of degree 4 (tools/binomial/fit_trig_poly.py: near-minimax in the relative error
 * of asin on [0, 1/2], 7.8e-9 before the fp32 roundings, every coefficient positive), three
 * pieces:
 *  - p <= 1/4: theta = asin(sqrt p) = s + s (p R(p)), s = sqrt(p);
 *  - p >= 3/4: theta = pi/2 - asin(sqrt(1 - p)) (asin(sqrt p) + asin(sqrt(1 - p)) = pi/2), with
 *    1 - p exact (Sterbenz), so the angle resolves p's failures near 1 as finely as p does;
 *  - between: theta = pi/4 + asin(2p - 1) / 2 (sin(2 theta - pi/2) = -cos(2 theta) = 2p - 1),
 *    2p - 1 exact in [-1/2, 1/2], asin(v) = v + v (v^2 R(v^2)): the same polynomial on the same
 *    interval, so one evaluation serves all three pieces with a selected base and argument.
 * Each piece is non-decreasing in p by construction (the header comment: R's Horner steps on
 * t >= 0 with positive coefficients, products of non-negative non-decreasing factors, and the
 * odd middle piece's rounding symmetric in the sign of v); the two switches are checked with
 * every other input. Error against long double (of asin(sqrt(p)) of the fp32 p, the square root
 * not rounded): <= 1.2 ulp on every fp32 p in [0, 1] (1.194 ulp at p = 0.2291; BinomialTrig
 * with GLINT_EXHAUSTIVE=1). asin(sqrt(p)) in fp32 loses most of its bits near p = 1, where
 * sqrt(p) rounds to 1 - k 2^-24 and asin's slope is unbounded. */
GLINT_FN real binomial_asin_sqrt(real p) {
#if GLINT_USE_DOUBLE
  return asin(sqrt(p));
#else
  real a = glint_fmin_nn(p, GLINT_R(1.0) - p);
  real v = (p + p) - GLINT_R(1.0);
  glint_mask middle = (p > GLINT_R(0.25)) & (p < GLINT_R(0.75));
  real b = glint_select(sqrt(a), v, middle);
  real t = glint_select(a, v * v, middle);
  real r = GLINT_R(0.04015101492404938);
  r = r * t + GLINT_R(0.02548602968454361);
  r = r * t + GLINT_R(0.04517228901386261);
  r = r * t + GLINT_R(0.0749807059764862);
  r = r * t + GLINT_R(0.1666666716337204);
  real s = b + b * (t * r);
  real upper = GLINT_BINOMIAL_PIO2_HI + (GLINT_BINOMIAL_PIO2_LO - s);
  real mid = GLINT_BINOMIAL_PIO4_HI + (GLINT_R(0.5) * s + GLINT_BINOMIAL_PIO4_LO);
  return glint_select(glint_select(s, upper, p >= GLINT_R(0.75)), mid, middle);
#endif
}

#endif /* GLINT_BINOMIAL_TRIG_H */
