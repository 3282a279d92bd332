#include "tools/area_auto/area_auto_fit.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
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

namespace {

// The truths consistent with a cached error e of a result x (RelativeError's two branches and
// the sign of x - T), NaN where a branch has none, each with its conditioning: the relative
// uncertainty (of max(T, kFloor)) that e's float rounding (2^-24 relative) leaves in it:
// 2^-24 e / (1 +- e) above the floor (x / (1 - e) is ill-conditioned as e -> 1: a result ~0),
// 2^-24 e below it.
struct Solution {
  double t, u;
};
std::array<Solution, 4> TruthsFromError(double x, double e) {
  const double nan = std::nan(""), r = 6e-8;
  std::array<Solution, 4> s = {Solution{x / (1 + e), r * e / (1 + e)},
                               Solution{e < 1 ? x / (1 - e) : nan, r * e / (1 - e)},
                               Solution{x - e * kFloor, r * e}, Solution{x + e * kFloor, r * e}};
  for (int i = 0; i < 4; ++i) {
    const double t = s[size_t(i)].t;
    if (!(std::isfinite(t) && t >= 0 && (i < 2 ? t >= kFloor : t < kFloor))) s[size_t(i)].t = nan;
  }
  return s;
}

// A cached float error e reproduced by a result x and a truth recovered with uncertainty u: to
// e's float rounding plus u moving |x - T| / T by (1 + e) u; 10x margin.
bool Reproduces(double x, double truth, float e, double u) {
  const double now = std::min(RelativeError(x, truth), 1e30), ek = double(e);
  return std::fabs(now - ek) <= 10 * (6e-8 * ek + (1 + ek) * u) + 1e-15;
}

// Recovered truths must be good to this (relative): errors computed against them are then off
// by at most ~1e-7, far below the fingerprint test's 3e-4 and the smallest budget (5e-3).
constexpr double kMaxUncertainty = 1e-7;

// std::max that keeps a NaN (an integration gone wrong must not vanish from max_deviation).
double MaxKeepingNan(double a, double b) {
  return std::isnan(a) || std::isnan(b) ? std::nan("") : std::max(a, b);
}

}  // namespace

std::vector<Sample> Remeasure(const std::vector<Config> &configs, const std::vector<Sample> &old,
                              const std::vector<int> &which, int threads, int verify_every,
                              RemeasureStats *stats) {
  bool redo[kCandidates] = {};
  for (int k : which) redo[k] = true;
  std::vector<size_t> offset(configs.size() + 1, 0);
  for (size_t i = 0; i < configs.size(); ++i) offset[i + 1] = offset[i] + configs[i].wo.size();
  std::vector<Sample> out(old);
  std::mutex mu;
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i; (i = next.fetch_add(1)) < configs.size();) {
      const Config &c = configs[i];
      const size_t nv = c.wo.size();
      std::vector<std::vector<double>> x(kCandidates);
      for (int k = 0; k < kCandidates; ++k)
        x[size_t(k)] = HostRed(MakeRequest(c, CandidateMethod(k), CandidateSamples(k), 1));
      std::vector<double> truth(nv, std::nan(""));
      for (size_t v = 0; v < nv; ++v) {
        const Sample &o = old[offset[i] + v];
        // Every solution of every usable unchanged candidate that reproduces all the other
        // usable candidates' cached errors; they must agree (one truth), and the
        // best-conditioned is kept if well conditioned. None, or two apart, leaves the query to
        // the integration: e.g. equal results cannot tell the sign, and a result 0 (error 1 for
        // any truth above the floor) tells nothing, so an ill-conditioned x / (1 - e) of another
        // candidate that also reproduces it makes the query ambiguous.
        auto usable = [&](int k) {
          return !redo[k] && std::isfinite(x[size_t(k)][v]) && o.error[k] < 1e29f;
        };
        int n_usable = 0;
        for (int k = 0; k < kCandidates; ++k) n_usable += usable(k);
        if (n_usable < 2) continue;
        Solution pick = {std::nan(""), 1.0};
        bool ambiguous = false;
        for (int k = 0; k < kCandidates; ++k) {
          if (!usable(k)) continue;
          for (const Solution &sol : TruthsFromError(x[size_t(k)][v], double(o.error[k]))) {
            if (!std::isfinite(sol.t)) continue;
            bool all = true;
            for (int j = 0; j < kCandidates && all; ++j)
              if (j != k && usable(j)) all = Reproduces(x[size_t(j)][v], sol.t, o.error[j], sol.u);
            if (!all) continue;
            if (std::isfinite(pick.t) &&
                std::fabs(sol.t - pick.t) >
                    (10 * (sol.u + pick.u) + kMaxUncertainty) * std::max(pick.t, kFloor))
              ambiguous = true;
            if (!std::isfinite(pick.t) || sol.u < pick.u) pick = sol;
          }
        }
        if (!ambiguous && pick.u <= kMaxUncertainty) truth[v] = pick.t;
      }
      // The integration (Truth, view by view independent) of the views left without a
      // recovered truth, or of all of a verified light's.
      const bool verify = verify_every > 0 && i % size_t(verify_every) == 0;
      std::vector<double> exact(nv, std::nan(""));
      Config todo = c;
      todo.wo.clear();
      for (size_t v = 0; v < nv; ++v)
        if (verify || !std::isfinite(truth[v])) todo.wo.push_back(c.wo[v]);
      if (!todo.wo.empty()) {
        const std::vector<double> t = Truth(todo);
        for (size_t v = 0, n = 0; v < nv; ++v)
          if (verify || !std::isfinite(truth[v])) exact[v] = t[n++];
      }
      double deviation = 0;
      size_t recovered = 0;
      for (size_t v = 0; v < nv; ++v) {
        if (std::isfinite(truth[v])) {
          ++recovered;
          if (verify)
            deviation = MaxKeepingNan(deviation,
                                      std::fabs(truth[v] - exact[v]) / std::max(exact[v], kFloor));
        } else {
          truth[v] = exact[v];
        }
        Sample &s = out[offset[i] + v];
        for (int k = 0; k < kCandidates; ++k)
          if (redo[k]) s.error[k] = float(std::min(RelativeError(x[size_t(k)][v], truth[v]), 1e30));
      }
      std::lock_guard<std::mutex> lock(mu);
      stats->recovered += recovered;
      stats->integrated += nv - recovered;
      if (verify) {
        stats->verified += recovered;
        stats->max_deviation = MaxKeepingNan(stats->max_deviation, deviation);
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, threads); ++t) pool.emplace_back(work);
  for (auto &t : pool) t.join();
  return out;
}

std::string RemeasureProblem(const RemeasureStats &stats) {
  if (stats.verified == 0 || stats.max_deviation <= kMaxRecoveryDeviation) return "";
  char b[256];
  std::snprintf(b, sizeof b,
                "recovered truths deviate from the integration by up to %.3g (relative), over the "
                "bound %.3g: a candidate not re-measured or the truth changed, or the cache is of "
                "another training set",
                stats.max_deviation, kMaxRecoveryDeviation);
  return b;
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
