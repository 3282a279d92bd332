// The cheaper neighbourhoods of the Kemppinen model (glint.v1.KemppinenNeighborhood,
// models/kemppinen/README.md "Neighbourhood"): one dithered MIP level (ONE_LEVEL) and, in
// addition, only the spatial cell holding the query (ONE_CELL), both with the A&S 7.1.27 erfc.
// Against independent references:
//   - the cheap erfc against libm, within A&S's published bound,
//   - the dither: the coarser level is picked with probability w1 (binomial statistics),
//   - Eq. 2: averaged over uv, D_star = D within k standard errors plus the cheap erfc's bound,
//   - against the explicit sum over every facet (one level; and two levels, where the reference
//     is the expectation over the roulette w0 Full(l0) + w1 Full(l1)): unbiased, RMS reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

#include "data/ltc/ltc_table.h"
#include "models/kemppinen/tests/kemppinen_test_material.h"

#define GLINT_TEST_KERNEL_EXTRA "models/kemppinen/tests/kemppinen_api.inc"
#include "tests/support/kernels_both_precisions.h"

// After the kernels: NdfName reads GLINT_NDF_BECKMANN.
#include "models/kemppinen/tests/kemppinen_test_stats.h"

namespace {

using glint::test::FootprintForLevel;
using glint::test::Glinty;
using glint::test::HoodName;
using glint::test::kCheapErfcBiasBound;
using glint::test::kCheapErfcBound;
using glint::test::NdfName;
using glint::test::Normalize;
using glint::test::Stats;
using glint::test::Summarise;
using glint::test::V3;

// ---------------------------------------------------------------------------------------------
// The cheap erfc (Abramowitz & Stegun 7.1.27) against libm on [0, 12] standard scores: within
// their published 5e-4; fp32 adds the rounding of ~10 operations on values <= 1 near the
// maximum error (<= 10 * 6e-8).
TEST(CheapErfc, WithinItsPublishedBoundOfLibm) {
  double worst64 = 0, worst32 = 0;
  for (int i = 0; i <= 120000; ++i) {
    double x = i * 1e-4 * std::sqrt(2.0);
    double ref = std::erfc(x / std::sqrt(2.0));
    worst64 = std::max(worst64, std::fabs(double(k64::kemppinen_erfc_abs_cheap(x)) - ref));
    worst32 = std::max(worst32, std::fabs(double(k32::kemppinen_erfc_abs_cheap(float(x))) - ref));
  }
  std::printf("erfc (A&S 7.1.27) vs libm on [0, 12]: max absolute error %.3g (fp64), %.3g (fp32)\n",
              worst64, worst32);
  EXPECT_LE(worst64, kCheapErfcBound);
  EXPECT_LE(worst32, kCheapErfcBound + 10 * 5.96e-8);
}

// The four cheap erfc of one kemppinen_erfc4_with call share one division (1 / (Pa Pb Pc Pd)
// and products; y clamped at the 6-sigma cut so the product cannot overflow fp32). Against libm
// on [-12, 12] in each slot: within A&S's 5e-4 plus the fp32 rounding of the ~10 operations of
// the polynomial and the 6 of the shared reciprocal (values <= 1: 16 x 2^-24), exactly 0 beyond
// the cut; and against one division per erfc (kemppinen_erfc_abs_cheap) within those 6
// roundings relative, so the sharing changes nothing but rounding.
TEST(CheapErfc, FourFromOneDivisionWithinTheBoundAndZeroBeyondTheCut) {
  const double u = 5.96e-8;
  double worst64 = 0, worst32 = 0, worst_rel32 = 0;
  for (int i = -12000; i <= 12000; ++i) {
    const double x = i * 1e-3;
    const double xs[4] = {x, -0.5 * x, 0.25 * x + 1.0, 7.0 - 0.3 * x};
    k64::KemppinenErfc4 e = k64::kemppinen_erfc4_with(xs[0], xs[1], xs[2], xs[3], 1);
    k32::KemppinenErfc4 f =
        k32::kemppinen_erfc4_with(float(xs[0]), float(xs[1]), float(xs[2]), float(xs[3]), 1);
    const double v64[4] = {e.a, e.b, e.c, e.d}, v32[4] = {f.a, f.b, f.c, f.d};
    for (int k = 0; k < 4; ++k) {
      const double ref = std::erfc(std::fabs(xs[k]) / std::sqrt(2.0));
      if (std::fabs(xs[k]) >= 6.0) {
        EXPECT_EQ(v64[k], 0.0) << xs[k];
        EXPECT_EQ(v32[k], 0.0) << xs[k];
        continue;
      }
      worst64 = std::max(worst64, std::fabs(v64[k] - ref));
      worst32 = std::max(worst32, std::fabs(v32[k] - ref));
      const double one = double(k32::kemppinen_erfc_abs_cheap(float(xs[k])));
      worst_rel32 = std::max(worst_rel32, std::fabs(v32[k] / one - 1.0));
    }
  }
  std::printf(
      "four cheap erfc from one division vs libm on [-12, 12]: max absolute error %.3g "
      "(fp64), %.3g (fp32); fp32 vs one division each: max relative %.3g\n",
      worst64, worst32, worst_rel32);
  EXPECT_LE(worst64, kCheapErfcBound);
  EXPECT_LE(worst32, kCheapErfcBound + 16 * u);
  // 6 roundings on the shared-division path (pab, pcd, their product, the division, r pcd, x pb)
  // and 1 in the one-division reference's own 1 / P.
  EXPECT_LE(worst_rel32, 7 * u);
}

// The dither of the one-level neighbourhoods: at lambda = l + w1 a query takes level l + 1
// with probability w1 (kemppinen_query_levels), else l, from a hash of its uv. Over n random uv
// the fraction taking l + 1 is binomial: within 4.5 standard errors sqrt(w1 (1 - w1) / n) of
// w1. A query keeps its level (the same uv, the same pick), and another seed picks anew.
TEST(OneLevel, PicksTheCoarserLevelWithTheTentWeight) {
  for (int hood : {GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL, GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL})
    for (double w : {0.1, 0.5, 0.85}) {
      Glinty g;
      g.neighborhood = hood;
      auto fp = FootprintForLevel(g, 5.0 + w);
      // The kernel's lambda (its regularisation of Sigma_s moves it by ~1e-4).
      const double w1 = k64::Lambda(g, fp.data()) - 5.0;
      ASSERT_NEAR(w1, w, 1e-3);
      const int n = 20000;
      std::mt19937_64 rng(5);
      std::uniform_real_distribution<double> uni(0.0, 100.0);
      int coarser = 0, other_seed_differs = 0;
      for (int i = 0; i < n; ++i) {
        double u = uni(rng), v = uni(rng);
        double l = k64::PickedLevel(g, u, v, fp.data());
        ASSERT_TRUE(l == 5.0 || l == 6.0) << l;
        coarser += l == 6.0;
        EXPECT_EQ(l, k64::PickedLevel(g, u, v, fp.data()));
        // fp32 keys the dither by the same float bits of uv.
        EXPECT_EQ(l, double(k32::PickedLevel(g, float(u), float(v), fp.data())))
            << "u " << u << " v " << v;
        Glinty g2 = g;
        g2.seed_lo = 12;
        other_seed_differs += k64::PickedLevel(g2, u, v, fp.data()) != l;
      }
      double p = double(coarser) / n, se = std::sqrt(w1 * (1 - w1) / n);
      std::printf("%-9s w1 %.2f: coarser level picked by %.4f of %d queries (SE %.4f)\n",
                  HoodName(hood), w1, p, n, se);
      EXPECT_NEAR(p, w1, 4.5 * se);
      // Two independent picks differ with probability 2 w1 (1 - w1).
      double q = 2 * w1 * (1 - w1);
      EXPECT_NEAR(double(other_seed_differs) / n, q, 4.5 * std::sqrt(q * (1 - q) / n));
    }
}

// K25 Eq. 2 for the cheap neighbourhoods: averaged over uv, D_star / D = 1 (away from the
// rim). Each level alone is a point process of density K_P and the dither picks a level, so
// the mean stays 1; ONE_CELL's compensation adds the filter's mass outside the one cell
// (1 - P_s of that cell), which a 2x2 block's P_s would undercount by 20-35% at these levels.
// Tolerance: 4.5 standard errors plus the cheap erfc's bias bound (kCheapErfcBiasBound).
TEST(Neighborhood, AveragedOverUvEqualsTheSmoothNdf) {
  struct Case {
    int ndf;
    double ax, ay, aniso, micro, lambda;
  };
  const Case cases[] = {
      {GLINT_NDF_GGX, 0.3, 0.3, 1.0, 0.02, 3.5},
      {GLINT_NDF_BECKMANN, 0.3, 0.3, 1.0, 0.02, 4.3},
      {GLINT_NDF_GGX, 0.4, 0.1, 3.0, 0.005, 7.0},  // anisotropic glints and NDF
      {GLINT_NDF_BECKMANN, 0.4, 0.2, 0.4, 0.005, 6.7},
  };
  const V3 hs[] = {{0, 0, 1}, {0.15, -0.1, 1}};
  for (int hood : {GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL, GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL})
    for (const Case &c : cases) {
      Glinty g;
      g.ndf = c.ndf;
      g.ax = c.ax;
      g.ay = c.ay;
      g.aniso = c.aniso;
      g.micro = c.micro;
      g.neighbors = 1;
      g.neighborhood = hood;
      auto fp = FootprintForLevel(g, c.lambda);
      for (V3 h0 : hs) {
        V3 h = Normalize(h0);
        auto disk = k64::ToDisk(g, h);
        auto ang = k64::Angular(g, h);
        double edge = 0.5 - std::hypot(disk.x - 0.5, disk.y - 0.5);
        ASSERT_GT(edge, 6 * std::max(ang.sx, ang.sy)) << "h too close to the rim";
        const int count = 40000;
        std::mt19937_64 rng(17);
        std::uniform_real_distribution<double> uni(0.0, 100.0);
        std::vector<double> s(count);
        for (int i = 0; i < count; ++i)
          s[size_t(i)] = k64::GlintFactor(g, uni(rng), uni(rng), fp.data(), h);
        Stats st = Summarise(s);
        std::printf(
            "Eq. 2 %-9s %-8s alpha %.2f,%.2f a %.1f lambda %.1f h (%.2f,%.2f): mean D*/D %.4f "
            "+- %.4f (spread %.2f)\n",
            HoodName(hood), NdfName(c.ndf), c.ax, c.ay, c.aniso, c.lambda, h.x, h.y, st.mean,
            st.se(), st.spread());
        EXPECT_NEAR(st.mean, 1.0, 4.5 * st.se() + kCheapErfcBiasBound)
            << HoodName(hood) << " " << NdfName(c.ndf) << " lambda " << c.lambda;
      }
    }
}

// Against the explicit sum over every facet whose lobe reaches the query (LevelFullSum, the
// slow test-only path of kemppinen_test.cpp), per neighbourhood and k:
//  - one level (lambda = 6): S of each neighbourhood (its compensation included) against the
//    level's full sum: unbiased within 4.5 SE plus the cheap erfc's bound;
//  - two levels (lambda = 5.5, w0 = w1 = 1/2): S against w0 Full(5) + w1 Full(6), the
//    expectation over the roulette numbers (E_r R(r, 1/2) = 1/2, Eq. 8) and over the dither.
// The RMS error per query relative to the mean is printed (the cost of the cheaper estimate;
// the README's table).
TEST(Neighborhood, AgainstTheSumOverEveryFacet) {
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN})
    for (double micro : {0.05, 0.01}) {
      Glinty g;
      g.ndf = ndf;
      g.micro = micro;
      const int count = 200;
      for (double target : {6.0, 5.5}) {
        auto fp = FootprintForLevel(g, target);
        // The kernel's lambda (its regularisation of Sigma_s adds ~1e-4; at 6 + 1e-4 the coarser
        // level's weight is ~1e-4, so that level is included too).
        const double lambda = k64::Lambda(g, fp.data());
        const int l0 = int(std::floor(lambda));
        const double w1 = lambda - l0;
        std::mt19937_64 rng(8);
        std::uniform_real_distribution<double> uni(0.0, 100.0), tilt(-0.25, 0.25);
        std::vector<double> u(count), v(count), full(count);
        std::vector<V3> hs(count);
        for (int i = 0; i < count; ++i) {
          u[size_t(i)] = uni(rng);
          v[size_t(i)] = uni(rng);
          hs[size_t(i)] = Normalize({tilt(rng), tilt(rng), 1});
          full[size_t(i)] = (1 - w1) * k64::LevelFullSum(g, u[size_t(i)], v[size_t(i)], fp.data(),
                                                         hs[size_t(i)], l0, 7.0, 7.0);
          if (w1 > 0)
            full[size_t(i)] += w1 * k64::LevelFullSum(g, u[size_t(i)], v[size_t(i)], fp.data(),
                                                      hs[size_t(i)], l0 + 1, 7.0, 7.0);
        }
        Stats sf = Summarise(full);
        for (int k : {1, 4})
          for (int hood :
               {GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER, GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL,
                GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL}) {
            g.neighbors = k;
            g.neighborhood = hood;
            std::vector<double> diff(count);
            double sq = 0;
            for (int i = 0; i < count; ++i) {
              double est =
                  k64::GlintFactor(g, u[size_t(i)], v[size_t(i)], fp.data(), hs[size_t(i)]);
              diff[size_t(i)] = est - full[size_t(i)];
              sq += diff[size_t(i)] * diff[size_t(i)];
            }
            Stats sd = Summarise(diff);
            double rms = std::sqrt(sq / count) / sf.mean;
            std::printf(
                "%-8s micro %.2f lambda %.1f k = %d %-9s: RMS error vs every facet %.4f of the "
                "mean "
                "(mean %.3f), bias %.4f +- %.4f\n",
                NdfName(ndf), micro, lambda, k, HoodName(hood), rms, sf.mean, sd.mean / sf.mean,
                sd.se() / sf.mean);
            const double erfc_bias =
                hood == GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER ? 10 * 1.5e-7 : kCheapErfcBiasBound;
            EXPECT_NEAR(sd.mean, 0.0, 4.5 * sd.se() + erfc_bias * sf.mean + 1e-12)
                << NdfName(ndf) << " micro " << micro << " lambda " << lambda << " k " << k << " "
                << HoodName(hood);
          }
      }
    }
}

