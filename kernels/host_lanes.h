/* The host path with lanes (issue 13): `real` as a C++ class holding GLINT_HOST_LANES values in a
 * GCC vector, so that the portable headers, written for OpenCL vectors on the device (compat.h),
 * compile for the host as the same SIMD code: one call evaluates GLINT_HOST_LANES queries, like a
 * device work-item. Included by compat.h (C++ only) when GLINT_HOST_LANES > 1; the translation
 * unit that defines it (models/smooth/host_lanes.cpp) also gets -ffp-contract=off, so every lane
 * rounds exactly like the scalar host path (no FMA contraction) and the results are bit-identical
 * to it (tests/service/host_lanes_test.cpp).
 *
 * What the headers use, per lane: + - * /, comparisons giving glint_mask (lanes of 0 / -1), | & !
 * on masks, glint_select (a per-lane choice), glint_any, casts from scalars (broadcast) and the
 * math functions below (lane by lane through the same <cmath> calls as the scalar path). */
#ifndef GLINT_HOST_LANES_H
#define GLINT_HOST_LANES_H

#include <cstdint>

#if GLINT_USE_DOUBLE
typedef double glint_lane_t;
typedef int64_t glint_lane_mask_t;
#else
typedef float glint_lane_t;
typedef int32_t glint_lane_mask_t;
#endif
typedef glint_lane_t glint_lane_vec
    __attribute__((vector_size(GLINT_HOST_LANES * sizeof(glint_lane_t))));
typedef glint_lane_mask_t glint_lane_mvec
    __attribute__((vector_size(GLINT_HOST_LANES * sizeof(glint_lane_t))));

/* Everything inlined into the one dispatching loop (host_lanes.cpp), whose target_clones then
 * compile all of it for AVX-512, AVX2 or the baseline. */
#define GLINT_FN inline __attribute__((always_inline))
#define GLINT_LANE_FN inline __attribute__((always_inline))

struct real {
  glint_lane_vec v;
  real() = default;
  /* Broadcast: (real)x and GLINT_R(x), as OpenCL's scalar-to-vector conversion. */
  GLINT_LANE_FN real(double x) : v(glint_lane_vec{} + (glint_lane_t)x) {}
  GLINT_LANE_FN static real of(glint_lane_vec x) {
    real r;
    r.v = x;
    return r;
  }
};

struct glint_mask {
  glint_lane_mvec m;
};

GLINT_LANE_FN real operator+(real a, real b) {
  return real::of(a.v + b.v);
}
GLINT_LANE_FN real operator-(real a, real b) {
  return real::of(a.v - b.v);
}
GLINT_LANE_FN real operator*(real a, real b) {
  return real::of(a.v * b.v);
}
GLINT_LANE_FN real operator/(real a, real b) {
  return real::of(a.v / b.v);
}
GLINT_LANE_FN real operator-(real a) {
  return real::of(-a.v);
}
GLINT_LANE_FN real &operator+=(real &a, real b) {
  a.v += b.v;
  return a;
}
GLINT_LANE_FN real &operator-=(real &a, real b) {
  a.v -= b.v;
  return a;
}
GLINT_LANE_FN real &operator*=(real &a, real b) {
  a.v *= b.v;
  return a;
}
GLINT_LANE_FN real &operator/=(real &a, real b) {
  a.v /= b.v;
  return a;
}

GLINT_LANE_FN glint_mask operator<(real a, real b) {
  return {a.v < b.v};
}
GLINT_LANE_FN glint_mask operator<=(real a, real b) {
  return {a.v <= b.v};
}
GLINT_LANE_FN glint_mask operator>(real a, real b) {
  return {a.v > b.v};
}
GLINT_LANE_FN glint_mask operator>=(real a, real b) {
  return {a.v >= b.v};
}
GLINT_LANE_FN glint_mask operator==(real a, real b) {
  return {a.v == b.v};
}
GLINT_LANE_FN glint_mask operator!=(real a, real b) {
  return {a.v != b.v};
}
GLINT_LANE_FN glint_mask operator|(glint_mask a, glint_mask b) {
  return {a.m | b.m};
}
GLINT_LANE_FN glint_mask operator&(glint_mask a, glint_mask b) {
  return {a.m & b.m};
}
GLINT_LANE_FN glint_mask operator!(glint_mask a) {
  return {a.m == 0};
}

