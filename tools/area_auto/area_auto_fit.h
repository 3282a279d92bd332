// Measuring and fitting the AUTO area method's error table (models/smooth/area_auto_table.h):
// shared by the fitting tool (fit_area_auto.cpp) and the test that checks the checked-in table
// against a regenerated sample of its own training set (tests/area/area_auto_test.cpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tools/area_auto/area_auto_data.h"

namespace glint::area_auto {

constexpr int kCandidates = 7;  // LTC, LECOCQ, LECOCQ_PEARSON, REFERENCE 4, 8, 16, 32
// The fit's quantiles: of the deterministic methods' relative error, and of MONTE_CARLO's
// per-sample coefficient of variation (which z = 1.96 then turns into a ~95% bound).
constexpr double kErrorQuantile = 0.95;
constexpr double kCvQuantile = 0.9;
// Fewer training queries in a cell than this: pooled with neighbouring cells (Fit).
constexpr int kMinPerCell = 12;
// MONTE_CARLO's cv from kCvSeeds independent estimates of kCvSamples samples each.
constexpr int kCvSeeds = 16;
constexpr uint32_t kCvSamples = 16;
constexpr uint64_t kTrainSeed = 1;
// The table header also carries the measurements of the first kFingerprintQueries training
// queries per NDF (the first two lights' 8 views: two of them grazing), re-measured by the test.
constexpr int kFingerprintQueries = 16;

glint::v1::AreaMethod CandidateMethod(int k);
uint32_t CandidateSamples(int k);

// One query of the training set: its cell, each candidate's relative error, and MONTE_CARLO's
// per-sample cv: sqrt(kCvSamples) x (standard deviation over kCvSeeds seeds) / max(truth, kFloor).
struct Sample {
  int cell = -1;
  float error[kCandidates] = {};
  float cv = 0;
};

// Measures every view of the configurations on the host path (fp32), `threads` threads.
std::vector<Sample> Measure(const std::vector<Config> &configs, int threads);

// Re-measures the candidates in `which` (indices into LTC .. REFERENCE 32) after a change of
// those methods only, without the truth integration that dominates Measure's cost: each query's
// truth is recovered from `old` (Measure's samples of the same configurations, before the
// change) and today's results of the other candidates, which must be unchanged. A cached error e
// of a result x fixes the truth T up to the sign of x - T (e = |x - T| / max(T, kFloor)): T =
// x / (1 -+ e) above the floor, x -+ e kFloor below it. The candidate of smallest cached error
// gives the solutions (the least sensitive to the float rounding of e); one is kept when it
// reproduces every other unchanged candidate's cached error (to float rounding) and the other
// solution does not. A query with no such unique solution (fewer than two usable candidates,
// equal results, or a changed result) gets Truth() like Measure. MONTE_CARLO's cv and the other
// candidates' errors are kept from `old`. Every `verify_every`-th configuration (0: none) also
// computes Truth() and records the largest relative deviation of the recovered truth from it.
struct RemeasureStats {
  size_t recovered = 0, integrated = 0, verified = 0;
  double max_deviation = 0;  // |recovered - Truth| / max(Truth, kFloor) over the verified
};
std::vector<Sample> Remeasure(const std::vector<Config> &configs, const std::vector<Sample> &old,
                              const std::vector<int> &which, int threads, int verify_every,
                              RemeasureStats *stats);

// The largest relative deviation of a verified recovered truth from the integration that a fit
// accepts. Remeasure keeps a recovered truth only when the float rounding of the cached errors
// leaves it uncertain by at most 1e-7 (area_auto_fit.cpp kMaxUncertainty), and Truth() is
// deterministic, so the integration reproduces the truth the cached errors were measured
// against: a recovered truth within its premises deviates by at most 1e-7. The bound is 10x that
// (the margin Remeasure's own consistency checks use). More means a premise is broken: a
// candidate outside `which` changed, the truth integration changed, or the cache is of another
// training set; the errors it gives are then not the table's (they would still be off by only
// (1 + e) x deviation, but nothing bounds the unverified lights' deviation then).
constexpr double kMaxRecoveryDeviation = 1e-6;

// Empty when the verified recovered truths are within kMaxRecoveryDeviation (or none were
// verified), else a message saying by how much they are not.
std::string RemeasureProblem(const RemeasureStats &stats);

// The table of one NDF: GLINT_AUTO_CELLS x 8 floats (7 error quantiles, the cv quantile), and
// per cell the number of training queries it drew on and its pooling level (0 = its own).
struct NdfTable {
  std::vector<float> values;
  std::vector<int> count, level;
};
NdfTable Fit(const std::vector<Sample> &samples);

// The nearest-rank q-quantile (the smallest x with at least q of the values <= x).
float Quantile(std::vector<float> v, double q);

}  // namespace glint::area_auto