// ---------------------------------------------------------------------------------------------
// The point-light pass takes a query's lights in pairs, both glint factors in one pass over the
// cells (kemppinen_reflect_at2, for throughput): it must give exactly the bits of each light
// alone (kemppinen_reflect_at) summed in the same order, in both precisions, for every
// neighbourhood and k, with colours, two levels and one, and an odd light count (the last light
// alone), including lights below the horizon in some queries (the early returns).
template <typename Query>
void ExpectPairedLightsBitIdentical(Query query, const char *precision) {
  std::mt19937 rng(20261206);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  auto dir = [&](double zmin) {
    double z = zmin + (1.0 - zmin) * U(rng), phi = 2 * M_PI * U(rng), r = std::sqrt(1 - z * z);
    return V3{r * std::cos(phi), r * std::sin(phi), z};
  };
  int cases = 0, mismatches = 0, nonzero = 0;
  for (int ndf : {1, GLINT_NDF_BECKMANN})
    for (int hood : {GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER, GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL,
                     GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL})
      for (int k : {1, 4, 9, 16})
        for (int n_lights : {2, 3}) {
          Glinty g;
          g.ndf = ndf;
          g.ax = 0.3;
          g.ay = 0.2;
          g.density = 1e5;
          g.neighbors = k;
          g.neighborhood = hood;
          if (k == 4) g.colors = {1, 0.2, 0.1, 1, 0.9, 0.2, 0.1, 0.5, 1};
          for (int i = 0; i < 12; ++i) {
            // Footprints over several MIP levels (two levels or one: lambda fractional or not).
            double j = 1e-4 * std::pow(10.0, 3 * U(rng));
            const double fp[4] = {j, 0.3 * j * (U(rng) - 0.5), 0.2 * j * (U(rng) - 0.5), j};
            double u = U(rng), v = U(rng);
            V3 wo = dir(0.05);
            std::vector<V3> wi;
            // Every fourth query has its second light below the horizon.
            for (int l = 0; l < n_lights; ++l) wi.push_back(dir(i % 4 == 0 && l == 1 ? -1 : 0.02));
            auto paired = query(g, u, v, fp, wo, wi, false);
            auto single = query(g, u, v, fp, wo, wi, true);
            ++cases;
            if (std::memcmp(paired.data(), single.data(), sizeof paired) != 0) {
              ++mismatches;
              ADD_FAILURE() << precision << " " << NdfName(ndf) << " " << HoodName(hood) << " k "
                            << k << " lights " << n_lights << ": paired " << double(paired[0])
                            << " " << double(paired[1]) << " " << double(paired[2])
                            << ", one by one " << double(single[0]) << " " << double(single[1])
                            << " " << double(single[2]);
            }
            if (paired[0] > 0) ++nonzero;
          }
        }
  std::printf("%s: %d queries, %d with light, %d differ from one light at a time\n", precision,
              cases, nonzero, mismatches);
  // Most queries see some light (else the comparison would be of zeros).
  EXPECT_GT(nonzero, cases / 2) << precision;
}

TEST(PairedLights, SameBitsAsOneLightAtATime) {
  ExpectPairedLightsBitIdentical(k32::QueryLights, "fp32");
  ExpectPairedLightsBitIdentical(k64::QueryLights, "fp64");
}

}  // namespace
