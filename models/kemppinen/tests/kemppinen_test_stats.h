// Sample statistics of the Kemppinen kernel tests (mean, unbiased variance, standard error of
// the mean: the tolerances of the statistical tests are multiples of se()), and the NDF's name
// for messages. Included after tests/support/kernels_both_precisions.h (GLINT_NDF_BECKMANN).
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

inline const char *NdfName(int ndf) {
  return ndf == GLINT_NDF_BECKMANN ? "Beckmann" : "GGX";
}
}  // namespace glint::test
