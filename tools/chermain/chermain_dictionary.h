// Generator of the Chermain et al. 2020 dictionary of multiscale 1D marginal
// slope distributions (paper Sec. 4.4-4.5 and 7.3), our own implementation:
//
//  - marginal m draws 2^(LEVELS-1) lobe means mu_k ~ N(0, alpha_dict^2 / 2)
//    (importance sampling of the Beckmann marginal of alpha_dict, Sec. 4.4)
//    from its own splitmix64 stream (Steele et al. 2014) seeded by (seed, m),
//    normals by Box-Muller;
//  - level l is the even mixture of the first 2^l means, each with its mirror
//    image: P(x, l) = 2^-l sum_{k < 2^l} (g(x - mu_k) + g(x + mu_k)) / 2, with
//    g a Gaussian lobe of std GLINT_CHERMAIN_LOBE_SIGMA (0.02);
//  - it is tabulated at BINS nodes x_j = j X_MAX / (BINS - 1) (x >= 0) and
//    normalised so that its piecewise-linear interpolant, zero beyond X_MAX,
//    integrates to 1 over the real line (Sec. 7.3: "normalised assuming
//    linear interpolation"); the kernel interpolates the same way.
//
// Lobes are evaluated within 10 sigma of their mean (exp(-50) ~ 2e-22 beyond).
// Everything is in double with a fixed summation order; the only library
// functions are exp, log, cos and sqrt, so the output is bit-reproducible for
// a given libm (glibc here); data/chermain/README.md has the command and the
// digest, and tests/chermain regenerates the data and compares bit for bit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace glint::chermain {

struct DictionaryConfig {
  uint64_t seed = 20200601;
  int marginals = 512;  // N
};

// GLINT_CHERMAIN_LEVELS x GLINT_CHERMAIN_BINS floats of marginal `m`
// (layout of models/chermain/chermain_params.h).
std::vector<float> GenerateMarginal(uint64_t seed, int m);

// The whole dictionary: marginals 0 .. config.marginals - 1 in order.
std::vector<float> GenerateDictionary(const DictionaryConfig &config, int threads = 1);

// 64-bit FNV-1a over the floats' little-endian bytes: the digest the data's
// README states and the tests check.
uint64_t DictionaryDigest(const float *data, size_t count);

// Piecewise-linear evaluation of one tabulated level at |x| (zero beyond
// X_MAX), the same rule as the kernel (models/chermain/chermain_eval.h).
double EvalMarginal(const float *level, double x);

}  // namespace glint::chermain
