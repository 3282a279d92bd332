// The AUTO area method (kernels/area/area_auto.h): its Monte Carlo sample count is the
// central-limit bound it claims; the checked-in error table (models/smooth/area_auto_table.h)
// agrees with a regenerated sample of its own training set; on held-out configurations (seed 3;
// the fit used seed 1) at most the stated fraction of queries exceeds the budget, against an
// independent adaptive integration in double; where the table says LTC meets the budget AUTO
// runs LTC itself; results are bit-identical however the batch is chunked.
#include <gtest/gtest.h>

#include <cassert>
#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include "client/lib/glint_client.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "tools/area_auto/area_auto_data.h"
#include "tools/area_auto/area_auto_fit.h"

namespace kf {
#define GLINT_USE_DOUBLE 0
#include "kernels/area/area_auto.h"
#undef GLINT_USE_DOUBLE
}  // namespace kf

namespace glint::area_auto {
namespace {

// What the method promises (README "Area lights: AUTO"): on configurations drawn like its
// training set, of the (query, light) pairs where the table predicts some candidate meets the
// budget, at most 10% exceed it. The design targets ~5%
// (95% error quantiles per cell; MONTE_CARLO's n from a 90% cv quantile and z = 1.96); the
// stated 10% leaves room for cells pooled from few training queries.
constexpr double kStatedExceedFraction = 0.10;

// k = 3 binomial standard errors of an observed fraction over m trials.
double Allowance(double p, size_t m) {
  return 3.0 * std::sqrt(p * (1.0 - p) / double(m));
}

TEST(AreaAuto, MonteCarloSamplesAreTheCentralLimitBound) {
  // n = ceil((z cv / b)^2), rounded up to even, at least 4, 0 beyond 1024.
  EXPECT_EQ(kf::area_auto_mc_samples(0.5f, 0.05f), 386);   // (1.96 * 10)^2 = 384.16 -> 385 -> 386
  EXPECT_EQ(kf::area_auto_mc_samples(1.0f, 0.196f), 100);  // exactly 100 up to float rounding
  EXPECT_EQ(kf::area_auto_mc_samples(0.01f, 0.5f), 4);
  EXPECT_EQ(kf::area_auto_mc_samples(2.0f, 0.01f), 0);  // 156816 > 1024
  for (float b : {0.01f, 0.05f, 0.2f}) {
    const int n = kf::area_auto_mc_samples(0.3f, b);
    if (n == 0) continue;
    // The predicted error z cv / sqrt(n) is within the budget, and n - 2 would not be.
    EXPECT_LE(1.96 * 0.3 / std::sqrt(double(n)), double(b) * (1 + 1e-6));
    if (n > 4) {
      EXPECT_GT(1.96 * 0.3 / std::sqrt(double(n - 2)), double(b) * (1 - 1e-6));
    }
  }
}

// The first configurations of the training set (MakeConfigs draws them in sequence, so they
// are the fit's own first ones), measured again: each candidate's error exceeds its table
// entry for at most 1 - kErrorQuantile of them, and MONTE_CARLO's cv its entry for at most
// 1 - kCvQuantile, up to 3 standard errors. A table left stale by a change of a method, of the
// cells or of the measurement fails this.
TEST(AreaAuto, CheckedInTableAgreesWithItsRegeneratedTrainingSample) {
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    const std::vector<Sample> samples = Measure(MakeConfigs(kTrainSeed, 12, 8, ndf), 2);
    const int t = ndf == GLINT_NDF_BECKMANN ? 1 : 0;
    size_t pairs = 0, above = 0, cv_n = 0, cv_above = 0;
    for (const Sample &s : samples) {
      if (s.cell < 0) continue;
      const float *e =
          kf::glint_area_auto_error + (t * GLINT_AUTO_CELLS + s.cell) * GLINT_AUTO_CELL_FLOATS;
      for (int k = 0; k < kCandidates; ++k) {
        ++pairs;
        above += s.error[k] > e[k];
      }
      ++cv_n;
      cv_above += s.cv > e[kCandidates];
    }
    ASSERT_GT(pairs, 400u);
    const double p = 1 - kErrorQuantile, pc = 1 - kCvQuantile;
    EXPECT_LE(double(above) / double(pairs), p + Allowance(p, pairs)) << "ndf " << ndf;
    EXPECT_LE(double(cv_above) / double(cv_n), pc + Allowance(pc, cv_n)) << "ndf " << ndf;
  }
}

// The table header carries the measurements of its first training queries (fit_area_auto.cpp):
// measured again with today's kernels, truth and training set they must be the same. A table
// fitted before a change of a method (as the previous one was, before LECOCQ's near-horizon
// sub-splitting), of the adaptive truth or of MakeConfigs fails here even where its quantiles
// still happen to cover the regenerated sample above. Tolerance: the host path is deterministic,
// but another compiler may contract the fp32 arithmetic differently, moving an output by a few
// ulps, i.e. an error by up to ~4 x 6e-8 / kFloor = 2.4e-4 at the floor; 1e-3 relative + 3e-4
// absolute is far below the smallest budget validated (0.005), so no choice depends on it.
TEST(AreaAuto, CheckedInTableIsFromTodaysMeasurements) {
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    const int configs = (GLINT_AUTO_FINGERPRINT_QUERIES + 7) / 8;
    const std::vector<Sample> samples = Measure(MakeConfigs(kTrainSeed, configs, 8, ndf), 2);
    ASSERT_GE(samples.size(), size_t(GLINT_AUTO_FINGERPRINT_QUERIES));
    const float *fp = kf::glint_area_auto_fingerprint + (ndf == GLINT_NDF_BECKMANN) *
                                                            GLINT_AUTO_FINGERPRINT_QUERIES *
                                                            GLINT_AUTO_CELL_FLOATS;
    for (int q = 0; q < GLINT_AUTO_FINGERPRINT_QUERIES; ++q) {
      for (int k = 0; k <= kCandidates; ++k) {
        const double now = k < kCandidates ? samples[size_t(q)].error[k] : samples[size_t(q)].cv;
        const double then = fp[q * GLINT_AUTO_CELL_FLOATS + k];
        EXPECT_NEAR(now, then, 3e-4 + 1e-3 * std::max(now, then))
            << "ndf " << ndf << " query " << q << " candidate " << k
            << " (7 = MONTE_CARLO's cv): regenerate models/smooth/area_auto_table.h";
      }
    }
  }
}

