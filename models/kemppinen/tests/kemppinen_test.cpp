// The Kemppinen et al. 2025 glinty NDF (models/kemppinen/; "K25") against independent
// references and the identities the paper states:
//   - the map T: |J_T| against finite differences of T itself (GGX and Beckmann, anisotropic),
//   - the Gaussian rectangle masses against quadrature of the normal density, in both tails,
//   - Eq. 2: averaged over uv positions, D_star = D within the computed statistical error,
//   - the spread of D_star / D per query falls as the density grows,
//   - k explicit neighbours + compensation (Eq. 9-10) against an explicit sum over every facet
//     of the level: unbiased, and the error falls with k,
//   - stability at the extremes and determinism in fp32; fp32 against fp64.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
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
using glint::test::NdfName;
using glint::test::Normalize;
using glint::test::Stats;
using glint::test::Summarise;
using glint::test::V3;

// ---------------------------------------------------------------------------------------------
// The map T (K25 3.2): the kernel's |J_T| is the area of U per unit solid angle, i.e. the
// determinant of T's differential. Reference: central differences of T along two orthonormal
// tangents of the sphere at h (error O(delta^2) ~ 1e-8 relative, rounding ~1e-16 / delta^2 ~ 1e-6).

TEST(DiskMap, JacobianMatchesFiniteDifferencesOfT) {
  const V3 hs[] = {
      {0.0, 0.0, 1.0}, {0.2, 0.1, 1.0}, {-0.5, 0.3, 1.0}, {0.9, -0.7, 1.0}, {0.05, 2.0, 1.0}};
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN})
    for (auto alphas : {std::array<double, 2>{0.3, 0.3}, std::array<double, 2>{0.5, 0.12}}) {
      Glinty g;
      g.ndf = ndf;
      g.ax = alphas[0];
      g.ay = alphas[1];
      for (V3 h0 : hs) {
        V3 h = Normalize(h0);
        // Orthonormal tangents t1, t2 at h.
        V3 a = std::fabs(h.z) < 0.9 ? V3{0, 0, 1} : V3{1, 0, 0};
        V3 t1 = Normalize({a.y * h.z - a.z * h.y, a.z * h.x - a.x * h.z, a.x * h.y - a.y * h.x});
        V3 t2 = {h.y * t1.z - h.z * t1.y, h.z * t1.x - h.x * t1.z, h.x * t1.y - h.y * t1.x};
        const double d = 1e-5;
        auto at = [&](double s1, double s2) {
          V3 p = Normalize({h.x + s1 * t1.x + s2 * t2.x, h.y + s1 * t1.y + s2 * t2.y,
                            h.z + s1 * t1.z + s2 * t2.z});
          return k64::ToDisk(g, p);
        };
        auto p1 = at(d, 0), m1 = at(-d, 0), p2 = at(0, d), m2 = at(0, -d);
        double dxdu = (p1.x - m1.x) / (2 * d), dydu = (p1.y - m1.y) / (2 * d);
        double dxdv = (p2.x - m2.x) / (2 * d), dydv = (p2.y - m2.y) / (2 * d);
        double numeric = std::fabs(dxdu * dydv - dxdv * dydu);
        auto c = k64::ToDisk(g, h);
        if (c.jac < 1e-6 * k64::ToDisk(g, {0, 0, 1}).jac) continue;  // T's rim: no digits left
        EXPECT_NEAR(c.jac / numeric, 1.0, 1e-5)
            << NdfName(ndf) << " alpha " << g.ax << "," << g.ay << " h " << h.x << "," << h.y;
        // The image lies in the disk of radius 1/2 about (1/2, 1/2) and the pole is its centre.
        EXPECT_LE(std::hypot(c.x - 0.5, c.y - 0.5), 0.5);
      }
      auto pole = k64::ToDisk(g, {0, 0, 1});
      EXPECT_DOUBLE_EQ(pole.x, 0.5);
      EXPECT_DOUBLE_EQ(pole.y, 0.5);
      // Grazing h goes to the rim (T is onto the disk).
      auto rim = k64::ToDisk(g, Normalize({1.0, 0.5, 1e-7}));
      EXPECT_NEAR(std::hypot(rim.x - 0.5, rim.y - 0.5), 0.5, 1e-5) << NdfName(ndf);
    }
}

