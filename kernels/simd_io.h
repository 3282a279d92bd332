/* Block loads and stores for kernels that evaluate GLINT_LANES queries per
 * work-item as the lanes of OpenCL vectors (`real` is float8 / double8 when
 * GLINT_LANES is 8; see compat.h): an array of xyz triples in, one vector per
 * coordinate out, and back. Device only.
 *
 * Why explicit vectors: PoCL runs LLVM -O3, SLP vectoriser included, on the
 * single work-item function before it builds the loop over work-items, so
 * the BRDF's natural wi/wo and RGB symmetries get packed into 2-wide vectors
 * and the loop vectoriser then gives up on the work-item loop ("instruction
 * return type cannot be vectorized"). Vectors in the source make the width
 * independent of those heuristics. */
#ifndef GLINT_SIMD_IO_H
#define GLINT_SIMD_IO_H

#include "kernels/compat.h"
#include "kernels/kernel_args.h"
#include "kernels/query.h"

#if GLINT_LANES == 1

GLINT_FN real3 block_load3(const __global float *a, uint base, uint n) {
  return query_load3(a, base);
}

GLINT_FN void block_store3(__global float *out, uint base, uint n, real3 v) {
  float x = (float)v.x, y = (float)v.y, z = (float)v.z;
  out[3 * base + 0] = GLINT_SATURATE_FLOAT(x);
  out[3 * base + 1] = GLINT_SATURATE_FLOAT(y);
  out[3 * base + 2] = GLINT_SATURATE_FLOAT(z);
}

#elif GLINT_LANES == 8 || GLINT_LANES == 16

/* float vectors of GLINT_LANES lanes; the shuffles below move between 3 of
 * them holding GLINT_LANES interleaved xyz triples and one per coordinate. */
#if GLINT_LANES == 8
typedef float8 floatn;
#define GLINT_VLOADN vload8
#define GLINT_VSTOREN vstore8
#define GLINT_CONVERT_REALN convert_double8
#define GLINT_CONVERT_FLOATN convert_float8
#define GLINT_DEINTERLEAVE_X(p0, p1, p2) (float8)(p0.s036, p1.s147, p2.s25)
#define GLINT_DEINTERLEAVE_Y(p0, p1, p2) (float8)(p0.s147, p1.s25, p2.s036)
#define GLINT_DEINTERLEAVE_Z(p0, p1, p2) (float8)(p0.s25, p1.s036, p2.s147)
#define GLINT_INTERLEAVE_0(x, y, z) (float8)(x.s0, y.s0, z.s0, x.s1, y.s1, z.s1, x.s2, y.s2)
#define GLINT_INTERLEAVE_1(x, y, z) (float8)(z.s2, x.s3, y.s3, z.s3, x.s4, y.s4, z.s4, x.s5)
#define GLINT_INTERLEAVE_2(x, y, z) (float8)(y.s5, z.s5, x.s6, y.s6, z.s6, x.s7, y.s7, z.s7)
#else
typedef float16 floatn;
#define GLINT_VLOADN vload16
#define GLINT_VSTOREN vstore16
#define GLINT_CONVERT_REALN convert_double16
#define GLINT_CONVERT_FLOATN convert_float16
#define GLINT_DEINTERLEAVE_X(p0, p1, p2) \
  (float16)(p0.s0369, p0.scf, p1.s258b, p1.se, p2.s147a, p2.sd)
#define GLINT_DEINTERLEAVE_Y(p0, p1, p2) \
  (float16)(p0.s147a, p0.sd, p1.s0369, p1.scf, p2.s258b, p2.se)
#define GLINT_DEINTERLEAVE_Z(p0, p1, p2) \
  (float16)(p0.s258b, p0.se, p1.s147a, p1.sd, p2.s0369, p2.scf)
#if defined(__has_builtin)
#if __has_builtin(__builtin_shufflevector)
#define GLINT_HAS_SHUFFLEVECTOR 1
#endif
#endif
#ifdef GLINT_HAS_SHUFFLEVECTOR
/* Each output vector as two two-source shuffles (x with y, then the result with z): two
 * shufflevectors, which LLVM lowers to two vpermt2ps with AVX-512. The component-wise
 * vector literals below gave ~50 instructions for the three stores of a block (inserts, blends
 * and masks loaded per block: objdump of PoCL's kernel), a tenth of the smooth probe kernel;
 * the same lanes move to the same places, so the stored bits are the same. -1 marks a lane the
 * second shuffle fills. */
#define GLINT_INTERLEAVE_0(x, y, z)                                                               \
  __builtin_shufflevector(                                                                        \
      __builtin_shufflevector(x, y, 0, 16, -1, 1, 17, -1, 2, 18, -1, 3, 19, -1, 4, 20, -1, 5), z, \
      0, 1, 16, 3, 4, 17, 6, 7, 18, 9, 10, 19, 12, 13, 20, 15)
#define GLINT_INTERLEAVE_1(x, y, z)                                                              \
  __builtin_shufflevector(                                                                       \
      __builtin_shufflevector(x, y, 21, -1, 6, 22, -1, 7, 23, -1, 8, 24, -1, 9, 25, -1, 10, 26), \
      z, 0, 21, 2, 3, 22, 5, 6, 23, 8, 9, 24, 11, 12, 25, 14, 15)
#define GLINT_INTERLEAVE_2(x, y, z)                                                             \
  __builtin_shufflevector(__builtin_shufflevector(x, y, -1, 11, 27, -1, 12, 28, -1, 13, 29, -1, \
                                                  14, 30, -1, 15, 31, -1),                      \
                          z, 26, 1, 2, 27, 4, 5, 28, 7, 8, 29, 10, 11, 30, 13, 14, 31)
