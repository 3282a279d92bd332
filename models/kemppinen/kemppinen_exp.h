/* exp(-x) for the point pass's facet lobes and erfc (models/kemppinen/kemppinen_ndf.h), whose
 * arguments are clamped: x <= 80 (the lobe cut, kemppinen_lobe_cut) or x <= 18 (erfc's y^2 at the
 * 6-sigma cut), and x >= -2 (a lobe cut of a zero norm).
 *
 * In the 16-lane fp32 AVX-512 point-pass entry (GLINT_FAST_ROOTS_ACTIVE, models/kemppinen/
 * kemppinen.cl) it is PoCL's own exp, SLEEF's xexpf (1-ulp: Cody-Waite reduction by ln 2 in two
 * parts, a degree-6 polynomial, then u 2^q), written out with its constants and operations in
 * the same order, so it returns the SAME BITS as the library call on this domain; what it
 * leaves out is what the domain never needs:
 *  - SLEEF scales by 2^q in two steps, u 2^(q >> 1) 2^(q - (q >> 1)), so that q down to -150
 *    reaches the subnormals, and then selects 0 below d = -104 and +inf above 104 (8 vector
 *    instructions, 3 of them shifts on the one port that also does the hash's multiplies). For
 *    x in [-86, 86], q = rint(-x / ln 2) is in [-125, 125] and u in [2^-1/2, 2^1/2], so u 2^q is a
 *    normal float: both of SLEEF's products are exact, and so is adding q to u's exponent field,
 *    one shift and one integer add. The same value, ~8 instructions fewer per exp; the point
 *    pass takes one exp per facet (16 per query at k = 1 with two lights) and one per erfc.
 *  - Read from PoCL's compiled kernel (objdump of glint_kemppinen.so, the constants at the
 *    exp's operands): -ln 2 split as 0.693145751953125 + 1.428606765330187919e-6, 1 / ln 2,
 *    the six coefficients below, vcvtps2dq (round to nearest even) for rint. Tested bit for bit
 *    against the device library's exp over the domain
 *    (models/kemppinen/tests/kemppinen_exp_device_test.cpp); the bench's outputs are unchanged
 *    (models/kemppinen/README.md "Throughput, session 16").
 * Elsewhere (host, fp64, other entries) the library's exp. */
#ifndef GLINT_KEMPPINEN_EXP_H
#define GLINT_KEMPPINEN_EXP_H

#include "kernels/compat.h"

#if GLINT_FAST_ROOTS_ACTIVE && __has_builtin(__builtin_elementwise_roundeven)
#define GLINT_KEMPPINEN_FAST_EXP 1
/* x in [-86, 86] (see above; callers pass [-2, 80]). */
GLINT_FN real kemppinen_exp_neg(real x) {
  real d = -x;
  /* SLEEF xexpf: q = rint(d / ln 2), s = d - q ln 2 in two fused steps. */
  real qf = __builtin_elementwise_roundeven(d * 1.442695040888963407359924681001892137426645954f);
  real s = fma(qf, -0.693145751953125f, d);
  s = fma(qf, -1.428606765330187919e-6f, s);
  real u = 0.000198527617612853646278381f;
  u = fma(u, s, 0.00139304355252534151077271f);
  u = fma(u, s, 0.00833336077630519866943359f);
  u = fma(u, s, 0.0416664853692054748535156f);
  u = fma(u, s, 0.166666671633720397949219f);
  u = fma(u, s, 0.5f);
  real ss = s * s; /* rounded on its own, as SLEEF's s * s argument */
  u = 1.0f + fma(ss, u, s);
  /* u 2^q: q into the exponent field (exact: the result is normal on the domain). */
  /* In unsigned arithmetic: q < 0 is common, and a negative signed int shifted left is undefined
   * in C99/OpenCL C; modulo 2^32 the sum has the same bits. */
  return as_float16(as_uint16(u) + (as_uint16(convert_int16(qf)) << 23));
}
#else
#undef GLINT_KEMPPINEN_FAST_EXP
#define GLINT_KEMPPINEN_FAST_EXP 0
GLINT_FN real kemppinen_exp_neg(real x) {
  return exp(-x);
}
#endif

#endif /* GLINT_KEMPPINEN_EXP_H */
