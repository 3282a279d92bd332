// The checked-in Chermain et al. 2020 dictionary (data/chermain/) against its
// generator and against the distribution it samples (paper Sec. 4.4-4.5, 7.3):
//  - the data is what the documented command writes, bit for bit, and has the
//    stated digest;
//  - every marginal at every level integrates to 1 under linear interpolation
//    (Eq. 4 for the product of two marginals), by an independent fine
//    quadrature of the interpolant the kernel evaluates;
//  - each level converges to the Beckmann marginal of alpha_dict (smoothed by
//    the lobe width): the L1 distance per level is bounded by the closed-form
//    standard deviation of a 2^l-lobe mixture, and the mean over all
//    marginals has no bias beyond its own sampling error.
#include "data/chermain/chermain_dictionary.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <vector>

#include "models/chermain/chermain_params.h"
#include "tools/chermain/chermain_dictionary.h"

namespace {

using glint::chermain_data::dictionary;
constexpr int kN = GLINT_CHERMAIN_MAX_DICTIONARY;
constexpr int kLevels = GLINT_CHERMAIN_LEVELS;
constexpr int kBins = GLINT_CHERMAIN_BINS;
constexpr double kStep = GLINT_CHERMAIN_X_MAX / (kBins - 1);
constexpr double kSl = GLINT_CHERMAIN_LOBE_SIGMA;
constexpr double kSt = GLINT_CHERMAIN_ALPHA_DICT / std::numbers::sqrt2;

const float *Level(int m, int l) {
  return dictionary() + (size_t(m) * kLevels + l) * kBins;
}

double Normal(double x, double var) {
  return std::exp(-x * x / (2 * var)) / std::sqrt(2 * std::numbers::pi * var);
}

// Trapezoid L1 distance over the real line between two even node tables.
double L1(const double *a, const double *b) {
  double s = 0;
  for (int j = 0; j < kBins; ++j)
    s += (j == 0 || j == kBins - 1 ? 0.5 : 1.0) * std::fabs(a[j] - b[j]);
  return 2 * kStep * s;
}

TEST(ChermainDictionary, DigestMatchesReadme) {
  EXPECT_EQ(glint::chermain::DictionaryDigest(dictionary(), glint::chermain_data::kFloats),
            glint::chermain_data::kDigest);
}

TEST(ChermainDictionary, RegeneratingReproducesTheDataBitForBit) {
  glint::chermain::DictionaryConfig config;
  config.seed = glint::chermain_data::kSeed;
  config.marginals = kN;
  const std::vector<float> regenerated = glint::chermain::GenerateDictionary(config, 2);
  ASSERT_EQ(regenerated.size(), glint::chermain_data::kFloats);
  EXPECT_EQ(std::memcmp(regenerated.data(), dictionary(), regenerated.size() * sizeof(float)), 0);
  // A smaller dictionary is a prefix of a larger one (one stream per marginal): the first 192
  // marginals are the dictionary shipped before the 512 one (its digest, data/chermain/README.md).
  EXPECT_EQ(glint::chermain::DictionaryDigest(dictionary(), size_t(192) * kLevels * kBins),
            0x2163317ec204fa75ull);
  config.marginals = 16;
  const std::vector<float> small = glint::chermain::GenerateDictionary(config, 1);
  EXPECT_EQ(std::memcmp(small.data(), dictionary(), small.size() * sizeof(float)), 0);
}

// Eq. 4 for the product of two marginals holds iff each integrates to 1. The
// interpolant is linear between nodes, so a midpoint rule on 16 sub-intervals
// per node interval is exact up to rounding (~1e-15); what remains is the
// rounding of the stored floats (relative 2^-24 each, all positive: <= 6e-8).
TEST(ChermainDictionary, EveryMarginalIntegratesToOne) {
  double worst = 0;
  for (int m = 0; m < kN; ++m) {
    for (int l = 0; l < kLevels; ++l) {
      const float *row = Level(m, l);
      const int sub = 16;
      const double h = kStep / sub;
      double s = 0;
      for (int k = 0; k < (kBins - 1) * sub; ++k)
        s += glint::chermain::EvalMarginal(row, (k + 0.5) * h);
      const double integral = 2 * h * s;  // even: both half-lines
      worst = std::fmax(worst, std::fabs(integral - 1));
      ASSERT_NEAR(integral, 1.0, 1e-6) << "marginal " << m << " level " << l;
    }
  }
  std::printf("worst |integral - 1| over %d marginals x %d levels: %.3g\n", kN, kLevels, worst);
}

// Level l of a marginal is the even mixture of 2^l lobes h(x, mu) =
// (g(x - mu) + g(x + mu)) / 2, mu ~ N(0, st^2), g = N(0, sl^2). Its mean is
// f(x) = N(x; 0, st^2 + sl^2) (the Beckmann marginal smoothed by the lobe), its
// variance Var(x) = (E[h^2] - f^2) / 2^l with, in closed form,
//   E[g(x - mu)^2]          = N(x; 0, st^2 + sl^2 / 2) / (2 sqrt(pi) sl),
//   E[g(x - mu) g(x + mu)]  = exp(-x^2 / sl^2) / (2 pi sl^2 sqrt(1 + 2 st^2 / sl^2)).
// Jensen: E|P - f| <= sqrt(Var), so the expected L1 distance per level is at
// most B(l) = int sqrt(Var(x)) dx; the mean over the N = 192 independent
// marginals of their L1 distances concentrates at or below E[L1] <= B(l).
// Bias test: the average of all N marginals at node x_j is a mean of N 2^l
// independent lobes, so z_j = (mean_j - f_j) / sqrt(Var_j / N) is ~N(0, 1)
// (where at least 20 lobes are expected nearby, for the central limit); over
// 64 nodes x 16 levels |z| <= 4.5 has family-wise false-alarm probability
// <= 1024 x 6.8e-6 = 0.7% (Bonferroni). A wrong alpha_dict or lobe width would
// give |z| in the tens at the coarse levels.
TEST(ChermainDictionary, LevelsConvergeToTheBeckmannMarginal) {
  double target[kBins], bound_sq[kBins];
  double tnorm = 0;
  for (int j = 0; j < kBins; ++j) {
    const double x = j * kStep;
    target[j] = Normal(x, kSt * kSt + kSl * kSl);
    const double eg2 =
        Normal(x, kSt * kSt + kSl * kSl / 2) / (2 * std::sqrt(std::numbers::pi) * kSl);
    const double egg =
        std::exp(-x * x / (kSl * kSl)) /
        (2 * std::numbers::pi * kSl * kSl * std::sqrt(1 + 2 * kSt * kSt / (kSl * kSl)));
    const double eh2 = 0.5 * eg2 + 0.5 * egg;
    bound_sq[j] = eh2 - target[j] * target[j];
    tnorm += (j == 0 || j == kBins - 1 ? 0.5 : 1.0) * target[j];
  }
  // The tables are normalised on [-4 st, 4 st]; so is the target (it loses 6e-5 of its mass).
  tnorm *= 2 * kStep;
  for (double &t : target) t /= tnorm;
  std::printf("level  mean L1(P_i, target)  bound B(l)  L1(mean_i P_i, target)  max |z|\n");
  for (int l = 0; l < kLevels; ++l) {
    double sd[kBins], sd_mean[kBins], zero[kBins] = {}, mean[kBins] = {};
    for (int j = 0; j < kBins; ++j) {
      sd[j] = std::sqrt(bound_sq[j] / std::ldexp(1.0, l));
      sd_mean[j] = sd[j] / std::sqrt(double(kN));
    }
    double mean_l1 = 0;
    for (int m = 0; m < kN; ++m) {
      double row[kBins];
      for (int j = 0; j < kBins; ++j) {
        row[j] = Level(m, l)[j];
        mean[j] += row[j] / kN;
      }
      mean_l1 += L1(row, target) / kN;
    }
    const double bound = L1(sd, zero);
    const double mean_of_all = L1(mean, target);
    double max_z = 0;
    for (int j = 0; j < kBins; ++j) {
      // The normal law needs many lobes near x_j: in the far tail (fewer than 20
      // expected within +-2 lobe widths) one lobe more or less is a large z.
      const double lobes_near = kN * std::ldexp(1.0, l) * target[j] * 4 * kSl;
      if (lobes_near >= 20) max_z = std::fmax(max_z, std::fabs(mean[j] - target[j]) / sd_mean[j]);
    }
    std::printf("%5d  %20.4f  %10.4f  %22.5f  %7.2f\n", l, mean_l1, bound, mean_of_all, max_z);
    EXPECT_LE(mean_l1, bound) << "level " << l;
    EXPECT_LE(max_z, 4.5) << "level " << l;
  }
}

}  // namespace
