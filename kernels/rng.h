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

GLINT_FN uint rng_mix(uint x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

/* Absorbs one more key into the running hash `h`. */
GLINT_FN uint rng_absorb(uint h, uint key) {
  return rng_mix(h ^ (key + 0x9e3779b9u)) + 0x632be5abu;
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

#endif /* GLINT_RNG_H */
