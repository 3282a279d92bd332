/* Portability layer: the BRDF headers in kernels/ compile as OpenCL C (device)
 * and as C++ (host scalar path and tests). Only this file knows which.
 *
 * `real` is float or double, chosen by GLINT_USE_DOUBLE (0 or 1), so tests can
 * run the same math in double. The shared headers use the common subset of
 * OpenCL C 1.2 and C++: no templates, references, overloads or classes.
 *
 * On the device one work-item evaluates GLINT_LANES queries (8 or 16, per model
 * pass: ModelPass::simd_width in server/model.h, set by server/device_engine.cpp): `real` is
 * then an OpenCL vector (float8/16 or double8/16), one lane per query, and every line of
 * the shared headers is SIMD
 * code. The host sees plain scalars, or with GLINT_HOST_LANES a class of
 * GLINT_HOST_LANES lanes (kernels/host_lanes.h). Rules that keep one source
 * valid for both:
 *  - `real3` is a struct of three `real`s; use the r3_* helpers (C++ also has
 *    operators, host-only, for code outside kernels/).
 *  - no branch on per-query values: on the device they are vectors and `if`
 *    does not compile. Compute with safe inputs, then choose with glint_select
 *    (a per-lane select). Guards stay; they just become selects. A branch on
 *    glint_any(condition) is fine: it is uniform per work-item (skips work
 *    only when no lane needs it) and an ordinary early return on the host.
 *  - comparisons give a glint_mask (int on the host, intN/longN lanes of 0/-1
 *    on the device); combine masks with |, & and !, never && or ||.
 *  - math builtins (sqrt, exp, erfc, fmin, fmax, clamp) work on both; PoCL has
 *    vector versions of them (SLEEF).
 *
 * Host use: include <cmath> first, then include the kernel headers inside a
 * namespace of your own so that float and double builds can share a binary
 * (see server/host_path.cpp). */
#ifndef GLINT_COMPAT_H
#define GLINT_COMPAT_H

#ifndef GLINT_USE_DOUBLE
#define GLINT_USE_DOUBLE 0
#endif

#ifdef __OPENCL_VERSION__
/* ---------------------------- OpenCL C --------------------------------- */
#if GLINT_USE_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif
/* Queries per work-item (set by the host, server/device_engine.cpp). With
 * GLINT_LANES > 1, `real` is an OpenCL vector type and every line of the
 * shared headers processes GLINT_LANES queries at once; comparisons then give
 * per-lane masks (`glint_mask`) for glint_select and glint_any. 1 gives the
 * scalar kernel (one query per work-item). */
#ifndef GLINT_LANES
#define GLINT_LANES 1
#endif
#if GLINT_LANES == 1
#if GLINT_USE_DOUBLE
typedef double real;
#else
typedef float real;
#endif
typedef int glint_mask;
#elif GLINT_LANES == 8
#if GLINT_USE_DOUBLE
typedef double8 real;
typedef long8 glint_mask;
#else
typedef float8 real;
typedef int8 glint_mask;
#endif
#elif GLINT_LANES == 16
#if GLINT_USE_DOUBLE
typedef double16 real;
typedef long16 glint_mask;
#else
typedef float16 real;
typedef int16 glint_mask;
#endif
#else
#error "GLINT_LANES must be 1, 8 or 16"
#endif
/* Inline everything into the entry point (no calls left but math builtins). */
#define GLINT_FN inline __attribute__((always_inline))
#define GLINT_GLOBAL __global
#define GLINT_CONSTANT __constant
#define GLINT_PRIVATE __private
#define glint_assert(x)
/* No implicit a * b + c -> fma contraction (OpenCL C allows it by default).
 * The host path (baseline x86-64, no FMA) rounds every product; contracting
 * on the device only changes the rounding in the cancellation-prone spots
 * (dot products of nearly orthogonal vectors in frame_to_local) and breaks
 * the device-vs-host agreement the tests ask for.
 * Except in kernels that ask for it (GLINT_CONTRACT_FMA: the lane entries
 * models/smooth/smooth.cl, models/smooth/smooth_area_lanes.cl (LTC) and
 * models/kemppinen/kemppinen.cl) on an 8- or 16-lane fp32 AVX-512 device, for
 * queries in the local frame: those kernels' speed is their count of vector
 * instructions (issues 9 and 13, docs/performance-history.md "The smooth kernel against
 * Mitsuba 3"), and a fused a * b + c is one instruction instead of two (and one
 * rounding instead of two). A branch taken when all lanes of a block agree
 * must then round each lane as the other branch does (fusion is within one
 * expression: models/kemppinen/kemppinen_ndf.h kemppinen_compensation_with). With a world frame
 * (GLINT_HAS_FRAME) the frame's dot products of nearly orthogonal vectors cancel, and a grazing
 * light's cosine moved by 7e-4 relative against the host (engine_test): off there. */
