/* Counter-based random numbers: every random value is a pure function of
 * integer keys (the request seed, a cell or sample index, a level, ...), never
 * of query order, chunking or thread id. This is what makes results
 * bit-identical however a request is split (DESIGN.md, "Determinism").
 *
 * The mixer is Wellons' "lowbias32" (hash-prospector, 2020: xor-shift /
 * multiply rounds with constants found by search for low avalanche bias,
 * bias ~0.17 on the full 32-bit domain), 32-bit only so it is the same on
 * every OpenCL device and on the host. Keys are absorbed one at a time,
 * sponge-style: h = mix(h ^ (key + golden * (i + 1))), so permuting keys
 * changes the stream. */
#ifndef GLINT_RNG_H
#define GLINT_RNG_H

#include "kernels/compat.h"

/* The mixer and the absorb step, written once for scalar keys and for the
 * lane keys at the end of this file. */
#define GLINT_RNG_MIX(x) \
  x ^= x >> 16;          \
  x *= 0x7feb352du;      \
  x ^= x >> 15;          \
  x *= 0x846ca68bu;      \
  x ^= x >> 16
#define GLINT_RNG_ABSORB(mix, h, key) (mix((h) ^ ((key) + 0x9e3779b9u)) + 0x632be5abu)

GLINT_FN uint rng_mix(uint x) {
  GLINT_RNG_MIX(x);
  return x;
}

/* Absorbs one more key into the running hash `h`. */
GLINT_FN uint rng_absorb(uint h, uint key) {
  return GLINT_RNG_ABSORB(rng_mix, h, key);
}

GLINT_FN uint rng_hash2(uint a, uint b) {
  return rng_mix(rng_absorb(rng_absorb(0u, a), b));
}
GLINT_FN uint rng_hash3(uint a, uint b, uint c) {
  return rng_mix(rng_absorb(rng_absorb(rng_absorb(0u, a), b), c));
}

/* Uniform in [0, 1) with 24 random bits: k * 2^-24 is exact in float and in
 * double, so fp32 and fp64 kernels see the same numbers. */
GLINT_FN real rng_u01(uint h) {
  return (real)(h >> 8) * GLINT_R(5.9604644775390625e-8);
}

/* The bit pattern of a float, to key random streams by input values (a
 * query's uv) rather than by its position in the batch. -0 is folded to +0 so
 * that equal values give equal keys. */
GLINT_FN uint rng_float_key(float f) {
  f = f == 0.0f ? 0.0f : f;
#ifdef __OPENCL_VERSION__
  return as_uint(f);
#else
  uint u;
  /* the builtin, not std::memcpy: these headers may be included inside a
   * namespace (server/host_path_f32.cpp), where no standard header can be. */
  __builtin_memcpy(&u, &f, sizeof u);
  return u;
#endif
}

/* Keys of per-lane values, for kernels that evaluate GLINT_LANES queries per
 * work-item (compat.h): glint_key is uint on the host and in one-query
 * kernels, the uint vector of GLINT_LANES lanes in lane kernels, and the
 * *_key functions are rng_mix, rng_absorb, rng_u01 and rng_float_key on it
 * (the same arithmetic lane by lane, so a lane's stream is the scalar one).
 * rng_real_key keys a `real` by the bits of its float rounding. */
#if defined(__OPENCL_VERSION__) && GLINT_LANES > 1
#if GLINT_LANES == 8
typedef uint8 glint_key;
typedef float8 glint_key_floats;
#define GLINT_KEY_AS_KEY as_uint8
#define GLINT_KEY_TO_FLOATS convert_float8
#define GLINT_KEY_TO_DOUBLES convert_double8
#else
typedef uint16 glint_key;
typedef float16 glint_key_floats;
#define GLINT_KEY_AS_KEY as_uint16
#define GLINT_KEY_TO_FLOATS convert_float16
#define GLINT_KEY_TO_DOUBLES convert_double16
#endif
#if GLINT_USE_DOUBLE
#define GLINT_KEY_TO_REAL GLINT_KEY_TO_DOUBLES
#else
#define GLINT_KEY_TO_REAL GLINT_KEY_TO_FLOATS
#endif

GLINT_FN glint_key rng_mix_key(glint_key x) {
  GLINT_RNG_MIX(x);
  return x;
}
GLINT_FN glint_key rng_absorb_key(glint_key h, glint_key key) {
  return GLINT_RNG_ABSORB(rng_mix_key, h, key);
}
GLINT_FN real rng_u01_key(glint_key h) {
  return GLINT_KEY_TO_REAL(h >> 8) * GLINT_R(5.9604644775390625e-8);
}
GLINT_FN glint_key rng_real_key(real c) {
  /* round to nearest as (float) does; -0 folded to +0 as in rng_float_key */
#if GLINT_USE_DOUBLE
  glint_key_floats f = GLINT_KEY_TO_FLOATS(c);
#else
  glint_key_floats f = c;
#endif
  return GLINT_KEY_AS_KEY(select(f, (glint_key_floats)(0.0f), f == 0.0f));
}
#else
typedef uint glint_key;
#define rng_mix_key rng_mix
#define rng_absorb_key rng_absorb
#define rng_u01_key rng_u01
GLINT_FN uint rng_real_key(real c) {
  return rng_float_key((float)c);
}
#endif

#endif /* GLINT_RNG_H */
