// Sample statistics of the Kemppinen kernel tests (mean, unbiased variance, standard error of
// the mean: the tolerances of the statistical tests are multiples of se()), and the NDF's name
// and the neighbourhood's names for messages, the cheap erfc's bounds. Included after
// tests/support/kernels_both_precisions.h (GLINT_NDF_BECKMANN, GLINT_KEMPPINEN_NEIGHBORHOOD_*).
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

namespace glint::test {
struct Stats {
  double mean = 0, var = 0;
  size_t n = 0;
  double se() const { return std::sqrt(var / double(n)); }
  double spread() const { return std::sqrt(var) / mean; }
};
inline Stats Summarise(const std::vector<double> &x) {
  Stats s;
  s.n = x.size();
  for (double v : x) s.mean += v;
  s.mean /= double(x.size());
  for (double v : x) s.var += (v - s.mean) * (v - s.mean);
  s.var /= double(x.size() - 1);
  return s;
}

inline const char *HoodName(int hood) {
  return hood == GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL    ? "ONE_CELL"
         : hood == GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL ? "ONE_LEVEL"
                                                          : "PAPER";
}

// A&S 7.1.27's bound on |erf error|, so on erfc's.
inline constexpr double kCheapErfcBound = 5e-4;

// The bias the cheap erfc can give one level's S (weight 1): the compensation (Eq. 9-10) and
// 1 - P_s are sums of products of per-axis masses, each factor in [0, 1] and each mass a half
// sum or difference of two erfc (error <= eps), the two-sided ones (x_out, y_out, 1 - P_s per
// axis) two masses: kemppinen_compensation_with's terms x_sq y_out + y_b x_out + (1 - P_s) x_b
// y_b change by at most eps + 2 eps + eps + 2 eps + 2 eps + 2 eps = 10 eps (first order; eps^2
// terms are below 1e-6).
inline constexpr double kCheapErfcBiasBound = 10 * kCheapErfcBound;

inline const char *NdfName(int ndf) {
  return ndf == GLINT_NDF_BECKMANN ? "Beckmann" : "GGX";
}
}  // namespace glint::test