// ---------------------------------------------------------------------------------------------
// The point-light pass's lobe (kemppinen_lobe_of_h: T(h), Eq. 4's 1 / sigma_a per axis and the
// Gaussian's norm, rearranged to fewer divisions) against an independent long-double
// evaluation of the paper's formulas for GGX: n = (hx / ax, hy / ay, hz) / |.| (the stretch,
// 3.2.1), x_a = 1/2 + (nx, ny) / (2 sqrt(1 + nz)) (Lambert, Eq. 7), |J_T| = (ax ay)^2 / (8 |M^T
// h|^3 (ax ay)^3) (kemppinen_to_disk; checked against finite differences of T above), sigma =
// alpha_star sqrt(|J_T|), sigma_x = sigma / a, sigma_y = sigma a. fp64 agrees to ~1e-15; fp32
// within the rounding of its ~16 operations (16 x 2^-24 relative for 1 / sigma, 19 for the norm,
// 8 ulps of 1/2 for x_a). Beckmann keeps kemppinen_to_disk and only shares the reciprocal: against
// the composed kemppinen_lobe(kemppinen_angular(.)) in the same precision, 1/sigma_x differs by
// at most 4 roundings, 1/sigma_y by 5 (fl(fl(1/s) fl(1/a)): 3 roundings against fl(1/fl(s a)): 2)
// and the norm by 13 (two more products on each side of those).
TEST(DiskMap, PointPassLobeMatchesThePaperFormulas) {
  const V3 hs[] = {{0.0, 0.0, 1.0},  {0.2, 0.1, 1.0},  {-0.5, 0.3, 1.0},
                   {0.9, -0.7, 1.0}, {0.05, 2.0, 1.0}, {3.0, -1.0, 0.01}};
  const double u = 5.96e-8;  // 2^-24
  double worst_rel32 = 0, worst_abs32 = 0;
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN})
    for (auto c :
         {std::array<double, 4>{0.3, 0.3, 0.02, 1.0}, std::array<double, 4>{0.5, 0.12, 0.05, 3.0},
          std::array<double, 4>{1e-3, 0.8, 1e-3, 0.2}, std::array<double, 4>{1.0, 1.0, 0.1, 1.0}}) {
      Glinty g;
      g.ndf = ndf;
      g.ax = c[0];
      g.ay = c[1];
      g.micro = c[2];
      g.aniso = c[3];
      for (V3 h0 : hs) {
        V3 h = Normalize(h0);
        auto l64 = k64::LobeOfH(g, h);
        auto l32 = k32::LobeOfH(g, h);
        if (ndf == GLINT_NDF_GGX) {
          using ld = long double;
          ld sx = ld(h.x) / ld(g.ax), sy = ld(h.y) / ld(g.ay), sz = ld(h.z);
          ld m = std::sqrt(sx * sx + sy * sy + sz * sz);  // |M^T h|
          ld nx = sx / m, ny = sy / m, nz = sz / m;
          ld x = 0.5L + nx / (2 * std::sqrt(1 + nz)), y = 0.5L + ny / (2 * std::sqrt(1 + nz));
          ld jac = 1 / (8 * ld(g.ax) * ld(g.ay) * m * m * m);
          ld sigma = ld(float(g.micro)) * std::sqrt(jac);
          ld a = ld(float(g.aniso));  // packed as float (kemppinen_params.h)
          ld inv_sx = a / sigma, inv_sy = 1 / (sigma * a);
          ld norm = inv_sx * inv_sy / (2 * ld(M_PI));
          const double ref[5] = {double(x), double(y), double(inv_sx), double(inv_sy),
                                 double(norm)};
          const double got64[5] = {l64.x, l64.y, l64.inv_sx, l64.inv_sy, l64.norm};
          const double got32[5] = {l32.x, l32.y, l32.inv_sx, l32.inv_sy, l32.norm};
          for (int i = 0; i < 5; ++i) {
            if (i < 2) {
              EXPECT_NEAR(got64[i], ref[i], 1e-14);
              EXPECT_NEAR(got32[i], ref[i], 8 * 0.5 * u) << "x_a, h " << h.x << "," << h.y;
              worst_abs32 = std::max(worst_abs32, std::fabs(got32[i] - ref[i]));
            } else {
              double rel32 = std::fabs(got32[i] / ref[i] - 1);
              EXPECT_NEAR(got64[i] / ref[i], 1.0, 1e-13);
              EXPECT_LE(rel32, (i == 4 ? 19 : 16) * u)
                  << "slot " << i << " alpha " << g.ax << "," << g.ay << " h " << h.x << "," << h.y;
              worst_rel32 = std::max(worst_rel32, rel32);
            }
          }
        } else {
          auto c64 = k64::LobeComposed(g, h);
          auto c32 = k32::LobeComposed(g, h);
          EXPECT_DOUBLE_EQ(l64.x, c64.x);
          EXPECT_DOUBLE_EQ(l64.y, c64.y);
          EXPECT_FLOAT_EQ(l32.x, c32.x);
          EXPECT_FLOAT_EQ(l32.y, c32.y);
          EXPECT_NEAR(l64.inv_sx / c64.inv_sx, 1.0, 1e-15);
          EXPECT_NEAR(l64.inv_sy / c64.inv_sy, 1.0, 1e-15);
          EXPECT_NEAR(l64.norm / c64.norm, 1.0, 1e-15);
          EXPECT_NEAR(double(l32.inv_sx) / double(c32.inv_sx), 1.0, 4 * u);
          EXPECT_NEAR(double(l32.inv_sy) / double(c32.inv_sy), 1.0, 5 * u);
          EXPECT_NEAR(double(l32.norm) / double(c32.norm), 1.0, 13 * u);
        }
      }
    }
  std::printf(
      "point-pass lobe (GGX) fp32 vs long double: x_a max abs %.3g, 1/sigma and norm max "
      "rel %.3g\n",
      worst_abs32, worst_rel32);
}

// ---------------------------------------------------------------------------------------------
// The level's log2 (kemppinen_log2_pos; fp32: exponent bits and the atanh series to s^9) against
// long double. Its error analysis: series truncation <= (2 / ln 2) s^11 / 11 / (1 - s^2) = 1.0e-9
// at |s| <= 3 - 2 sqrt 2; fp32 roundings: m - 1 exact (Sterbenz), s within 2 u, s^2 5 u, the
// Horner sum (terms after the first < 3% of it) ~2 u with its rounded coefficients, s p within
// 5 u, |s p| <= 0.5, so <= 2.5 u = 1.5e-7 absolute (u = 2^-24); then e + s p rounds once,
// <= 1/2 ulp of the result. Inputs: every binade of the level's argument's range [1e-30, 1e30]
// (log-uniform, plus each power of two, its neighbours and the split points sqrt(2) 2^e, where
// the exponent/mantissa decomposition changes). fp64 is the library's log2.
TEST(FastLog2, WithinItsBoundOfLongDouble) {
  const double u = 5.9604644775390625e-8;
  std::vector<float> xs;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> lx(std::log(1e-30), std::log(1e30));
  for (int i = 0; i < 200000; ++i) xs.push_back(float(std::exp(lx(rng))));
  for (int e = -99; e <= 99; ++e)
    for (double base : {1.0, std::sqrt(2.0)}) {
      float x = float(std::ldexp(base, e));
      xs.push_back(x);
      xs.push_back(std::nextafter(x, 0.0f));
      xs.push_back(std::nextafter(x, 1e38f));
    }
  for (int i = 0; i <= 100000; ++i) xs.push_back(float(0.5 + 2.5 * i / 100000.0));
  double worst = 0, worst_ulps = 0;
  size_t fp64_mismatches = 0;
  float first_fp64_mismatch = 0;
  for (float x : xs) {
    double got = k32::kemppinen_log2_pos(x);
    long double ref = std::log2((long double)x);
    double err = std::fabs(double((long double)got - ref));
    double half_ulp = 0.5 * std::fabs(double(std::nextafter(float(got), 1e38f) - float(got)));
    ASSERT_LE(err, 2.5 * u + 1e-9 + half_ulp) << "x = " << x << " got " << got;
    worst = std::max(worst, err);
    worst_ulps = std::max(worst_ulps, err / (2 * half_ulp));
    if (k64::kemppinen_log2_pos(double(x)) != std::log2(double(x)) && fp64_mismatches++ == 0)
      first_fp64_mismatch = x;
  }
  EXPECT_EQ(fp64_mismatches, 0u) << "fp64 differs from std::log2, first at x = "
                                 << first_fp64_mismatch;
  std::printf("fast log2 (fp32) vs long double over %zu inputs: max abs error %.3g, %.2f ulp\n",
              xs.size(), worst, worst_ulps);
}

