// Latency percentiles for the load tool (glint load) and anything else that summarises samples.
//
// Method: nearest rank. The p-th percentile of n samples is the smallest sample x such that at
// least p% of the samples are <= x, i.e. the sample of rank ceil(p/100 * n) (1-based) in
// ascending order. It is always one of the measured values (never interpolated), so a p99 of
// 100 samples is the 99th smallest and a p50 of 4 samples is the 2nd smallest. This is the
// definition perf_analyzer's reports are read with and the one the unit test checks by hand.
#pragma once

#include <vector>

namespace glint::client {

// Nearest-rank percentile of `samples` (any order) for p in (0, 100]. Returns NaN for an empty
// set; throws std::invalid_argument for p outside (0, 100].
double NearestRankPercentile(std::vector<double> samples, double p);

// Several percentiles of one set of samples with one sort; same definition and errors.
std::vector<double> NearestRankPercentiles(std::vector<double> samples,
                                           const std::vector<double> &ps);

}  // namespace glint::client