/* OpenCL's select(a, b, c): c ? b : a per lane. */
GLINT_LANE_FN real glint_select(real a, real b, glint_mask c) {
  return real::of(c.m ? b.v : a.v);
}
GLINT_LANE_FN bool glint_mask_any(glint_mask c) {
  for (int i = 0; i < GLINT_HOST_LANES; ++i)
    if (c.m[i]) return true;
  return false;
}
#define glint_any(c) glint_mask_any(c)

/* Math functions lane by lane through the scalar path's own <cmath> calls (bit-identical). */
#define GLINT_LANEWISE1(fn)                                              \
  GLINT_LANE_FN real fn(real x) {                                        \
    real r;                                                              \
    for (int i = 0; i < GLINT_HOST_LANES; ++i) r.v[i] = std::fn(x.v[i]); \
    return r;                                                            \
  }
#define GLINT_LANEWISE2(fn)                                                      \
  GLINT_LANE_FN real fn(real x, real y) {                                        \
    real r;                                                                      \
    for (int i = 0; i < GLINT_HOST_LANES; ++i) r.v[i] = std::fn(x.v[i], y.v[i]); \
    return r;                                                                    \
  }
GLINT_LANEWISE1(exp)
GLINT_LANEWISE1(exp2)
GLINT_LANEWISE1(expm1)
GLINT_LANEWISE1(log)
GLINT_LANEWISE1(log2)
GLINT_LANEWISE1(log1p)
GLINT_LANEWISE1(erf)
GLINT_LANEWISE1(erfc)
GLINT_LANEWISE1(floor)
GLINT_LANEWISE1(sin)
GLINT_LANEWISE1(cos)
GLINT_LANEWISE1(asin)
GLINT_LANEWISE1(acos)
GLINT_LANEWISE2(pow)
GLINT_LANEWISE2(atan2)
#undef GLINT_LANEWISE1
#undef GLINT_LANEWISE2

/* The ones on the hot path as vector operations, with the scalar functions' exact values. */
GLINT_LANE_FN real sqrt(real x) {
  /* Correctly rounded; with -fno-math-errno the loop can become one vsqrtps. */
  real r;
  for (int i = 0; i < GLINT_HOST_LANES; ++i) r.v[i] = std::sqrt(x.v[i]);
  return r;
}
GLINT_LANE_FN real fabs(real x) {
  /* Clear the sign bit (fabs(-0) = +0, NaN stays NaN). */
  const glint_lane_mask_t sign = glint_lane_mask_t(1) << (8 * sizeof(glint_lane_t) - 1);
  const glint_lane_mvec magnitude = glint_lane_mvec{} + ~sign;
  return real::of((glint_lane_vec)((glint_lane_mvec)x.v & magnitude));
}
/* glibc's fmax / fmin on x86-64: x when x >= y (so fmax(-0, +0) = -0) or when y is NaN, else y. */
GLINT_LANE_FN real fmax(real x, real y) {
  return real::of(((x.v >= y.v) | (y.v != y.v)) ? x.v : y.v);
}
GLINT_LANE_FN real fmin(real x, real y) {
  return real::of(((x.v <= y.v) | (y.v != y.v)) ? x.v : y.v);
}

GLINT_LANE_FN glint_mask isfinite(real x) {
  glint_mask r;
  for (int i = 0; i < GLINT_HOST_LANES; ++i) r.m[i] = std::isfinite(x.v[i]) ? -1 : 0;
  return r;
}

#endif /* GLINT_HOST_LANES_H */
