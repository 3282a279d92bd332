#include "tools/chermain/chermain_dictionary.h"

#include <cmath>
#include <cstring>
#include <numbers>
#include <thread>

#include "models/chermain/chermain_params.h"

namespace glint::chermain {
namespace {

constexpr int kLevels = GLINT_CHERMAIN_LEVELS;
constexpr int kBins = GLINT_CHERMAIN_BINS;
constexpr double kXMax = GLINT_CHERMAIN_X_MAX;
constexpr double kStep = kXMax / (kBins - 1);
constexpr double kLobeSigma = GLINT_CHERMAIN_LOBE_SIGMA;
constexpr double kTargetSigma = GLINT_CHERMAIN_ALPHA_DICT / std::numbers::sqrt2;

// splitmix64 (Steele, Lea & Flood 2014): a 64-bit counter through a fixed mixer.
struct SplitMix64 {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  // Uniform in (0, 1]: 53 random bits, never 0 (Box-Muller takes its log).
  double uniform() { return (double(next() >> 11) + 1.0) * 0x1.0p-53; }
};

// Adds the lobe pair g(x - mu) + g(x + mu) (without the 1/2) to the nodes.
void AddLobePair(double mu, double *sum) {
  const double inv_two_var = 1.0 / (2.0 * kLobeSigma * kLobeSigma);
  const double norm = 1.0 / (std::sqrt(2.0 * std::numbers::pi) * kLobeSigma);
  const double reach = 10.0 * kLobeSigma;
  for (double c : {mu, -mu}) {
    int lo = int(std::ceil((c - reach) / kStep));
    int hi = int(std::floor((c + reach) / kStep));
    if (lo < 0) lo = 0;
    if (hi > kBins - 1) hi = kBins - 1;
    for (int j = lo; j <= hi; ++j) {
      const double d = j * kStep - c;
      sum[j] += norm * std::exp(-d * d * inv_two_var);
    }
  }
}

}  // namespace

std::vector<float> GenerateMarginal(uint64_t seed, int m) {
  SplitMix64 rng{seed ^ (0xd1b54a32d192ed03ull * uint64_t(m + 1))};
  const int n_means = 1 << (kLevels - 1);
  std::vector<double> means(size_t(n_means), 0.0);
  for (int k = 0; k < n_means; k += 2) {
    // Box-Muller: two independent normals from two uniforms.
    const double r = std::sqrt(-2.0 * std::log(rng.uniform()));
    const double phi = 2.0 * std::numbers::pi * rng.uniform();
    means[size_t(k)] = kTargetSigma * r * std::cos(phi);
    means[size_t(k) + 1] = kTargetSigma * r * std::sin(phi);
  }
  std::vector<float> out(size_t(kLevels) * kBins);
  double sum[kBins] = {};
  int used = 0;
  for (int level = 0; level < kLevels; ++level) {
    for (; used < (1 << level); ++used) AddLobePair(means[size_t(used)], sum);
    // Trapezoid integral of the even interpolant over R: 2 * step * (sum - ends / 2).
    double integral = 0.0;
    for (int j = 0; j < kBins; ++j) integral += (j == 0 || j == kBins - 1) ? 0.5 * sum[j] : sum[j];
    integral *= 2.0 * kStep;
    float *row = out.data() + size_t(level) * kBins;
    for (int j = 0; j < kBins; ++j) row[j] = float(sum[j] / integral);
  }
  return out;
}

std::vector<float> GenerateDictionary(const DictionaryConfig &config, int threads) {
  const size_t per = size_t(kLevels) * kBins;
  std::vector<float> out(per * size_t(config.marginals));
  if (threads < 1) threads = 1;
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      for (int m = t; m < config.marginals; m += threads) {
        const std::vector<float> one = GenerateMarginal(config.seed, m);
        std::memcpy(out.data() + per * size_t(m), one.data(), per * sizeof(float));
      }
    });
  }
  for (auto &th : pool) th.join();
  return out;
}

uint64_t DictionaryDigest(const float *data, size_t count) {
  uint64_t h = 0xcbf29ce484222325ull;
  for (size_t i = 0; i < count; ++i) {
    uint32_t bits;
    std::memcpy(&bits, &data[i], sizeof bits);
    for (int b = 0; b < 4; ++b) {
      h ^= (bits >> (8 * b)) & 0xffu;
      h *= 0x100000001b3ull;
    }
  }
  return h;
}

double EvalMarginal(const float *level, double x) {
  const double t = std::fabs(x) / kStep;
  if (!(t <= kBins - 1)) return 0.0;
  int k = int(t);
  if (k > kBins - 2) k = kBins - 2;
  const double f = t - k;
  return (1.0 - f) * level[k] + f * level[k + 1];
}

}  // namespace glint::chermain