// ---------------------------------------------------------------------------------------------
// Gaussian rectangle masses (the erf of Eq. 10): Abramowitz & Stegun 7.1.26 for erfc, arranged
// so tails do not cancel. First the approximation against libm over [0, 12] (its published
// bound: absolute error <= 1.5e-7), then the masses against composite Simpson quadrature of the
// normal density (4000 panels: error ~ (b-a)^5 / n^4 * max|f^(4)| < 1e-14 for these unit-length
// intervals): a mass is half a difference or sum of two erfc values, so its error is within
// the same 1.5e-7. fp32 adds the rounding of the Horner evaluation: <= 2 n eps sum |a_i| t^i with
// n = 5, eps = 2^-24 and sum |a_i| = 4.48 (t <= 1), i.e. 2.7e-6, plus the exp's few ulps.

const double kFp32ErfcBound = 1.5e-7 + 2 * 5 * 5.96e-8 * 4.48 + 4 * 5.96e-8;

TEST(RectangleMass, ErfcApproximationWithinItsPublishedBoundOfLibm) {
  double worst64 = 0, worst32 = 0;
  for (int i = 0; i <= 120000; ++i) {
    double x = i * 1e-4 * std::sqrt(2.0);  // erfc_abs takes x = sqrt(2) y
    double ref = std::erfc(x / std::sqrt(2.0));
    worst64 = std::max(worst64, std::fabs(double(k64::kemppinen_erfc_abs(x)) - ref));
    worst32 = std::max(worst32, std::fabs(double(k32::kemppinen_erfc_abs(float(x))) - ref));
  }
  std::printf("erfc (A&S 7.1.26) vs libm on [0, 12]: max absolute error %.3g (fp64), %.3g (fp32)\n",
              worst64, worst32);
  EXPECT_LE(worst64, 1.5e-7);
  EXPECT_LE(worst32, kFp32ErfcBound);
}

// The compensation's erfc with the cut (kemppinen_erfc4): beyond GLINT_KEMPPINEN_ERFC_CUT = 6
// standard scores it is exactly 0, which adds at most erfc(6 / sqrt 2) = 1.97e-9 (libm) to the
// approximation's own error; inside it is the approximation. Against libm on [-12, 12], each of
// the four slots, in both precisions.
TEST(RectangleMass, ErfcCutBeyondSixSigmaWithinTheBoundPlusTheTail) {
  const double tail = std::erfc(6.0 / std::sqrt(2.0));
  EXPECT_LT(tail, 2e-9);
  double worst64 = 0, worst32 = 0;
  for (int i = -12000; i <= 12000; ++i) {
    double x = i * 1e-3;
    double ref = std::erfc(std::fabs(x) / std::sqrt(2.0));
    k64::KemppinenErfc4 e = k64::kemppinen_erfc4(x, -x, 0.5 * x, 7.0);
    k32::KemppinenErfc4 f = k32::kemppinen_erfc4(float(x), float(-x), float(0.5 * x), 7.0f);
    for (double v : {double(e.a), double(e.b)}) worst64 = std::max(worst64, std::fabs(v - ref));
    for (double v : {double(f.a), double(f.b)}) worst32 = std::max(worst32, std::fabs(v - ref));
    double ref_half = std::erfc(std::fabs(0.5 * x) / std::sqrt(2.0));
    worst64 = std::max(worst64, std::fabs(double(e.c) - ref_half));
    worst32 = std::max(worst32, std::fabs(double(f.c) - ref_half));
    EXPECT_EQ(double(e.d), 0.0);  // 7 sigma: cut
    EXPECT_EQ(double(f.d), 0.0);
    if (std::fabs(x) >= 6.0) {
      EXPECT_EQ(double(e.a), 0.0) << x;
      EXPECT_EQ(double(f.a), 0.0) << x;
    }
  }
  std::printf(
      "erfc with the 6-sigma cut vs libm on [-12, 12]: max absolute error %.3g (fp64), "
      "%.3g (fp32)\n",
      worst64, worst32);
  EXPECT_LE(worst64, 1.5e-7 + tail);
  EXPECT_LE(worst32, kFp32ErfcBound + tail);
}

double SimpsonMass(double a, double b) {
  const int n = 4000;
  double h = (b - a) / n, sum = 0;
  auto f = [](double x) { return std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI); };
  for (int i = 0; i <= n; ++i) sum += f(a + i * h) * (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2));
  return sum * h / 3;
}

TEST(RectangleMass, MatchesQuadratureInBothTailsAndInTheMiddle) {
  const double intervals[][2] = {{-1, 2},  {0.5, 1.5}, {-1.5, -0.5}, {5, 6},
                                 {-6, -5}, {8, 9},     {-9, -8},     {-0.1, 0.2}};
  for (auto &iv : intervals) {
    double ref = SimpsonMass(iv[0], iv[1]);
    EXPECT_NEAR(k64::Mass(iv[0], iv[1]), ref, 1.5e-7) << iv[0] << " " << iv[1];
    EXPECT_NEAR(k32::Mass(iv[0], iv[1]), ref, kFp32ErfcBound) << iv[0] << " " << iv[1];
    EXPECT_GE(k32::Mass(iv[0], iv[1]), 0.0);
  }
}

