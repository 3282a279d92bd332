/* GLINT_UNROLL before a loop: unroll it fully on the device. PoCL's kernel
 * compiler leaves loops rolled (it keeps them for its work-item loop
 * vectoriser), so a loop over a fixed count of lanes, vertices or edges stays
 * a loop: its private arrays live in memory instead of registers, and
 * independent iterations (a quad's four edge terms, each a long chain of
 * sqrt, division and a polynomial) are not interleaved. Measured on the LTC
 * lane pass (issue 13): the table lookup's share of the pass fell from ~22%
 * to ~10% (perf annotate, loaded machine). Unrolling changes no arithmetic.
 * On the host and in one-query kernels the compiler decides (the macro is
 * empty). */
#ifndef GLINT_UNROLL_H
#define GLINT_UNROLL_H

#include "kernels/compat.h"

/* Lane kernels only: unrolling lengthens PoCL's kernel builds (bench_ltc_cost
 * on a fresh cache, loaded machine: 32.6 s instead of 20.6 s with it in every
 * kernel), and the one-query kernels (GLINT_LANES == 1: the other area
 * methods, the glint models' per-query passes) were not measured to gain
 * from it. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
#define GLINT_UNROLL _Pragma("unroll")
/* A loop over a polygon's vertex count is unrolled where the count is a
 * constant after inlining (quads: area_ltc_shade calls with n = 4) and stays
 * a loop in the copy for any count, which clang reports as a failed request
 * ("loop not unrolled") at every kernel build: expected, not a defect. */
#pragma clang diagnostic ignored "-Wpass-failed"
#else
#define GLINT_UNROLL
#endif

#endif /* GLINT_UNROLL_H */