// Every table entry is a finite, non-negative error (or 1e30 for "never measured finite").
TEST(AreaAuto, TableEntriesAreNonNegative) {
  for (size_t i = 0; i < sizeof kf::glint_area_auto_error / sizeof(float); ++i) {
    ASSERT_GE(kf::glint_area_auto_error[i], 0.0f) << i;
    ASSERT_LE(kf::glint_area_auto_error[i], 1e30f) << i;
  }
  for (float c : kf::glint_area_auto_cost) EXPECT_GT(c, 0.0f);
}

struct HeldOut {
  std::vector<Config> set;
  std::vector<std::vector<double>> truth;
};
const HeldOut &HeldOutSet(int ndf) {
  static HeldOut sets[2];
  HeldOut &h = sets[ndf == GLINT_NDF_BECKMANN];
  if (h.set.empty()) {
    h.set = MakeConfigs(3, 16, 8, ndf);
    for (const Config &c : h.set) h.truth.push_back(Truth(c));
  }
  return h;
}

TEST(AreaAuto, HeldOutQueriesExceedTheBudgetAtMostTheStatedFraction) {
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    const HeldOut &h = HeldOutSet(ndf);
    for (float budget : {0.05f, 0.2f}) {
      size_t n = 0, above = 0;
      for (size_t i = 0; i < h.set.size(); ++i) {
        const auto x = HostRed(MakeRequest(h.set[i], glint::v1::AUTO, 0, 11, budget));
        const std::vector<int> cells = Cells(h.set[i]);
        const std::vector<Choice> choice = Choices(h.set[i], budget);
        for (size_t v = 0; v < x.size(); ++v) {
          if (cells[v] < 0) continue;  // sees nothing of the light: 0 by every method
          // The contract covers the queries where some candidate was predicted to meet the
          // budget; the others get the smallest predicted error (bench_area_auto reports both).
          if (!(choice[v].predicted <= budget)) continue;
          ++n;
          above += RelativeError(x[v], h.truth[i][v]) > double(budget);
        }
      }
      ASSERT_GT(n, 30u) << "ndf " << ndf << " budget " << budget;
      EXPECT_LE(double(above) / double(n),
                kStatedExceedFraction + Allowance(kStatedExceedFraction, n))
          << "ndf " << ndf << " budget " << budget << ": " << above << " of " << n;
    }
  }
}