// ---------------------------------------------------------------------------------------------
// Eq. 2: lim 1/|X| int_X D_star(x, h) dx = D(h). Monte Carlo over uv positions spread over ~1e8
// grid cells (independent facets); the tolerance is 4.5 standard errors of that mean plus the
// method's known bias bounds: the lobe mass beyond the disk edge (h chosen >= 6 lobe sigmas
// inside: < 1e-9) and, for the sheared footprint, the spatial compensation's diagonal
// approximation, bounded by the filter mass outside the spatial block (computed per sample).

struct Eq2Case {
  int ndf;
  double ax, ay, aniso, micro, lambda;
};

TEST(GlintyNdf, AveragedOverUvEqualsTheSmoothNdf) {
  const Eq2Case cases[] = {
      {GLINT_NDF_GGX, 0.3, 0.3, 1.0, 0.02, 3.5},
      {GLINT_NDF_BECKMANN, 0.3, 0.3, 1.0, 0.02, 3.5},
      {GLINT_NDF_GGX, 0.4, 0.1, 3.0, 0.005, 7.0},  // anisotropic glints and NDF
      {GLINT_NDF_BECKMANN, 0.4, 0.2, 0.4, 0.005, 6.5},
      {GLINT_NDF_GGX, 0.6, 0.6, 1.0, 0.08, -0.5},  // lambda < 0: level 0, one angular cell
  };
  const V3 hs[] = {{0, 0, 1}, {0.15, -0.1, 1}, {-0.2, 0.05, 1}};
  for (const Eq2Case &c : cases) {
    // Below level 0 few footprints hold a facet (spread ~20): more samples for the same SE.
    const int count = c.lambda < 0 ? 200000 : 40000;
    Glinty g;
    g.ndf = c.ndf;
    g.ax = c.ax;
    g.ay = c.ay;
    g.aniso = c.aniso;
    g.micro = c.micro;
    auto fp = FootprintForLevel(g, c.lambda);
    for (V3 h0 : hs) {
      V3 h = Normalize(h0);
      auto disk = k64::ToDisk(g, h);
      auto ang = k64::Angular(g, h);
      double edge = 0.5 - std::hypot(disk.x - 0.5, disk.y - 0.5);
      ASSERT_GT(edge, 6 * std::max(ang.sx, ang.sy)) << "h too close to the rim for this bound";
      std::mt19937_64 rng(17);
      std::uniform_real_distribution<double> uni(0.0, 100.0);
      std::vector<double> s(count);
      for (int i = 0; i < count; ++i)
        s[size_t(i)] = k64::GlintFactor(g, uni(rng), uni(rng), fp.data(), h);
      Stats st = Summarise(s);
      double D = k64::SmoothD(g, h);
      std::printf(
          "Eq. 2 %-8s alpha %.2f,%.2f a %.1f lambda %4.1f h (%.2f,%.2f): mean D*/D %.4f "
          "+- %.4f (spread %.2f)\n",
          NdfName(c.ndf), c.ax, c.ay, c.aniso, c.lambda, h.x, h.y, st.mean, st.se(), st.spread());
      EXPECT_NEAR(st.mean * D, D, 4.5 * st.se() * D + 1e-9 * D)
          << NdfName(c.ndf) << " lambda " << c.lambda;
    }
  }
}

// The same identity for a sheared footprint, where the spatial compensation's P_s uses the
// diagonal of Sigma_s: its error is at most the filter mass outside the 2x2 spatial block,
// which the test bounds per sample by the union of the two axes' tails (libm erfc, in double).
TEST(GlintyNdf, AveragedOverUvEqualsTheSmoothNdfForShearedFootprints) {
  Glinty g;
  const double j = 2e-3;
  const double fp[4] = {j, 0.7 * j, -0.4 * j, j};
  const V3 h = Normalize({0.1, 0.2, 1});
  const int count = 200000;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uni(0.0, 100.0);
  std::vector<double> s(count);
  double bias_bound = 0;
  for (int i = 0; i < count; ++i) {
    double u = uni(rng), v = uni(rng);
    s[size_t(i)] = k64::GlintFactor(g, u, v, fp, h);
    auto f = k64::MakeFootprint(g, u, v, fp);
    double lf = std::floor(f.lambda), w1 = f.lambda - lf;
    for (int l : {int(lf), int(lf) + 1}) {
      double w = l == int(lf) ? 1 - w1 : w1;
      auto b = k64::kemppinen_blocks(k64::MakeParams(g), f, k64::Angular(g, h), double(l));
      double ssx = std::sqrt(f.sxx) * b.res_s, ssy = std::sqrt(f.syy) * b.res_s;
      auto tails = [](double lo, double hi) {
        return 0.5 * std::erfc(-lo / std::sqrt(2.0)) + 0.5 * std::erfc(hi / std::sqrt(2.0));
      };
      bias_bound += w * (tails((b.bs_x - b.ts_x) / ssx, (b.bs_x + 2 - b.ts_x) / ssx) +
                         tails((b.bs_y - b.ts_y) / ssy, (b.bs_y + 2 - b.ts_y) / ssy));
    }
  }
  bias_bound /= count;
  Stats st = Summarise(s);
  std::printf("Eq. 2 sheared footprint: mean D*/D %.4f +- %.4f, P_s bias bound %.2e\n", st.mean,
              st.se(), bias_bound);
  EXPECT_NEAR(st.mean, 1.0, 4.5 * st.se() + bias_bound);
}

