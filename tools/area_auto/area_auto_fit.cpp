#include "tools/area_auto/area_auto_fit.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include "kernels/area/area_auto_features.h"

namespace glint::area_auto {

glint::v1::AreaMethod CandidateMethod(int k) {
  return k == 0   ? glint::v1::LTC
         : k == 1 ? glint::v1::LECOCQ
         : k == 2 ? glint::v1::LECOCQ_PEARSON
                  : glint::v1::REFERENCE;
}
uint32_t CandidateSamples(int k) {
  return k < 3 ? 0u : 4u << (k - 3);
}

std::vector<Sample> Measure(const std::vector<Config> &configs, int threads) {
  std::vector<std::vector<Sample>> per(configs.size());
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i; (i = next.fetch_add(1)) < configs.size();) {
      const Config &c = configs[i];
      const std::vector<double> truth = Truth(c);
      const std::vector<int> cells = Cells(c);
      std::vector<Sample> s(c.wo.size());
      for (size_t v = 0; v < s.size(); ++v) s[v].cell = cells[v];
      for (int k = 0; k < kCandidates; ++k) {
        const auto x = HostRed(MakeRequest(c, CandidateMethod(k), CandidateSamples(k), 1));
        for (size_t v = 0; v < s.size(); ++v)
          s[v].error[k] = float(std::min(RelativeError(x[v], truth[v]), 1e30));
      }
      std::vector<double> sum(s.size(), 0.0), sum2(s.size(), 0.0);
      for (int seed = 1; seed <= kCvSeeds; ++seed) {
        const auto x = HostRed(MakeRequest(c, glint::v1::MONTE_CARLO, kCvSamples, uint64_t(seed)));
        for (size_t v = 0; v < s.size(); ++v) {
          sum[v] += x[v];
          sum2[v] += x[v] * x[v];
        }
      }
      for (size_t v = 0; v < s.size(); ++v) {
        const double mean = sum[v] / kCvSeeds;
        const double var = std::max(0.0, (sum2[v] - kCvSeeds * mean * mean) / (kCvSeeds - 1));
        const double cv = std::sqrt(var * kCvSamples) / std::max(truth[v], kFloor);
        s[v].cv = float(std::isfinite(cv) ? std::min(cv, 1e30) : 1e30);
      }
      per[i] = std::move(s);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, threads); ++t) pool.emplace_back(work);
  for (auto &t : pool) t.join();
  std::vector<Sample> all;
  for (auto &s : per) all.insert(all.end(), s.begin(), s.end());
  return all;
}

float Quantile(std::vector<float> v, double q) {
  if (v.empty()) return 1e30f;
  std::sort(v.begin(), v.end());
  size_t rank = size_t(std::ceil(q * double(v.size())));
  rank = std::clamp<size_t>(rank, 1, v.size());
  return v[rank - 1];
}

namespace {

// Cell index digits (area_auto_cell): alpha, view, omega, elevation, alignment.
struct Digits {
  int d[5];
};
Digits Split(int cell) {
  const int sizes[5] = {GLINT_AUTO_ALPHA_BINS, GLINT_AUTO_VIEW_BINS, GLINT_AUTO_OMEGA_BINS,
                        GLINT_AUTO_ELEVATION_BINS, GLINT_AUTO_ALIGN_BINS};
  Digits r;
  for (int i = 4; i >= 0; --i) {
    r.d[i] = cell % sizes[i];
    cell /= sizes[i];
  }
  return r;
}

// Pooling levels: which digits must match. Level 0 all; then the elevation is dropped, then
// the alignment, the solid angle and the view; level 5 pools the whole NDF. The order drops
// the features that mattered least first (bench_area's per-band errors: alpha first, then
// the view, the light's size, its alignment with the lobe).
bool Matches(const Digits &a, const Digits &b, int level) {
  static const int keep[6][5] = {{1, 1, 1, 1, 1}, {1, 1, 1, 0, 1}, {1, 1, 1, 0, 0},
                                 {1, 1, 0, 0, 0}, {1, 0, 0, 0, 0}, {0, 0, 0, 0, 0}};
  for (int i = 0; i < 5; ++i)
    if (keep[level][i] && a.d[i] != b.d[i]) return false;
  return true;
}

}  // namespace

NdfTable Fit(const std::vector<Sample> &samples) {
  NdfTable t;
  t.values.assign(size_t(GLINT_AUTO_CELLS) * (kCandidates + 1), 0.0f);
  t.count.assign(GLINT_AUTO_CELLS, 0);
  t.level.assign(GLINT_AUTO_CELLS, 0);
  std::vector<Digits> digits;
  for (const Sample &s : samples) digits.push_back(Split(std::max(s.cell, 0)));
  for (int cell = 0; cell < GLINT_AUTO_CELLS; ++cell) {
    const Digits me = Split(cell);
    std::vector<size_t> members;
    int level = 0;
    for (; level < 6; ++level) {
      members.clear();
      for (size_t i = 0; i < samples.size(); ++i)
        if (samples[i].cell >= 0 && Matches(me, digits[i], level)) members.push_back(i);
      if (int(members.size()) >= kMinPerCell) break;
    }
    level = std::min(level, 5);
    t.count[size_t(cell)] = int(members.size());
    t.level[size_t(cell)] = level;
    float *out = &t.values[size_t(cell) * (kCandidates + 1)];
    for (int k = 0; k < kCandidates; ++k) {
      std::vector<float> e;
      for (size_t i : members) e.push_back(samples[i].error[k]);
      out[k] = Quantile(e, kErrorQuantile);
    }
    std::vector<float> cv;
    for (size_t i : members) cv.push_back(samples[i].cv);
    out[kCandidates] = Quantile(cv, kCvQuantile);
  }
  return t;
}

}  // namespace glint::area_auto