// Where the table's LTC entry meets the budget, LTC is the cheapest candidate: AUTO must run
// LTC there (its output bit-identical to an LTC request's), and LTC must really meet the budget
// on (nearly) all of those held-out queries.
TEST(AreaAuto, PicksLtcWhereLtcMeetsTheBudget) {
  const float budget = 0.2f;
  size_t ltc = 0, ltc_within = 0;
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    const HeldOut &h = HeldOutSet(ndf);
    for (size_t i = 0; i < h.set.size(); ++i) {
      const std::vector<int> cells = Cells(h.set[i]);
      const std::vector<Choice> choice = Choices(h.set[i], budget);
      const auto x_auto = HostRed(MakeRequest(h.set[i], glint::v1::AUTO, 0, 11, budget));
      const auto x_ltc = HostRed(MakeRequest(h.set[i], glint::v1::LTC, 0, 11));
      for (size_t v = 0; v < cells.size(); ++v) {
        if (cells[v] < 0) continue;
        const float entry =
            kf::glint_area_auto_error[((ndf == GLINT_NDF_BECKMANN) * GLINT_AUTO_CELLS + cells[v]) *
                                      GLINT_AUTO_CELL_FLOATS];
        if (!(entry <= budget)) continue;
        ++ltc;
        EXPECT_EQ(choice[v].method, GLINT_AREA_LTC);
        EXPECT_EQ(x_auto[v], x_ltc[v]) << "config " << i << " view " << v;
        ltc_within += RelativeError(x_ltc[v], h.truth[i][v]) <= double(budget);
      }
    }
  }
  ASSERT_GT(ltc, 20u) << "too few held-out queries where the table trusts LTC";
  const double p = 1 - kErrorQuantile;
  EXPECT_GE(double(ltc_within) / double(ltc), 1 - (2 * p + Allowance(2 * p, ltc)))
      << ltc_within << " of " << ltc;
}