// Per-glint colours (K25 3.3.6): each facet takes one of two colours from its cell's hash, the
// compensation the mean colour. Averaged over uv, D_star / D per channel is the mean colour
// (Eq. 2 per channel, within 4.5 standard errors); bright pixels of a sparse pattern are single
// facets, so their g / r ratio is one of the two colours' (within 0.05), about half each
// (binomial: |n0 - n1| <= 4.5 sqrt(n0 + n1)), and together most of them (>= 80%; the rest mix
// two facets or the compensation).
TEST(GlintyNdf, ColouredGlintsAverageToTheMeanColourAndComeInTheGivenColours) {
  Glinty g;
  g.colors = {1.0, 0.2, 0.1, 1.0, 0.9, 0.2};
  std::array<double, 3> mean{};
  for (int ch = 0; ch < 3; ++ch)
    mean[size_t(ch)] = 0.5 * (g.colors[size_t(ch)] + g.colors[size_t(3 + ch)]);
  const V3 h = Normalize({0.1, -0.05, 1});
  {
    auto fp = FootprintForLevel(g, 3.5);
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> uni(0.0, 100.0);
    std::array<std::vector<double>, 3> s;
    for (int i = 0; i < 40000; ++i) {
      auto c = k64::GlintFactorRgb(g, uni(rng), uni(rng), fp.data(), h);
      for (int ch = 0; ch < 3; ++ch) s[size_t(ch)].push_back(c[size_t(ch)]);
    }
    for (int ch = 0; ch < 3; ++ch) {
      Stats st = Summarise(s[size_t(ch)]);
      std::printf("coloured glints, channel %d: mean D*/D %.4f +- %.4f, mean colour %.4f\n", ch,
                  st.mean, st.se(), mean[size_t(ch)]);
      EXPECT_NEAR(st.mean, mean[size_t(ch)], 4.5 * st.se()) << "channel " << ch;
    }
  }
  {
    Glinty sparse = g;
    sparse.density = 1e5;
    const double fp[4] = {1e-3, 0, 0, 1e-3};
    std::mt19937_64 rng(32);
    std::uniform_real_distribution<double> uni(0.0, 100.0);
    int bright = 0, first = 0, second = 0;
    const double r0 = 0.2, r1 = 0.9;  // g / r of the two colours
    for (int i = 0; i < 40000; ++i) {
      auto c = k64::GlintFactorRgb(sparse, uni(rng), uni(rng), fp, h);
      if (!(c[0] > 5.0)) continue;
      ++bright;
      double ratio = c[1] / c[0];
      first += std::fabs(ratio - r0) < 0.05;
      second += std::fabs(ratio - r1) < 0.05;
    }
    std::printf("coloured glints: %d bright pixels, %d of colour 0, %d of colour 1\n", bright,
                first, second);
    EXPECT_GT(bright, 100);
    EXPECT_GE(first + second, bright * 8 / 10);
    EXPECT_LE(std::abs(first - second), 4.5 * std::sqrt(double(first + second)));
  }
}