#if defined(GLINT_CONTRACT_FMA) && GLINT_LANES >= 8 && !GLINT_USE_DOUBLE && \
    defined(__AVX512F__) && !GLINT_HAS_FRAME
#define GLINT_CONTRACT_FMA_ACTIVE 1
#pragma OPENCL FP_CONTRACT ON
#else
#define GLINT_CONTRACT_FMA_ACTIVE 0
#pragma OPENCL FP_CONTRACT OFF
#endif

#else
/* ------------------------------- C++ ----------------------------------- */
#include <cassert>
#include <cmath>

#if defined(GLINT_HOST_LANES) && GLINT_HOST_LANES > 1
/* The host path with lanes: `real` holds GLINT_HOST_LANES queries (kernels/host_lanes.h). */
#define GLINT_HOST_LANES_ACTIVE 1
#include "kernels/host_lanes.h"
#else
#define GLINT_HOST_LANES_ACTIVE 0
#if GLINT_USE_DOUBLE
typedef double real;
#else
typedef float real;
#endif
#define GLINT_FN inline
typedef int glint_mask; /* result of a comparison of two reals */
#endif
#define GLINT_GLOBAL
#define GLINT_CONSTANT
#define GLINT_PRIVATE
#define glint_assert(x) assert(x)

using std::acos;
using std::asin;
using std::atan2;
using std::cos;
using std::erf;
using std::erfc;
using std::exp;
using std::exp2;
using std::expm1;
using std::fabs;
using std::floor;
using std::fma; /* the float overload for floats (::fma would round the sum in double first) */
using std::fmax;
using std::fmin;
using std::isfinite;
using std::log;
using std::log1p;
using std::log2;
using std::logb;
using std::pow;
using std::sin;
using std::sqrt;
using std::tan;

typedef unsigned int uint;

GLINT_FN real clamp(real x, real lo, real hi) {
  return fmin(fmax(x, lo), hi);
}
#endif

/* floor(x), exact, per lane. On the device PoCL's library floor is ~12 vector
 * instructions (truncate, convert back, correct negative fractions, restore the
 * sign and keep |x| >= 2^23 and NaN as they are: perf annotate of the KEMPPINEN
 * kernel, which takes ~11 floors per query); clang's elementwise builtin is
 * llvm.floor, one vrndscaleps with AVX-512 (roundps with SSE4.1). floor is exact,
 * so both give the same bits in every lane, NaN and infinities included. */
#if defined(__OPENCL_VERSION__) && defined(__has_builtin)
#if __has_builtin(__builtin_elementwise_floor)
#define glint_floor(x) __builtin_elementwise_floor(x)
#endif
#endif
#ifndef glint_floor
#define glint_floor(x) floor(x)
#endif

/* ------------------------------ common --------------------------------- */

/* Three components in the working precision (directions, RGB). */
typedef struct {
  real x, y, z;
} real3;

GLINT_FN real3 make_real3(real x, real y, real z) {
  real3 v;
  v.x = x;
  v.y = y;
  v.z = z;
  return v;
}

