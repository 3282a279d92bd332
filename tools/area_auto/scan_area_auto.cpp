// Scans the AUTO training set (area_auto_data.h MakeConfigs, seed 1) for physically impossible
// outputs: every light has radiance 1 and the material is grey Schlick f0 = 1 with a
// height-correlated Smith G2, whose directional albedo is at most 1 (int f cos_i dwi over the
// hemisphere = int D_wo(h) G2 / G1(wo) dh <= 1, Heitz 2014 Eq. 99 and Sec. 5), so a query's
// radiance above 1 is an error of the method, whatever the truth is. Runs LTC, LECOCQ,
// LECOCQ_PEARSON, REFERENCE 4-32 and MONTE_CARLO 64 (seed 1) on the host path (fp32, as the
// training measurement) and prints every query where a deterministic method is above 1 + kSlack,
// with the truth (Truth) beside it; MONTE_CARLO's estimates above 1 are only counted.
//   glint_scan_area_auto [--configs N] [--threads T]
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "kernels/layout.h"
#include "tools/area_auto/area_auto_data.h"
#include "tools/area_auto/area_auto_fit.h"

using namespace glint::area_auto;

namespace {
// fp32 rounding of a result near 1 (a few ulps of the sums): not an energy excess.
constexpr double kSlack = 1e-4;
constexpr int kMethods = kCandidates + 1;  // the candidates, then MONTE_CARLO 64
const char *Name(int k) {
  static const char *names[kMethods] = {"LTC",         "LECOCQ",       "LECOCQ_PEARSON",
                                        "REFERENCE4",  "REFERENCE8",   "REFERENCE16",
                                        "REFERENCE32", "MONTE_CARLO64"};
  return names[k];
}
}  // namespace

int main(int argc, char **argv) {
  int configs = 1000, threads = 2;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--configs" && i + 1 < argc)
      configs = std::stoi(argv[++i]);
    else if (a == "--threads" && i + 1 < argc)
      threads = std::stoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: glint_scan_area_auto [--configs N] [--threads T]\n");
      return 2;
    }
  }
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    const std::vector<Config> set = MakeConfigs(kTrainSeed, configs, 8, ndf);
    std::vector<int> over(kMethods, 0);
    std::mutex mu;
    std::atomic<size_t> next{0};
    auto work = [&] {
      for (size_t i; (i = next.fetch_add(1)) < set.size();) {
        const Config &c = set[i];
        std::vector<std::vector<double>> x(kMethods);
        for (int k = 0; k < kCandidates; ++k)
          x[size_t(k)] = HostRed(MakeRequest(c, CandidateMethod(k), CandidateSamples(k), 1));
        x[kCandidates] = HostRed(MakeRequest(c, glint::v1::MONTE_CARLO, 64, 1));
        for (size_t v = 0; v < c.wo.size(); ++v) {
          // MONTE_CARLO is unbiased, not bounded: one estimate may exceed 1 (counted, not a
          // reason to list the query).
          bool any = false;
          for (int k = 0; k < kCandidates; ++k) any |= x[size_t(k)][v] > 1 + kSlack;
          if (x[kCandidates][v] > 1 + kSlack) {
            std::lock_guard<std::mutex> lock(mu);
            ++over[kCandidates];
          }
          if (!any) continue;
          Config one = c;
          one.wo = {c.wo[v]};
          const double truth = Truth(one)[0];
          std::lock_guard<std::mutex> lock(mu);
          std::printf("%s [%zu] view %zu (wo.z %.3g, alpha %.3g): truth %.4g;",
                      ndf == GLINT_NDF_BECKMANN ? "BECKMANN" : "GGX", i, v, c.wo[v][2], c.alpha,
                      truth);
          for (int k = 0; k < kCandidates; ++k) {
            if (x[size_t(k)][v] > 1 + kSlack) {
              ++over[size_t(k)];
              std::printf(" %s %.4g", Name(k), x[size_t(k)][v]);
            }
          }
          std::printf("\n");
        }
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < std::max(1, threads); ++t) pool.emplace_back(work);
    for (auto &t : pool) t.join();
    std::printf("%s: %zu queries; above 1:", ndf == GLINT_NDF_BECKMANN ? "BECKMANN" : "GGX",
                set.size() * 8);
    for (int k = 0; k < kMethods; ++k) std::printf(" %s %d", Name(k), over[size_t(k)]);
    std::printf("\n");
    std::fflush(stdout);
  }
  return 0;
}