// Each query approaches D as the density grows (K25 3.3.2: "the appearance quickly converges to
// that of a smooth BRDF"): the relative spread of D_star / D over uv positions at a fixed
// footprint, per decade of density. Asserted: it falls over every two decades, and it is below
// 5% at 1e12 facets per unit uv area (10^6 facets in the footprint's lobe region).
TEST(GlintyNdf, SpreadPerQueryFallsAsTheDensityGrows) {
  const double fp[4] = {1e-3, 0, 0, 1e-3};
  const V3 h = Normalize({0.1, -0.05, 1});
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    double previous = HUGE_VAL;
    for (int decade = 2; decade <= 12; ++decade) {
      Glinty g;
      g.ndf = ndf;
      g.density = std::pow(10.0, decade);
      std::mt19937_64 rng(3);
      std::uniform_real_distribution<double> uni(0.0, 100.0);
      std::vector<double> s(4000);
      for (double &x : s) x = k64::GlintFactor(g, uni(rng), uni(rng), fp, h);
      Stats st = Summarise(s);
      std::printf("%-8s density 1e%-2d: D*/D mean %.3f, relative spread %.4g\n", NdfName(ndf),
                  decade, st.mean, st.spread());
      if (decade % 2 == 0) {
        EXPECT_LT(st.spread(), previous) << NdfName(ndf) << " density 1e" << decade;
        previous = st.spread();
      }
      if (decade == 12) {
        EXPECT_LT(st.spread(), 0.05) << NdfName(ndf);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The facet hash (kemppinen_facet_key, kemppinen_facet_of_key): every field of a facet (spatial
// offsets, angular offsets, roulette number, colour pick) uniform on [0, 1), every pair of
// fields independent, and each of the six fields independent of the same field in the next
// angular cell along x and along y (the cells whose packed keys ix + 2^16 iy differ by 1 and by
// 2^16) and in the next spatial cell. Reference: the uniform distribution, by chi-square over
// 640000 facets per level (levels 6, 9 and 20: at 6 and 9 the 40 x 40 block lies inside the
// grid's 2^l cells per axis; 20 is beyond the packing's injective range l <= 16): 16 bins per
// field (15 degrees of freedom), 8 x 8 per pair (63). Each statistic against its 0.9999 quantile
// (Wilson-Hilferty, within 1% at these degrees of freedom): 117 statistics, so a correct hash
// fails one with probability ~1%. The draws as mix(key ^ 2) (the derivation of the hash before
// session 18, there for sy against ay) failed the test's first form (160000 facets, level 3) at sy
// against pick, 118.5; with 4x the facets that defect's expected statistic is ~300. At this size
// the test also caught the packed word absorbed without its odd multiplier (kemppinen_facet_key):
// ay against the x neighbour's ay, 106.5 at level 9 (609 at 2e7 even-ix samples).
namespace {
double ChiSquareQuantile9999(int dof) {
  const double z = 3.7190164854556804, k = dof;  // the standard normal's 0.9999 quantile
  const double t = 1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k));
  return k * t * t * t;
}
}  // namespace

TEST(FacetHash, FieldsUniformAndIndependentWithinAndAcrossCells) {
  Glinty g;
  const char *names[6] = {"sx", "sy", "ax", "ay", "r", "pick"};
  const double q15 = ChiSquareQuantile9999(15), q63 = ChiSquareQuantile9999(63);
  double worst1 = 0, worst2 = 0;
  for (int level : {6, 9, 20}) {
    // 1600 spatial cells x a 20 x 20 angular block (every other cell, from 65516 at level 20
    // so that the block crosses 2^16), each facet against its neighbours at x + 1, y + 1 and
    // in the next spatial cell: disjoint pairs (overlapping ones would not be chi-square).
    const double i0 = level == 20 ? 65516.0 : 0.0;
    std::vector<std::array<double, 6>> f, fx, fy, fs;
    for (int c = 0; c < 1600; ++c)
      for (int ix = 0; ix < 20; ++ix)
        for (int iy = 0; iy < 20; ++iy) {
          const double x = i0 + 2 * ix, y = i0 + 2 * iy, cx = 2 * c, cy = 7 * c + 1;
          f.push_back(k64::FacetFields(g, level, cx, cy, x, y));
          fx.push_back(k64::FacetFields(g, level, cx, cy, x + 1, y));
          fy.push_back(k64::FacetFields(g, level, cx, cy, x, y + 1));
          fs.push_back(k64::FacetFields(g, level, cx + 1, cy, x, y));
        }
    const double n = double(f.size());
    for (int a = 0; a < 6; ++a) {
      std::array<double, 16> c{};
      for (const auto &v : f) c[size_t(v[size_t(a)] * 16)] += 1;
      double chi2 = 0, e = n / 16;
      for (double k : c) chi2 += (k - e) * (k - e) / e;
      worst1 = std::max(worst1, chi2);
      EXPECT_LT(chi2, q15) << "level " << level << " field " << names[a];
    }
    // Pairs (a, b) of the same facet, a < b, then field a against field a of a neighbour.
    auto pair_chi2 = [&](const std::vector<std::array<double, 6>> &p, int a, int b) {
      std::array<double, 64> c{};
      for (size_t i = 0; i < f.size(); ++i)
        c[size_t(f[i][size_t(a)] * 8) * 8 + size_t(p[i][size_t(b)] * 8)] += 1;
      double chi2 = 0, e = n / 64;
      for (double k : c) chi2 += (k - e) * (k - e) / e;
      return chi2;
    };
    for (int a = 0; a < 6; ++a)
      for (int b = a + 1; b < 6; ++b) {
        double chi2 = pair_chi2(f, a, b);
        worst2 = std::max(worst2, chi2);
        EXPECT_LT(chi2, q63) << "level " << level << " " << names[a] << " vs " << names[b];
      }
    for (int a = 0; a < 6; ++a) {  // each field against the neighbours' same field
      for (const auto *p : {&fx, &fy, &fs}) {
        double chi2 = pair_chi2(*p, a, a);
        worst2 = std::max(worst2, chi2);
        EXPECT_LT(chi2, q63) << "level " << level << " " << names[a] << " vs a neighbour's";
      }
    }
  }
  std::printf(
      "facet hash: worst chi-square %.1f of one field (15 dof, 0.9999 quantile %.1f), "
      "%.1f of a pair (63 dof, %.1f)\n",
      worst1, q15, worst2, q63);
}

// ---------------------------------------------------------------------------------------------
// Eq. 9-11 against the explicit sum over every facet of the level (the slow test-only path):
// the estimate (2x2 spatial x k angular cells + compensation) and the full sum have the same
// expectation (the mean difference is within 4.5 standard errors), and the error per query
// falls as k grows.
TEST(Compensation, KNeighboursAgainstTheSumOverEveryFacet) {
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    Glinty g;
    g.ndf = ndf;
    g.micro = 0.05;
    const int level = 6;
    auto fp = FootprintForLevel(g, level);
    const int count = 300;
    std::mt19937_64 rng(8);
    std::uniform_real_distribution<double> uni(0.0, 100.0), tilt(-0.25, 0.25);
    std::vector<std::array<double, 3>> queries(count);
    std::vector<V3> hs(count);
    std::vector<double> full(count);
    for (int i = 0; i < count; ++i) {
      queries[size_t(i)] = {uni(rng), uni(rng), 0};
      hs[size_t(i)] = Normalize({tilt(rng), tilt(rng), 1});
      full[size_t(i)] = k64::LevelFullSum(g, queries[size_t(i)][0], queries[size_t(i)][1],
                                          fp.data(), hs[size_t(i)], level, 7.0, 7.0);
    }
    Stats sf = Summarise(full);
    double previous = HUGE_VAL;
    for (int k : {1, 4, 9, 16}) {
      g.neighbors = k;
      std::vector<double> diff(count);
      double sq = 0;
      for (int i = 0; i < count; ++i) {
        double est = k64::LevelEstimate(g, queries[size_t(i)][0], queries[size_t(i)][1], fp.data(),
                                        hs[size_t(i)], level);
        diff[size_t(i)] = est - full[size_t(i)];
        sq += diff[size_t(i)] * diff[size_t(i)];
      }
      Stats sd = Summarise(diff);
      double rms = std::sqrt(sq / count) / sf.mean;
      std::printf(
          "%-8s k = %2d: RMS error vs every facet %.4f of the mean (mean %.3f), bias %.4f "
          "+- %.4f\n",
          NdfName(ndf), k, rms, sf.mean, sd.mean / sf.mean, sd.se() / sf.mean);
      EXPECT_NEAR(sd.mean, 0.0, 4.5 * sd.se() + 1e-12) << NdfName(ndf) << " k " << k;
      EXPECT_LT(rms, previous) << NdfName(ndf) << " k " << k;
      previous = rms;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Furnace (K25 Fig. 15): directional albedo of the glinty BRDF relative to the smooth one,
// averaged over uv at a converged density (1e9 facets per unit uv, footprint 1e-3: per-query
// spread ~5%), wi cosine-weighted (estimator pi f). E[D_star | h] <= D because the facet lobes
// lose mass beyond the disk rim, so the ratio is <= 1 within the statistical error (asserted).
// How much is lost depends on microroughness against roughness (K25 Fig. 14 right: particles
// rougher than the surface lose the highlight's energy): the ratios measured on 2026-11-30 are
// asserted to within 0.02 as a regression guard only (no independent bound: the loss is the lobe
// mass beyond the rim integrated over the BRDF's lobe, which the paper also only measures).
TEST(KemppinenModel, FurnaceEnergyRelativeToSmoothRegressionGuard) {
  const V3 wo = Normalize({0.5, 0.0, 1.0});
  const double fp[4] = {1e-3, 0, 0, 1e-3};
  // Measured glinty / smooth albedo per (ndf, microroughness, alpha) in the loop order below.
  const double measured[] = {0.999, 1.000, 1.001, 0.258, 0.946, 1.000,
                             0.896, 0.997, 0.999, 0.113, 0.714, 0.981};
  int c = 0;
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN})
    for (double micro : {0.02, 0.2})
      for (double alpha : {0.05, 0.3, 1.0}) {
        Glinty g;
        g.ndf = ndf;
        g.density = 1e9;
        g.micro = micro;
        g.ax = g.ay = alpha;
        std::mt19937_64 rng(12);
        std::uniform_real_distribution<double> uni(0.0, 1.0), pos(0.0, 100.0);
        const int count = 20000;
        std::vector<double> glinty(count), smooth(count);
        for (int i = 0; i < count; ++i) {
          double r = std::sqrt(uni(rng)), phi = 2 * M_PI * uni(rng);
          V3 wi = {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - r * r))};
          glinty[size_t(i)] = M_PI * k64::Query(g, pos(rng), pos(rng), fp, wo, wi, true)[0];
          smooth[size_t(i)] = M_PI * k64::SmoothProbe(g, wo, wi);
        }
        Stats sg = Summarise(glinty), ss = Summarise(smooth);
        double ratio = sg.mean / ss.mean;
        std::vector<double> e(count);
        for (int i = 0; i < count; ++i)
          e[size_t(i)] = glinty[size_t(i)] - ratio * smooth[size_t(i)];
        double se = Summarise(e).se() / ss.mean;
        std::printf(
            "furnace %-8s alpha %.2f microroughness %.2f: albedo %.4f, glinty / smooth "
            "%.4f +- %.4f\n",
            NdfName(ndf), alpha, micro, ss.mean, ratio, se);
        EXPECT_LE(ratio, 1.0 + 4.5 * se);
        EXPECT_NEAR(ratio, measured[c++], 0.02 + 4.5 * se) << "regression guard";
      }
}