// Near-horizon views: wo.z 0.01, 1e-3, 3e-4 on held-out lights (seed 5), inside the training
// set's grazing band (MakeConfigs: every fourth view, cos theta_o log-uniform in [1e-4, cos 85])
// and the table's last view bin (85-90 deg). Where the table predicts a candidate meets the
// budget, the stated fraction holds as on the held-out set above; and where AUTO picked LECOCQ or
// LECOCQ_PEARSON, whose errors grow from 85 deg to the horizon (tests/area/lecocq_test.cpp
// GrazingViews*), the fraction of those over the budget is held to the same statement (printed:
// how often AUTO picks them there).
// History: session 10's table stopped at 89 deg (these views fell in a 70-90 deg bin dominated by
// ordinary views) and was fitted before LECOCQ's near-horizon fix; AUTO then trusted REFERENCE 4-8
// nodes here, which miss the streak a grazing lobe makes along the horizon, and 7-15% of the
// covered queries were over the budget (GGX budget 0.05: 11 of 72). Refitted with the grazing
// bin (session 11): GGX 4 of 65 / 2 of 84 / 1 of 96 over at budgets 0.05 / 0.2 / 0.5, Beckmann
// 4 of 77 / 2 of 94 / 2 of 94 (2.1-6.2%); LECOCQ / LECOCQ_PEARSON chosen for 12 and 3 Beckmann
// queries at 0.2 and 0.5, none over. Session 14 (refit after REFERENCE's polar pieces): GGX 2 of
// 66 / 2 of 84 / 1 of 96, Beckmann 2 of 77 / 3 of 94 / 2 of 96; LECOCQ / LECOCQ_PEARSON chosen
// for 17 and 3 Beckmann queries at 0.2 and 0.5, one over.
TEST(AreaAuto, GrazingViewsExceedTheBudgetAtMostTheStatedFraction) {
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    std::vector<Config> set = MakeConfigs(5, 16, 6, ndf);
    for (Config &c : set) {
      const double zs[3] = {0.01, 1e-3, 3e-4};
      for (size_t v = 0; v < c.wo.size(); ++v) {
        // Keep each view's azimuth, move it to the horizon.
        const double z = zs[v % 3], r = std::hypot(c.wo[v][0], c.wo[v][1]);
        const double s = std::sqrt(1 - z * z);
        c.wo[v] = r > 0 ? V3{s * c.wo[v][0] / r, s * c.wo[v][1] / r, z} : V3{s, 0, z};
      }
    }
    std::vector<std::vector<double>> truth;
    for (const Config &c : set) truth.push_back(Truth(c));
    for (float budget : {0.05f, 0.2f, 0.5f}) {
      size_t n = 0, above = 0, lecocq = 0, lecocq_above = 0;
      std::map<int, int> over_by_method;  // GLINT_AREA_* -> queries over the budget
      for (size_t i = 0; i < set.size(); ++i) {
        const auto x = HostRed(MakeRequest(set[i], glint::v1::AUTO, 0, 11, budget));
        const std::vector<int> cells = Cells(set[i]);
        const std::vector<Choice> choice = Choices(set[i], budget);
        for (size_t v = 0; v < x.size(); ++v) {
          if (cells[v] < 0 || !(choice[v].predicted <= budget)) continue;
          const bool over = RelativeError(x[v], truth[i][v]) > double(budget);
          ++n;
          above += over;
          if (over) ++over_by_method[choice[v].method];
          if (choice[v].method == GLINT_AREA_LECOCQ ||
              choice[v].method == GLINT_AREA_LECOCQ_PEARSON) {
            ++lecocq;
            lecocq_above += over;
          }
        }
      }
      std::printf("grazing AUTO ndf %d budget %.2f: %zu of %zu over (by GLINT_AREA_*:", ndf,
                  double(budget), above, n);
      for (auto [method, count] : over_by_method) std::printf(" %d: %d", method, count);
      std::printf("); LECOCQ/PEARSON chosen %zu, %zu over\n", lecocq, lecocq_above);
      ASSERT_GT(n, 30u) << "ndf " << ndf << " budget " << budget;
      EXPECT_LE(double(above) / double(n),
                kStatedExceedFraction + Allowance(kStatedExceedFraction, n))
          << "ndf " << ndf << " budget " << budget << ": " << above << " of " << n;
      if (lecocq > 0) {
        EXPECT_LE(double(lecocq_above) / double(lecocq),
                  kStatedExceedFraction + Allowance(kStatedExceedFraction, lecocq))
            << "ndf " << ndf << " budget " << budget << ": LECOCQ " << lecocq_above << " of "
            << lecocq;
      }
    }
  }
}

// The choice and the Monte Carlo keys depend only on each query's own inputs: any chunking
// of the batch gives bit-identical results (DESIGN.md "Determinism").
TEST(AreaAuto, BitIdenticalUnderChunking) {
  Config c = MakeConfigs(4, 1, 64, GLINT_NDF_GGX)[0];
  c.alpha = 0.05;  // low roughness: the budget needs MONTE_CARLO or REFERENCE for some views
  const glint::v1::EvaluateRequest r = MakeRequest(c, glint::v1::AUTO, 0, 5, 0.02f);
  const EvalPlan plan = MakeEvalPlan(r, r.queries());
  std::vector<float> whole(3 * 64);
  HostEvaluate(plan, r.queries(), whole.data());
  std::vector<float> chunked(3 * 64);
  for (auto [b, e] : {std::pair{0u, 13u}, {13u, 40u}, {40u, 41u}, {41u, 64u}}) {
    const glint::v1::QueryBatch s = glint::client::SliceQueries(r.queries(), b, e);
    HostEvaluate(plan, s, chunked.data() + 3 * b);
  }
  for (size_t i = 0; i < whole.size(); ++i) ASSERT_EQ(whole[i], chunked[i]) << i;
  // And the budget changes the work: the methods chosen are not all LTC.
  int non_ltc = 0;
  for (const Choice &ch : Choices(c, 0.02f)) non_ltc += ch.method != GLINT_AREA_LTC;
  EXPECT_GT(non_ltc, 0);
}

}  // namespace
}  // namespace glint::area_auto
