#include "client/lib/percentile.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace glint::client {

std::vector<double> NearestRankPercentiles(std::vector<double> samples,
                                           const std::vector<double> &ps) {
  for (const double p : ps) {
    if (!(p > 0.0 && p <= 100.0)) {
      throw std::invalid_argument("percentile " + std::to_string(p) + " is outside (0, 100]");
    }
  }
  std::vector<double> out;
  out.reserve(ps.size());
  if (samples.empty()) {
    out.assign(ps.size(), std::numeric_limits<double>::quiet_NaN());
    return out;
  }
  std::sort(samples.begin(), samples.end());
  const double n = static_cast<double>(samples.size());
  for (const double p : ps) {
    // Rank ceil(p n / 100), 1-based. For integer p and n < 2^53, p n is exact and the
    // correctly rounded quotient is exact when p n / 100 is an integer and at least 0.01 away
    // from one otherwise, so ceil never moves an exact rank up by one.
    auto rank = static_cast<size_t>(std::ceil(p * n / 100.0));
    rank = std::clamp<size_t>(rank, 1, samples.size());
    out.push_back(samples[rank - 1]);
  }
  return out;
}

double NearestRankPercentile(std::vector<double> samples, double p) {
  return NearestRankPercentiles(std::move(samples), {p}).front();
}

}  // namespace glint::client