#else
#define GLINT_INTERLEAVE_0(x, y, z)                                                             \
  (float16)(x.s0, y.s0, z.s0, x.s1, y.s1, z.s1, x.s2, y.s2, z.s2, x.s3, y.s3, z.s3, x.s4, y.s4, \
            z.s4, x.s5)
#define GLINT_INTERLEAVE_1(x, y, z)                                                             \
  (float16)(y.s5, z.s5, x.s6, y.s6, z.s6, x.s7, y.s7, z.s7, x.s8, y.s8, z.s8, x.s9, y.s9, z.s9, \
            x.sa, y.sa)
#define GLINT_INTERLEAVE_2(x, y, z)                                                             \
  (float16)(z.sa, x.sb, y.sb, z.sb, x.sc, y.sc, z.sc, x.sd, y.sd, z.sd, x.se, y.se, z.se, x.sf, \
            y.sf, z.sf)
#endif
#endif

#if GLINT_USE_DOUBLE
#define GLINT_FLOATS_TO_REAL(v) GLINT_CONVERT_REALN(v)
#define GLINT_REAL_TO_FLOATS(v) GLINT_CONVERT_FLOATN(v) /* round to nearest, like (float) */
#else
#define GLINT_FLOATS_TO_REAL(v) (v)
#define GLINT_REAL_TO_FLOATS(v) (v)
#endif

/* Queries [base, base + GLINT_LANES) of an array of xyz triples, in lanes:
 * three contiguous vector loads and shuffles. In the last, partial block the
 * lanes past n repeat query n - 1 (finite work, never stored). */
GLINT_FN real3 block_load3(const __global float *a, uint base, uint n) {
  floatn p0, p1, p2;
  if (base + GLINT_LANES <= n) {
    const __global float *s = a + 3 * (size_t)base;
    p0 = GLINT_VLOADN(0, s);
    p1 = GLINT_VLOADN(1, s);
    p2 = GLINT_VLOADN(2, s);
  } else {
    float t[3 * GLINT_LANES];
    for (uint k = 0; k < GLINT_LANES; ++k) {
      size_t j = 3 * (size_t)min(base + k, n - 1);
      t[3 * k + 0] = a[j + 0];
      t[3 * k + 1] = a[j + 1];
      t[3 * k + 2] = a[j + 2];
    }
    p0 = GLINT_VLOADN(0, t);
    p1 = GLINT_VLOADN(1, t);
    p2 = GLINT_VLOADN(2, t);
  }
  return make_real3(GLINT_FLOATS_TO_REAL(GLINT_DEINTERLEAVE_X(p0, p1, p2)),
                    GLINT_FLOATS_TO_REAL(GLINT_DEINTERLEAVE_Y(p0, p1, p2)),
                    GLINT_FLOATS_TO_REAL(GLINT_DEINTERLEAVE_Z(p0, p1, p2)));
}

/* The inverse: lanes back to xyz triples; only queries < n are written. */
GLINT_FN void block_store3(__global float *out, uint base, uint n, real3 v) {
  /* Saturated at FLT_MAX, NaN kept (GLINT_SATURATE_FLOAT, kernels/kernel_args.h). */
  const floatn max = (floatn)(FLT_MAX);
  floatn x = GLINT_REAL_TO_FLOATS(v.x);
  floatn y = GLINT_REAL_TO_FLOATS(v.y);
  floatn z = GLINT_REAL_TO_FLOATS(v.z);
  x = select(x, max, x > max);
  y = select(y, max, y > max);
  z = select(z, max, z > max);
  floatn q0 = GLINT_INTERLEAVE_0(x, y, z);
  floatn q1 = GLINT_INTERLEAVE_1(x, y, z);
  floatn q2 = GLINT_INTERLEAVE_2(x, y, z);
  if (base + GLINT_LANES <= n) {
    /* Whole vectors through a 4-byte-aligned vector type: one unaligned store each. PoCL's
     * vstore16 became three stores per vector (4 + 4 + 8 floats, with two extracts), 9
     * instructions per block where 3 do (objdump of the smooth kernel, issue 13). */
    typedef floatn __attribute__((aligned(4))) floatn_unaligned;
    __global floatn_unaligned *d = (__global floatn_unaligned *)(out + 3 * (size_t)base);
    d[0] = q0;
    d[1] = q1;
    d[2] = q2;
  } else {
    float t[3 * GLINT_LANES];
    GLINT_VSTOREN(q0, 0, t);
    GLINT_VSTOREN(q1, 1, t);
    GLINT_VSTOREN(q2, 2, t);
    for (uint k = 0; base + k < n; ++k) {
      size_t j = 3 * (size_t)(base + k);
      out[j + 0] = t[3 * k + 0];
      out[j + 1] = t[3 * k + 1];
      out[j + 2] = t[3 * k + 2];
    }
  }
}

#else
#error "kernels/simd_io.h supports GLINT_LANES 1, 8 and 16"
#endif

/* The query inputs of the block of queries [base, base + GLINT_LANES): the
 * GLINT_LANES-wide counterpart of query_load (kernels/query.h). */
GLINT_FN QueryInputs block_load_queries(EvalSpec spec, KernelInputs in, uint base) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  QueryInputs q;
  q.wo = block_load3(in.wo, base, in.n);
  q.wi = zero;
  q.position = zero;
  q.normal = zero;
  q.tangent = zero;
  if (spec.probe) q.wi = block_load3(in.wi, base, in.n);
  if (spec.has_frame) {
    q.position = block_load3(in.position, base, in.n);
    q.normal = block_load3(in.normal, base, in.n);
    q.tangent = block_load3(in.tangent, base, in.n);
  }
  return q;
}

#endif /* GLINT_SIMD_IO_H */
