/* Portability layer: the BRDF headers in kernels/ compile as OpenCL C (device)
 * and as C++ (host scalar path and tests). Only this file knows which.
 *
 * `real` is float or double, chosen by GLINT_USE_DOUBLE (0 or 1), so tests can
 * run the same math in double. The shared headers use the common subset of
 * OpenCL C 1.2 and C++: no templates, references, overloads or classes.
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
typedef double real;
typedef double3 real3;
#else
typedef float real;
typedef float3 real3;
#endif
/* Inline everything into the entry point: PoCL vectorises across work-items
 * only in loops without calls. */
#define GLINT_FN inline __attribute__((always_inline))
#define GLINT_GLOBAL __global
#define GLINT_CONSTANT __constant
#define GLINT_PRIVATE __private
#define glint_assert(x)

GLINT_FN real3 make_real3(real x, real y, real z) { return (real3)(x, y, z); }

#else
/* ------------------------------- C++ ----------------------------------- */
#include <cassert>
#include <cmath>

#if GLINT_USE_DOUBLE
typedef double real;
#else
typedef float real;
#endif
#define GLINT_FN inline
#define GLINT_GLOBAL
#define GLINT_CONSTANT
#define GLINT_PRIVATE
#define glint_assert(x) assert(x)

using std::acos;
using std::atan2;
using std::cos;
using std::erf;
using std::erfc;
using std::exp;
using std::fabs;
using std::fmax;
using std::fmin;
using std::isfinite;
using std::log;
using std::pow;
using std::sin;
using std::sqrt;

typedef unsigned int uint;

struct real3 {
  real x, y, z;
};
GLINT_FN real3 make_real3(real x, real y, real z) {
  real3 v = {x, y, z};
  return v;
}
GLINT_FN real3 operator+(real3 a, real3 b) { return make_real3(a.x + b.x, a.y + b.y, a.z + b.z); }
GLINT_FN real3 operator-(real3 a, real3 b) { return make_real3(a.x - b.x, a.y - b.y, a.z - b.z); }
GLINT_FN real3 operator-(real3 a) { return make_real3(-a.x, -a.y, -a.z); }
GLINT_FN real3 operator*(real3 a, real3 b) { return make_real3(a.x * b.x, a.y * b.y, a.z * b.z); }
GLINT_FN real3 operator*(real3 a, real s) { return make_real3(a.x * s, a.y * s, a.z * s); }
GLINT_FN real3 operator*(real s, real3 a) { return a * s; }
GLINT_FN real3 operator/(real3 a, real s) { return make_real3(a.x / s, a.y / s, a.z / s); }
GLINT_FN real3 &operator+=(real3 &a, real3 b) {
  a = a + b;
  return a;
}
GLINT_FN real dot(real3 a, real3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
GLINT_FN real3 cross(real3 a, real3 b) {
  return make_real3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
GLINT_FN real length(real3 a) { return sqrt(dot(a, a)); }
GLINT_FN real3 normalize(real3 a) { return a / length(a); }
GLINT_FN real clamp(real x, real lo, real hi) { return fmin(fmax(x, lo), hi); }
#endif

/* Literal in the working precision. fp32 device builds also pass
 * -cl-single-precision-constant so literals never force double arithmetic. */
#define R(x) ((real)(x))

#define GLINT_PI R(3.14159265358979323846)
#define GLINT_INV_PI R(0.31830988618379067154)
#define GLINT_SQRT_PI R(1.77245385090551602730)

#endif /* GLINT_COMPAT_H */