GLINT_FN real3 r3_add(real3 a, real3 b) {
  return make_real3(a.x + b.x, a.y + b.y, a.z + b.z);
}
GLINT_FN real3 r3_sub(real3 a, real3 b) {
  return make_real3(a.x - b.x, a.y - b.y, a.z - b.z);
}
/* Component-wise product (RGB times RGB). */
GLINT_FN real3 r3_mul(real3 a, real3 b) {
  return make_real3(a.x * b.x, a.y * b.y, a.z * b.z);
}
GLINT_FN real3 r3_scale(real3 a, real s) {
  return make_real3(a.x * s, a.y * s, a.z * s);
}
GLINT_FN real3 r3_div(real3 a, real s) {
  return make_real3(a.x / s, a.y / s, a.z / s);
}
GLINT_FN real r3_dot(real3 a, real3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
GLINT_FN real3 r3_cross(real3 a, real3 b) {
  return make_real3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
GLINT_FN real r3_length(real3 a) {
  return sqrt(r3_dot(a, a));
}
GLINT_FN real3 r3_normalize(real3 a) {
  return r3_div(a, r3_length(a));
}

/* OpenCL's select(a, b, c): c ? b : a, per lane. A conditional expression on
 * values that are already computed: a select instruction, never a branch
 * (for OpenCL vectors, `?:` with a vector condition is select()). */
#if !(defined(GLINT_HOST_LANES_ACTIVE) && GLINT_HOST_LANES_ACTIVE)
GLINT_FN real glint_select(real a, real b, glint_mask c) {
  return c ? b : a;
}
#endif
GLINT_FN real3 r3_select(real3 a, real3 b, glint_mask c) {
  return make_real3(glint_select(a.x, b.x, c), glint_select(a.y, b.y, c),
                    glint_select(a.z, b.z, c));
}

/* fmax(x, c), fmin(x, c) and clamp(x, lo, hi) for bounds c, lo <= hi that are never NaN (a
 * constant, or a value known finite), as selects. PoCL's fmax / fmin honour a NaN in either
 * operand (llvm.maxnum: 4 vector instructions on x86, compare unordered, compare, or the
 * masks, blend); with a bound that is not NaN, x > c ? x : c has the value of fmax(x, c) for
 * every x, NaN included (NaN > c is false: c, as fmax(NaN, c) = c), and is one vmaxps (MAXPS
 * returns its second operand when unordered). Only a zero's sign may differ (fmax(-0, +0) is
 * either zero). clamp(NaN, lo, hi) = lo, as OpenCL's fmin(fmax(NaN, lo), hi). */
GLINT_FN real glint_fmax_nn(real x, real c) {
  return glint_select(c, x, x > c);
}
GLINT_FN real glint_fmin_nn(real x, real c) {
  return glint_select(c, x, x < c);
}
GLINT_FN real glint_clamp_nn(real x, real lo, real hi) {
  return glint_fmin_nn(glint_fmax_nn(x, lo), hi);
}

/* True if the condition holds in at least one lane: lets a work-item skip a
 * whole computation when no lane needs it. The branch is uniform per
 * work-item (all of its lanes take it together), so it does not break the
 * SIMD code; it pays off only where whole blocks of queries agree (coherent
 * batches), so use it sparingly. On the host it is the plain condition. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
/* An OR reduction of the lanes, tested for the sign bit (true lanes are -1): PoCL's any()
 * extracts and tests the lanes one by one with a branch each, which cost ~20% of the binomial
 * lane kernel's exact-search loops (perf, issue 13). glint_any_by_mask below is cheaper still
 * per test but measured slower as the default (session 18). */
#define glint_any(c) (__builtin_reduce_or(c) < 0)
#elif defined(GLINT_HOST_LANES_ACTIVE) && GLINT_HOST_LANES_ACTIVE
/* kernels/host_lanes.h */
#else
#define glint_any(c) (c)
#endif

/* glint_any with the lanes' sign bits (true lanes are -1) gathered into an AVX-512 mask
 * register and tested against 0 (vpmovd2m / vpmovq2m, which LLVM folds into the comparison
 * that made the mask, then kortest: 2-3 instructions where PoCL lowers the OR reduction to ~10
 * extract / or / shuffle instructions on the vector unit). The same truth value, so the same
 * branches and results. Not the default: session 18 made it glint_any for every lane kernel
 * and measured it slower where it changed the code (SMOOTH's 8-lane LTC pass 3-4% per
 * CPU-second, BINOMIAL's quad rows 2-4%; the punctual SMOOTH and KEMPPINEN fp32 kernels
 * compiled to the same machine code), so it serves the loops where it measured faster:
 * BINOMIAL's draw (binomial_count.h: its exact search, 4-6% of the fp32 quad kernel; fp64
 * +1-6%, about the noise; docs/performance-history.md "Session 18: glint_any by mask
 * register"). Every branch of it compiled in PoCL when it was glint_any. The builtins are
 * clang's, as PoCL compiles them for its -mcpu (skylake-avx512 here defines __AVX512DQ__,
 * __AVX512VL__ and __AVX512BW__); elsewhere (no AVX-512, the host) it is glint_any. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1 && defined(__AVX512DQ__)
#if GLINT_LANES == 16 && !GLINT_USE_DOUBLE
#define glint_any_by_mask(c) (__builtin_ia32_cvtd2mask512(c) != 0)
#elif GLINT_LANES == 16
/* long16 is two zmm registers: the OR of its halves (LLVM folds it into kortestb of the two
 * comparisons' masks). A function, so that c is evaluated once. */
GLINT_FN int glint_any_by_mask_long16(long16 c) {
  return __builtin_ia32_cvtq2mask512(c.lo | c.hi) != 0;
}
#define glint_any_by_mask(c) glint_any_by_mask_long16(c)
#elif GLINT_USE_DOUBLE
#define glint_any_by_mask(c) (__builtin_ia32_cvtq2mask512(c) != 0)
#elif defined(__AVX512VL__)
#define glint_any_by_mask(c) (__builtin_ia32_cvtd2mask256(c) != 0)
#else
#define glint_any_by_mask(c) glint_any(c)
#endif
#else
#define glint_any_by_mask(c) glint_any(c)
#endif

#ifndef __OPENCL_VERSION__
/* Host-only conveniences for C++ code outside kernels/ (the shared headers use
 * the r3_* functions so that host and device run the same code). */
GLINT_FN real3 operator+(real3 a, real3 b) {
  return r3_add(a, b);
}
GLINT_FN real3 operator-(real3 a, real3 b) {
  return r3_sub(a, b);
}
GLINT_FN real3 operator-(real3 a) {
  return make_real3(-a.x, -a.y, -a.z);
}
GLINT_FN real3 operator*(real3 a, real3 b) {
  return r3_mul(a, b);
}
GLINT_FN real3 operator*(real3 a, real s) {
  return r3_scale(a, s);
}
GLINT_FN real3 operator*(real s, real3 a) {
  return r3_scale(a, s);
}
GLINT_FN real3 operator/(real3 a, real s) {
  return r3_div(a, s);
}
GLINT_FN real3 &operator+=(real3 &a, real3 b) {
  a = a + b;
  return a;
}
GLINT_FN real dot(real3 a, real3 b) {
  return r3_dot(a, b);
}
GLINT_FN real3 cross(real3 a, real3 b) {
  return r3_cross(a, b);
}
GLINT_FN real length(real3 a) {
  return r3_length(a);
}
GLINT_FN real3 normalize(real3 a) {
  return r3_normalize(a);
}
#endif

/* The value of a uniform `real` (the same in every lane: a material or request parameter) as a
 * scalar of real's precision, `real_scalar`. On the 16-lane device a division or square root of
 * a broadcast value otherwise stays a vector instruction (LLVM does not narrow it), which keeps
 * the divider busy ~10 cycles for one value (PoCL's KEMPPINEN kernel: sqrt(density) and
 * 1e-6 / density per block); as a scalar it is the same IEEE operation, so the same bits, then
 * broadcast. On the host (`real` a scalar, or host lanes) it is the value itself. Only for
 * values that are uniform by construction: lane 0 stands for all. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
#if GLINT_USE_DOUBLE
typedef double real_scalar;
#else
typedef float real_scalar;
#endif
#define GLINT_UNIFORM(x) ((x).s0)
#else
typedef real real_scalar;
#define GLINT_UNIFORM(x) (x)
#endif

/* Literal in the working precision. fp32 device builds also pass
 * -cl-single-precision-constant so literals never force double arithmetic. */
#define GLINT_R(x) ((real)(x))

#define GLINT_PI GLINT_R(3.14159265358979323846)
#define GLINT_INV_PI GLINT_R(0.31830988618379067154)
#define GLINT_SQRT_PI GLINT_R(1.77245385090551602730)

/* sqrt(x) and 1 / sqrt(x) for finite x >= 0 (x > 0 for the reciprocal), and 1 / x
 * (glint_recip_nn below). In kernels that ask for
 * them (GLINT_FAST_ROOTS: the 16-lane entries models/smooth/smooth.cl,
 * models/kemppinen/kemppinen.cl) on a 16-lane fp32 AVX-512 device they are AVX-512's 14-bit
 * reciprocal square root estimate refined by one Newton step, r' = r (3/2 - x r^2 / 2), whose
 * relative error is (3/2) e^2 + e^3 / 2 for an estimate error e < 2^-14 (Intel SDM, VRSQRT14PS),
 * plus the rounding of the step: at most 4 2^-24 relative, 2-4 ulp
 * (tests/kernels/fast_roots_device_test.cpp measures it against long double over every binade).
 * Why: vsqrtps and vdivps on 16 lanes share one unit that takes 10-12 cycles per instruction on
 * this device (Skylake-X), and the conductor probe kernel's 11 square roots and 6 divisions per
 * block kept it busy for most of the block (issue 13); the estimate is a pipelined 2-cycle
 * instruction. Everywhere else (host, fp64, 8 lanes, other devices, the other models' kernels) they
 * are sqrt and 1 / sqrt, correctly rounded on PoCL: the host path, and the device on a CPU without
 * AVX-512, then differ from the AVX-512 device by these few ulp (inside the device-vs-host
 * tolerance); replicas that must agree bit for bit need the same CPU kind, as they already do for
 * PoCL's code generation. GLINT_FAST_ROOTS_ACTIVE says which is compiled. */
#if defined(GLINT_FAST_ROOTS) && defined(__OPENCL_VERSION__) && GLINT_LANES == 16 && \
    !GLINT_USE_DOUBLE && defined(__AVX512F__)
#define GLINT_FAST_ROOTS_ACTIVE 1
/* glint_sqrt_nn for x > 0: x = 0 gives NaN here (the estimate of 1 / sqrt(0) is inf, and 0 * inf),
 * 0 elsewhere. glint_sqrt_nn(x) is glint_select(glint_sqrt_nn_nonzero(x), 0, x == 0), the same
 * operations, so a caller that applies that select only where it matters (F_conductor's rare
 * rescaling, kernels/fresnel.h) gets the same bits. */
GLINT_FN real glint_sqrt_nn_nonzero(real x) {
  /* x rsqrt(x) with the Newton step on the product: s (3/2 - r s / 2), s = x r. */
  real r = __builtin_ia32_rsqrt14ps512_mask(x, (real)(0.0f), (ushort)0xFFFF);
  real s = x * r;
  return s * (GLINT_R(1.5) - GLINT_R(0.5) * r * s);
}
GLINT_FN real glint_sqrt_nn(real x) {
  /* x = 0 gives r = inf and 0 * inf: selected to the exact 0. */
  return glint_select(glint_sqrt_nn_nonzero(x), GLINT_R(0.0), x == GLINT_R(0.0));
}
GLINT_FN real glint_rsqrt_nn(real x) {
  real r = __builtin_ia32_rsqrt14ps512_mask(x, (real)(0.0f), (ushort)0xFFFF);
  /* x r first: x / 2 would lose a subnormal x's last bit. */
  return r * (GLINT_R(1.5) - GLINT_R(0.5) * ((x * r) * r));
}
/* 1 / x for finite x > 0 whose reciprocal is a normal float (x in [2^-126, 2^126]): AVX-512's
 * 14-bit reciprocal estimate (VRCP14PS, |e| < 2^-14) and one Newton step r (2 - x r), relative
 * error e^2 < 2^-28 plus the step's three roundings (x r ~ 1 rounds by 2^-24 into 2 - x r,
 * which rounds once more, and the last product): <= 3 2^-24 + 2^-28
 * (tests/kernels/fast_roots_device_test.cpp). */
GLINT_FN real glint_recip_nn(real x) {
  real r = __builtin_ia32_rcp14ps512_mask(x, (real)(0.0f), (ushort)0xFFFF);
  return r * (GLINT_R(2.0) - x * r);
}
/* a b + c: one fused multiply-add (one rounding) in the same kernels, a product and a sum
 * elsewhere (FP_CONTRACT is off: the host has no FMA in its baseline ISA, -march=x86-64, and
 * host and device should round alike; these kernels already differ from the host by their
 * roots' ulps). For polynomial steps whose own approximation error dwarfs one rounding. */
GLINT_FN real glint_fma_fast(real a, real b, real c) {
  return fma(a, b, c);
}
#else
#define GLINT_FAST_ROOTS_ACTIVE 0
GLINT_FN real glint_sqrt_nn(real x) {
  return sqrt(x);
}
GLINT_FN real glint_sqrt_nn_nonzero(real x) {
  return sqrt(x);
}
GLINT_FN real glint_rsqrt_nn(real x) {
  return GLINT_R(1.0) / sqrt(x);
}
GLINT_FN real glint_recip_nn(real x) {
  return GLINT_R(1.0) / x;
}
GLINT_FN real glint_fma_fast(real a, real b, real c) {
  return a * b + c;
}
#endif

#endif /* GLINT_COMPAT_H */