// ---------------------------------------------------------------------------------------------
// Stability at the extremes (DESIGN.md; the shader's pitfalls, notes Sec. 5): finite,
// non-negative and deterministic in fp32 through kemppinen_query, probes and lights.

TEST(KemppinenModel, StableAndDeterministicAtTheExtremesInFp32) {
  struct Case {
    const char *what;
    Glinty g;
    std::array<double, 4> fp;
    double u, v;
    V3 wo, wi;
  };
  Glinty base;
  std::vector<Case> cases;
  const std::array<double, 4> fp0 = {1e-3, 0, 0, 1e-3};
  const V3 wo0 = Normalize({0.3, 0.1, 1}), wi0 = Normalize({-0.3, -0.1, 1});
  auto add = [&](const char *what, Glinty g, std::array<double, 4> fp, double u, double v, V3 wo,
                 V3 wi) {
    cases.push_back({what, g, fp, u, v, wo, wi});
  };
  add("base", base, fp0, 0.3, 0.7, wo0, wi0);
  add("zero footprint (det = 0, lambda <= 0)", base, {0, 0, 0, 0}, 0.3, 0.7, wo0, wi0);
  add("rank-1 footprint (det -> 0)", base, {1e-3, 1e-3, 1e-3, 1e-3}, 0.3, 0.7, wo0, wi0);
  add("enormous footprint", base, {1e3, 0, 0, 1e3}, 0.3, 0.7, wo0, wi0);
  add("footprint near FLT_MAX", base, {3e38, -3e38, 3e38, 3e38}, 0.3, 0.7, wo0, wi0);
  add("uv = 1e7", base, fp0, 1e7, -1e7, wo0, wi0);
  add("grazing wo", base, fp0, 0.3, 0.7, Normalize({1, 0, 1e-6}), wi0);
  add("grazing wi", base, fp0, 0.3, 0.7, wo0, Normalize({-1, 0.2, 1e-6}));
  add("h grazing (1 + v_z -> 0 in the Lambert map)", base, fp0, 0.3, 0.7, Normalize({1, 0, 1e-3}),
      Normalize({1, 0.01, 1e-3}));
  add("wi = -wo mirrored below", base, fp0, 0.3, 0.7, wo0, {-wo0.x, -wo0.y, -wo0.z});
  for (double density : {1e-3, 1e15, 1e30}) {
    Glinty g = base;
    g.density = density;
    add("density extreme", g, fp0, 0.3, 0.7, wo0, wi0);
    add("density extreme, tiny footprint", g, {1e-9, 0, 0, 1e-9}, 0.3, 0.7, wo0, wi0);
    add("density extreme, zero footprint", g, {0, 0, 0, 0}, 0.3, 0.7, wo0, wi0);
    add("density extreme, huge footprint", g, {10, 0, 0, 10}, 0.3, 0.7, wo0, wi0);
    add("density extreme, footprint 1e30", g, {1e30, 1e30, 0, 1e30}, 0.3, 0.7, wo0, wi0);
  }
  for (double alpha : {1e-4, 1.0}) {
    Glinty g = base;
    g.ax = g.ay = alpha;
    add("alpha extreme", g, fp0, 0.3, 0.7, wo0, wi0);
    add("alpha extreme at the mirror direction", g, fp0, 0.3, 0.7, wo0, {-wo0.x, -wo0.y, wo0.z});
  }
  for (double micro : {1e-5, 1.0}) {
    Glinty g = base;
    g.micro = micro;
    add("microroughness extreme", g, fp0, 0.3, 0.7, wo0, {-wo0.x, -wo0.y, wo0.z});
  }
  for (double aniso : {0.05, 20.0}) {
    Glinty g = base;
    g.aniso = aniso;
    add("anisotropy extreme", g, fp0, 0.3, 0.7, wo0, wi0);
  }
  size_t n = cases.size();
  for (size_t i = 0; i < n; ++i) {
    Case c = cases[i];
    c.g.ndf = GLINT_NDF_BECKMANN;
    cases.push_back(c);
  }
  for (const Case &c : cases)
    for (int k : {1, 4, 9, 16})
      for (int hood : {GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER, GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL,
                       GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL}) {
        for (bool probe : {false, true}) {
          Glinty g = c.g;
          g.neighbors = k;
          g.neighborhood = hood;
          auto a = k32::Query(g, c.u, c.v, c.fp.data(), c.wo, c.wi, probe);
          auto b = k32::Query(g, c.u, c.v, c.fp.data(), c.wo, c.wi, probe);
          for (int ch = 0; ch < 3; ++ch) {
            EXPECT_TRUE(std::isfinite(a[size_t(ch)]) && a[size_t(ch)] >= 0.0)
                << c.what << " " << NdfName(g.ndf) << " k " << k << " neighbourhood " << hood
                << " probe " << probe << " = " << a[size_t(ch)];
            EXPECT_EQ(a[size_t(ch)], b[size_t(ch)]) << c.what;
          }
        }
      }
}

// The parameter ranges the validation accepts, crossed (a stability sweep for this model):
// every combination of extreme and typical density, roughness, microroughness, anisotropy,
// filter size and footprint, with both NDFs, every k, probes and a light, at uv 0.3 and 1e7 and
// a grazing and a tilted view: finite and non-negative in fp32.
TEST(KemppinenModel, StableOverTheCrossedParameterRangesInFp32) {
  const double densities[] = {1e-6, 1e-3, 1.0, 1e6, 1e15, 1e30};
  const double alphas[] = {1e-4, 0.3, 1.0};
  const double micros[] = {1e-5, 0.02, 1.0};
  const double anisos[] = {0.05, 1.0, 20.0};
  const double filters[] = {0.1, 0.7, 4.0};
  const std::array<double, 4> fps[] = {
      {0, 0, 0, 0},     {1e-9, 0, 0, 1e-9}, {1e-3, 2e-4, -1e-4, 1e-3},
      {1e3, 0, 0, 1e3}, {3e38, 0, 0, 3e38}, {1e-3, 1e-3, 1e-3, 1e-3}};
  const V3 wos[] = {Normalize({0.3, 0.1, 1}), Normalize({1, 0.2, 1e-5})};
  const V3 wi = Normalize({-0.2, -0.1, 1});
  long checked = 0, bad = 0;
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN})
    for (double density : densities)
      for (double alpha : alphas)
        for (double micro : micros)
          for (double aniso : anisos)
            for (double filter : filters)
              for (const auto &fp : fps) {
                Glinty g;
                g.ndf = ndf;
                g.density = density;
                g.ax = alpha;
                g.ay = std::min(1.0, 2 * alpha);
                g.micro = micro;
                g.aniso = aniso;
                g.filter = filter;
                g.neighbors = 1 + int(checked % 4) * (int(checked % 4) + 2);  // 1, 4, 9, 16
                g.neighborhood = int((checked / 4) % 3);  // GLINT_KEMPPINEN_NEIGHBORHOOD_*
                for (double u : {0.3, 1e7})
                  for (const V3 &wo : wos)
                    for (bool probe : {false, true}) {
                      auto a = k32::Query(g, u, 0.7, fp.data(), wo, wi, probe);
                      ++checked;
                      for (double c : a)
                        if (!(std::isfinite(c) && c >= 0.0) && ++bad <= 5)
                          ADD_FAILURE()
                              << NdfName(ndf) << " density " << density << " alpha " << alpha
                              << " micro " << micro << " aniso " << aniso << " filter " << filter
                              << " fp " << fp[0] << " u " << u << " probe " << probe << " = " << c;
                    }
              }
  std::printf("crossed parameter sweep: %ld queries, %ld bad\n", checked, bad);
  EXPECT_EQ(bad, 0);
}

// fp32 against fp64 where the problem is well conditioned (uv in [0, 10], moderate footprint and
// parameters): a float rounding of x_s res_s (~1e3 cells: ~6e-5 cells absolute) moves a facet
// lobe's exponent by at most |d q / d x| ~ 2 * 3 sigma / sigma^2 * 6e-5 cells ~ 1e-3 relative
// with sigma >= 0.25 cells; allowed: 2e-3 relative for 99% of queries. The rest may see floor()
// pick another block (an x_s res_s within rounding of a cell boundary).
TEST(KemppinenModel, Fp32AgreesWithFp64WhereWellConditioned) {
  for (int hood : {GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER, GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL,
                   GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL})
    for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
      Glinty g;
      g.ndf = ndf;
      g.neighborhood = hood;
      g.micro = 0.05;
      std::mt19937_64 rng(21);
      std::uniform_real_distribution<double> uni(0.0, 10.0), tilt(-0.3, 0.3);
      const std::array<double, 4> fp = {4e-3, 1e-3, -5e-4, 3e-3};
      int agree = 0, lit = 0;
      const int count = 2000;
      for (int i = 0; i < count; ++i) {
        double u = uni(rng), v = uni(rng);
        V3 wo = Normalize({tilt(rng), tilt(rng), 1}), wi = Normalize({tilt(rng), tilt(rng), 1});
        double a = k32::Query(g, u, v, fp.data(), wo, wi, true)[0];
        double b = k64::Query(g, u, v, fp.data(), wo, wi, true)[0];
        agree += std::fabs(a - b) <= 2e-3 * std::fabs(b) + 1e-30;
        lit += b > 0;
      }
      EXPECT_GT(lit, count / 2) << NdfName(ndf) << " neighbourhood " << hood;
      EXPECT_GE(agree, count * 99 / 100) << NdfName(ndf) << " neighbourhood " << hood;
    }
}

}  // namespace
