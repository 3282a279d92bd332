// The P-NDF of Yan et al. 2014 (models/normal_map/normal_map_pndf.h) against independent
// references: closed forms (flat, tilted and linear normal fields, where the P-NDF is a
// Gaussian), binning of footprint samples (the paper's Fig. 9 check), brute-force quadrature of
// its integral over (s, t) (normalisation), and the pruning error bound the cut-off implies.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "models/normal_map/normal_map_table.h"
#include "tests/support/kernels_both_precisions.h"

namespace glint {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A W x H vertex grid whose (s, t) is f(i, j).
template <class F>
std::vector<float> Table(uint32_t w, uint32_t h, F f, int subdivision = 1) {
  std::vector<float> st(size_t(w) * h * 2);
  for (uint32_t j = 0; j < h; ++j)
    for (uint32_t i = 0; i < w; ++i) {
      const auto [s, t] = f(double(i), double(j));
      st[(size_t(j) * w + i) * 2] = float(s);
      st[(size_t(j) * w + i) * 2 + 1] = float(t);
    }
  return BuildNormalMapTable(w, h, st, subdivision);
}

double Pndf64(const std::vector<float> &table, double u, double v, const double fp[4], double s,
              double t, double sigma_r, double cutoff, k64::NmStats *stats = nullptr) {
  k64::NmStats local{};
  return k64::nm_pndf(table.data(), u, v, fp, s, t, sigma_r, cutoff, stats ? stats : &local);
}

float Pndf32(const std::vector<float> &table, float u, float v, const double fp64[4], float s,
             float t, float sigma_r, float cutoff) {
  k32::NmStats local{};
  const float fp[4] = {float(fp64[0]), float(fp64[1]), float(fp64[2]), float(fp64[3])};
  return k32::nm_pndf(table.data(), u, v, fp, s, t, sigma_r, cutoff, &local);
}

// The footprint Gaussian's covariance in vertex coordinates (the model's definition, README:
// Sigma = (0.5 px)^2 J J^T scaled by W, H, plus the 0.01-texel floor).
void FootprintCovariance(uint32_t w, uint32_t h, const double fp[4], double c[3]) {
  const double ax = fp[0] * w, ay = fp[1] * h, bx = fp[2] * w, by = fp[3] * h;
  c[0] = 0.25 * (ax * ax + bx * bx) + 1e-4;
  c[1] = 0.25 * (ax * ay + bx * by);
  c[2] = 0.25 * (ay * ay + by * by) + 1e-4;
}

// N(x; 0, C) for a 2D covariance C = (c0, c1; c1, c2).
double Gauss2(double x, double y, double c0, double c1, double c2) {
  const double det = c0 * c2 - c1 * c1;
  const double q = (c2 * x * x - 2 * c1 * x * y + c0 * y * y) / det;
  return std::exp(-0.5 * q) / (2 * kPi * std::sqrt(det));
}

// A flat map: the P-NDF is exactly G_r centred on (0, 0), whatever the footprint.
TEST(NormalMapPndf, FlatMapIsTheIntrinsicGaussian) {
  const auto table = Table(16, 16, [](double, double) { return std::pair{0.0, 0.0}; });
  const double sigma_r = 0.02;
  for (const auto &fp : {std::array<double, 4>{0.0, 0.0, 0.0, 0.0},
                         {0.1, 0.02, -0.03, 0.2},
                         {0.01, 0.0, 0.0, 0.01}}) {
    for (auto [s, t] : {std::pair{0.0, 0.0}, {0.01, -0.02}, {0.05, 0.03}}) {
      const double expect = Gauss2(s, t, sigma_r * sigma_r, 0, sigma_r * sigma_r);
      // Only the Gauss-Legendre pieces of Eq. 11 approximate (the flat map's Gaussian is
      // integrated exactly by erf where erf saturates); 1e-6 relative in double.
      EXPECT_NEAR(Pndf64(table, 0.37, 0.81, fp.data(), s, t, sigma_r, 10.0), expect,
                  1e-6 * Gauss2(0, 0, sigma_r * sigma_r, 0, sigma_r * sigma_r))
          << s << " " << t;
      EXPECT_NEAR(Pndf32(table, 0.37f, 0.81f, fp.data(), float(s), float(t), float(sigma_r), 10.0f),
                  expect, 1e-4 * Gauss2(0, 0, sigma_r * sigma_r, 0, sigma_r * sigma_r));
    }
  }
}

TEST(NormalMapPndf, ConstantTiltedMapIsTheGaussianCentredOnTheTilt) {
  const double s0 = 0.3, t0 = -0.2, sigma_r = 0.01;
  const auto table = Table(8, 4, [&](double, double) { return std::pair{s0, t0}; });
  const double fp[4] = {0.05, 0.0, 0.0, 0.05};
  const double peak = 1.0 / (2 * kPi * sigma_r * sigma_r);
  for (auto [ds, dt] : {std::pair{0.0, 0.0}, {0.01, 0.0}, {-0.015, 0.02}}) {
    const double expect = Gauss2(ds, dt, sigma_r * sigma_r, 0, sigma_r * sigma_r);
    EXPECT_NEAR(Pndf64(table, 0.9, 0.1, fp, s0 + ds, t0 + dt, sigma_r, 10.0), expect, 1e-6 * peak);
    EXPECT_NEAR(
        Pndf32(table, 0.9f, 0.1f, fp, float(s0 + ds), float(t0 + dt), float(sigma_r), 10.0f),
        expect, 1e-4 * peak);
  }
}

// A linear normal field n(x) = M (x - x0) + n0 over a footprint far from the map's periodic seam:
// n(X) for X ~ N(c, Sigma) is Gaussian, so D = N(s; M (c - x0) + n0, M Sigma M^T + sigma_r^2 I)
// in closed form. This exercises the full triangle integral (Eq. 8-11) with correlated,
// anisotropic, rank-deficient Gaussians, over many triangles.
TEST(NormalMapPndf, LinearNormalFieldGivesTheClosedFormGaussian) {
  const uint32_t W = 256, H = 256;
  struct Case {
    double m[4], sigma_r, fp[4];
  };
  for (const Case &c : {Case{{0.004, 0.001, -0.002, 0.003}, 0.01, {0.012, 0.004, -0.002, 0.02}},
                        Case{{0.01, 0.0, 0.0, 0.0}, 0.002, {0.01, 0.0, 0.0, 0.01}},  // rank 1
                        Case{{0.02, 0.01, 0.01, 0.005}, 1e-3, {0.004, 0.0, 0.0, 0.03}}}) {
    const double x0 = 128, y0 = 128;
    const auto table = Table(W, H, [&](double i, double j) {
      return std::pair{c.m[0] * (i - x0) + c.m[1] * (j - y0),
                       c.m[2] * (i - x0) + c.m[3] * (j - y0)};
    });
    double cov[3];
    FootprintCovariance(W, H, c.fp, cov);
    // Footprint centre (vertex coordinates) = u W - 1/2.
    const double u = 0.52, v = 0.47, cx = u * W - 0.5 - x0, cy = v * H - 0.5 - y0;
    const double mu_s = c.m[0] * cx + c.m[1] * cy, mu_t = c.m[2] * cx + c.m[3] * cy;
    // M Sigma M^T + sigma_r^2 I
    const double a = c.m[0], b = c.m[1], d = c.m[2], e = c.m[3];
    const double r2 = c.sigma_r * c.sigma_r;
    const double k0 = a * a * cov[0] + 2 * a * b * cov[1] + b * b * cov[2] + r2;
    const double k1 = a * d * cov[0] + (a * e + b * d) * cov[1] + b * e * cov[2];
    const double k2 = d * d * cov[0] + 2 * d * e * cov[1] + e * e * cov[2] + r2;
    const double peak = Gauss2(0, 0, k0, k1, k2);
    for (double ks : {-1.5, 0.0, 0.7, 2.0})
      for (double kt : {-1.0, 0.0, 1.3}) {
        const double s = mu_s + ks * std::sqrt(k0), t = mu_t + kt * std::sqrt(k2);
        const double expect = Gauss2(s - mu_s, t - mu_t, k0, k1, k2);
        EXPECT_NEAR(Pndf64(table, u, v, c.fp, s, t, c.sigma_r, 10.0), expect, 1e-5 * peak)
            << "sigma_r " << c.sigma_r << " at (" << ks << ", " << kt << ")";
        EXPECT_NEAR(
            Pndf32(table, float(u), float(v), c.fp, float(s), float(t), float(c.sigma_r), 10.0f),
            expect, 2e-3 * peak)
            << "fp32, sigma_r " << c.sigma_r;
      }
  }
}

// A bumpy (sum of sines) map; vertex (s, t) in the unit disk.
std::pair<double, double> Bumpy(double i, double j) {
  const double s =
      0.15 * std::sin(2 * kPi * (i / 16.0 + 0.2)) + 0.1 * std::sin(2 * kPi * (j / 8.0 + i / 32.0));
  const double t =
      0.12 * std::cos(2 * kPi * (j / 16.0)) + 0.08 * std::sin(2 * kPi * (i / 8.0 - j / 32.0));
  return {s, t};
}

// The paper's check (Sec. 5, Fig. 9): sample G_p, look up the linearly interpolated normal,
// perturb it by G_r, histogram; compare with D at the bin centres.
TEST(NormalMapPndf, MatchesBinningOfFootprintSamples) {
  const uint32_t W = 32, H = 32;
  const auto table = Table(W, H, Bumpy);
  const float *vtx = table.data() + GLINT_NM_HEADER_FLOATS;
  auto vertex = [&](int64_t i, int64_t j, int c) {
    i = ((i % W) + W) % W;
    j = ((j % H) + H) % H;
    return double(vtx[(size_t(j) * W + size_t(i)) * 2 + size_t(c)]);
  };
  const double sigma_r = 0.03;
  for (const auto &fp : {std::array<double, 4>{0.08, 0.03, -0.01, 0.06}, {0.01, 0.0, 0.0, 0.01}}) {
    double cov[3];
    FootprintCovariance(W, H, fp.data(), cov);
    const double u = 0.3, v = 0.6, cx = u * W - 0.5, cy = v * H - 0.5;
    const double l00 = std::sqrt(cov[0]), l10 = cov[1] / l00,
                 l11 = std::sqrt(cov[2] - l10 * l10);  // Cholesky
    // Bins of h over [-0.4, 0.4]^2.
    const double h = 0.01, lo = -0.4;
    const int nb = 80;
    std::vector<double> counts(size_t(nb) * nb, 0.0);
    std::mt19937_64 rng(12345);
    std::normal_distribution<double> normal;
    const int64_t N = 2000000;
    for (int64_t k = 0; k < N; ++k) {
      const double z0 = normal(rng), z1 = normal(rng);
      const double x = cx + l00 * z0, y = cy + l10 * z0 + l11 * z1;
      const double fx0 = std::floor(x), fy0 = std::floor(y);
      const double fx = x - fx0, fy = y - fy0;
      const int64_t i = int64_t(fx0), j = int64_t(fy0);
      double n[2];
      for (int c = 0; c < 2; ++c) {
        if (fx + fy <= 1.0) {  // lower triangle (v00, v10, v01)
          n[c] = vertex(i, j, c) + fx * (vertex(i + 1, j, c) - vertex(i, j, c)) +
                 fy * (vertex(i, j + 1, c) - vertex(i, j, c));
        } else {  // upper (v11, v01, v10)
          n[c] = vertex(i + 1, j + 1, c) +
                 (1 - fx) * (vertex(i, j + 1, c) - vertex(i + 1, j + 1, c)) +
                 (1 - fy) * (vertex(i + 1, j, c) - vertex(i + 1, j + 1, c));
        }
      }
      const double s = n[0] + sigma_r * normal(rng), t = n[1] + sigma_r * normal(rng);
      const int bs = int(std::floor((s - lo) / h)), bt = int(std::floor((t - lo) / h));
      if (bs >= 0 && bs < nb && bt >= 0 && bt < nb) counts[size_t(bt) * nb + bs] += 1.0;
    }
    // Per bin: the histogram estimates the bin average of D with standard error
    // sqrt(D / (N h^2)); the bin average differs from the centre value by at most
    // h^2 / 24 (|D_ss| + |D_tt|) <= h^2 / 24 * 2 max|G_r''| = h^2 / (24 pi sigma_r^4)
    // (D is G_r convolved with a probability distribution). Allow 5 standard errors.
    const double disc = h * h / (24 * kPi * std::pow(sigma_r, 4));
    // Every other bin in s and t (a quarter of them) keeps the test fast.
    double max_excess = -1e300, l1 = 0.0, mass = 0.0;
    for (int bt = 0; bt < nb; bt += 2)
      for (int bs = 0; bs < nb; bs += 2) {
        const double s = lo + (bs + 0.5) * h, t = lo + (bt + 0.5) * h;
        const double d = Pndf64(table, u, v, fp.data(), s, t, sigma_r, 5.0);
        const double hist = counts[size_t(bt) * nb + bs] / (double(N) * h * h);
        const double tol = 5.0 * std::sqrt(std::max(d, 1.0) / (double(N) * h * h)) + disc;
        max_excess = std::max(max_excess, std::fabs(hist - d) - tol);
        l1 += 4 * std::fabs(hist - d) * h * h;
        mass += 4 * d * h * h;
      }
    std::printf(
        "footprint (%g %g %g %g): L1(hist - D) = %.4f (sampled bins x 4) over mass %.4f, "
        "disc bound %.3f\n",
        fp[0], fp[1], fp[2], fp[3], l1, mass, disc);
    EXPECT_LE(max_excess, 0.0);
  }
}

// Sec. 3: D is a probability density on the extended disk; all of G_r's mass lies inside the
// disk for this map, so D integrates to 1. The midpoint sum of a function band-limited at
// ~1 / sigma_r with h = sigma_r / 2 is exact to ~exp(-2 pi^2 (sigma_r / h)^2) = e^-79; the
// truncation at 8 sigma_r beyond the map's normals leaves ~1e-15; the rest is the triangle
// integrals' error (< 1e-5 relative in LinearNormalFieldGivesTheClosedFormGaussian).
TEST(NormalMapPndf, IntegratesToOneOverTheDisk) {
  const uint32_t W = 32, H = 32;
  const auto table = Table(W, H, Bumpy);
  const double sigma_r = 0.05, h = sigma_r / 2;
  const double fp[4] = {0.02, 0.01, 0.0, 0.03};
  double sum = 0.0;
  const double lim = 0.25 + 8 * sigma_r;  // |s|, |t| of Bumpy <= 0.25
  for (double s = -lim + h / 2; s < lim; s += h)
    for (double t = -lim + h / 2; t < lim; t += h)
      sum += Pndf64(table, 0.7, 0.2, fp, s, t, sigma_r, 10.0) * h * h;
  EXPECT_NEAR(sum, 1.0, 2e-5);
}

// Sec. 6 pruning at cut-off c drops (a) footprint mass outside the c-sigma box, at most
// 4 Phi(-c), each weighted by at most max G_r = 1 / (2 pi sigma_r^2), and (b) points whose
// normal is beyond c sigma_r in s or t, where G_r <= exp(-c^2 / 2) / (2 pi sigma_r^2). So
// |D_c - D| <= (4 Phi(-c) + exp(-c^2 / 2)) / (2 pi sigma_r^2); D at c = 10 stands for D.
TEST(NormalMapPndf, PruningChangesDLessThanTheCutoffPredicts) {
  const uint32_t W = 64, H = 64;
  const auto table = Table(W, H, Bumpy);
  const double sigma_r = 0.02, fp[4] = {0.05, 0.01, -0.01, 0.04};
  std::vector<std::array<double, 3>> reference;  // s, t, D at cutoff 10
  uint32_t full_triangles = 0;
  for (double s = -0.3; s <= 0.3; s += 0.031)
    for (double t = -0.25; t <= 0.25; t += 0.043) {
      k64::NmStats b{};
      reference.push_back({s, t, Pndf64(table, 0.4, 0.45, fp, s, t, sigma_r, 10.0, &b)});
      full_triangles += b.triangles;
    }
  for (double c : {3.0, 4.0, 5.0}) {
    const double bound = (4 * 0.5 * std::erfc(c / std::sqrt(2.0)) + std::exp(-0.5 * c * c)) /
                         (2 * kPi * sigma_r * sigma_r);
    double worst = 0.0;
    uint32_t pruned_triangles = 0;
    for (const auto &[s, t, d] : reference) {
      k64::NmStats a{};
      worst = std::max(worst, std::fabs(Pndf64(table, 0.4, 0.45, fp, s, t, sigma_r, c, &a) - d));
      pruned_triangles += a.triangles;
    }
    std::printf("cutoff %g: max |D_c - D| = %.3g (bound %.3g), triangles %u vs %u at 10 sigma\n", c,
                worst, bound, pruned_triangles, full_triangles);
    EXPECT_LE(worst, bound);
    EXPECT_LT(pruned_triangles, full_triangles);
  }
}

// The traversal's stack (normal_map_params.h GLINT_NM_STACK) holds at most 3 (levels - 2) + 4
// entries; a long map (16384 x 4 cells: 15 levels) with nothing pruned (sigma_r 0.5, cutoff 10,
// a footprint over the whole map) visits every node and stays within it.
TEST(NormalMapPndf, TraversalStackStaysWithinItsBoundOnADeepMap) {
  const uint32_t W = 16384, H = 4;
  const auto table = Table(W, H, [](double i, double j) {
    return std::pair{0.3 * std::sin(i * 0.01), 0.1 * std::cos(j)};
  });
  const uint32_t levels = uint32_t(table[2]);
  ASSERT_EQ(levels, 15u);
  const double fp[4] = {0.2, 0.0, 0.0, 0.2};
  k64::NmStats stats{};
  const double d = Pndf64(table, 0.5, 0.5, fp, 0.1, 0.0, 0.5, 10.0, &stats);
  EXPECT_TRUE(std::isfinite(d) && d > 0.0) << d;
  EXPECT_EQ(stats.overflow, 0u);
  EXPECT_LE(stats.max_stack, 3 * (levels - 2) + 4);
  EXPECT_GE(stats.max_stack, levels - 2);  // the traversal did go down to level 1
  EXPECT_LE(3 * (levels - 2) + 4, uint32_t(GLINT_NM_STACK));
  EXPECT_GE(stats.triangles, 2 * W * H);  // nothing pruned: every triangle of a period
}

// fp32 (the device default) against fp64 on the bumpy map.
TEST(NormalMapPndf, Fp32AgreesWithFp64) {
  const auto table = Table(32, 32, Bumpy);
  const double fp[4] = {0.05, 0.0, 0.01, 0.04}, sigma_r = 0.01;
  const double peak = 1.0 / (2 * kPi * sigma_r * sigma_r);
  for (double s = -0.3; s <= 0.3; s += 0.05)
    for (double t = -0.2; t <= 0.2; t += 0.05) {
      const double d64 = Pndf64(table, 0.3, 0.3, fp, s, t, sigma_r, 5.0);
      const double d32 = Pndf32(table, 0.3f, 0.3f, fp, float(s), float(t), float(sigma_r), 5.0f);
      EXPECT_NEAR(d32, d64, 1e-4 * peak + 1e-3 * d64) << s << " " << t;
    }
}

}  // namespace
}  // namespace glint

namespace glint {
namespace {

// The large-footprint limit (README "Periodic tiling, footprint limits"): a footprint at least
// one period wide along both axes sees the map's global normal distribution convolved with G_r,
//   D(s) = 1 / (W H) int_period G_r(n(x) - s) dx,
// (the wrapped Gaussian is uniform to 5.4e-9; the kernel's near-uniform weight varies by at most
// 2.5e-5). The reference sums G_r(n(x) - s) over M x M midpoints of every cell, n(x) interpolated
// on the cell's two triangles (written out here), at M = 24 and 12; the tolerance is 2x their
// difference (the midpoint rule's error estimate) plus 3e-5 of the value.
TEST(NormalMapPndf, LargeFootprintApproachesTheGlobalNdfConvolvedWithGr) {
  const uint32_t W = 8, H = 6;
  const auto st = [](double i, double j) {
    return std::pair{0.2 * std::sin(2 * kPi * (i + 0.3 * j) / 8),
                     0.15 * std::cos(2 * kPi * (2.0 * j + 0.5 * i) / 6)};
  };
  const auto table = Table(W, H, st);
  const double sigma_r = 0.05;
  const auto global = [&](double s, double t, int m) {
    double sum = 0;
    for (uint32_t j = 0; j < H; ++j)
      for (uint32_t i = 0; i < W; ++i) {
        const auto [s00, t00] = st(i, j);
        const auto [s10, t10] = st((i + 1) % W, j);
        const auto [s01, t01] = st(i, (j + 1) % H);
        const auto [s11, t11] = st((i + 1) % W, (j + 1) % H);
        for (int a = 0; a < m; ++a)
          for (int b = 0; b < m; ++b) {
            const double fx = (a + 0.5) / m, fy = (b + 0.5) / m;
            double ns, nt;
            if (fx + fy <= 1) {
              ns = s00 + fx * (s10 - s00) + fy * (s01 - s00);
              nt = t00 + fx * (t10 - t00) + fy * (t01 - t00);
            } else {
              ns = s11 + (1 - fx) * (s01 - s11) + (1 - fy) * (s10 - s11);
              nt = t11 + (1 - fx) * (t01 - t11) + (1 - fy) * (t10 - t11);
            }
            // The table stores float (s, t): round as it does.
            sum += Gauss2(double(float(ns)) - s, double(float(nt)) - t, sigma_r * sigma_r, 0,
                          sigma_r * sigma_r);
          }
      }
    return sum / (double(m) * m * W * H);
  };
  // sigma = 0.5 px x J in uv periods: 1, 3 and 1000 periods, a NaN footprint (the largest).
  const double nan = std::nan("");
  for (const auto &fp : {std::array<double, 4>{2.0, 0.0, 0.0, 2.0},
                         {6.0, 1.0, -1.0, 6.0},
                         {2000.0, 0.0, 0.0, 2000.0},
                         {nan, 0.0, 0.0, 1.0}}) {
    for (auto [s, t] : {std::pair{0.0, 0.0}, {0.1, -0.05}, {-0.18, 0.12}, {0.3, 0.3}}) {
      const double fine = global(s, t, 24), coarse = global(s, t, 12);
      const double tol = 2 * std::fabs(fine - coarse) + 3e-5 * fine + 1e-12;
      for (double u : {0.1, 0.77})
        EXPECT_NEAR(Pndf64(table, u, 0.4, fp.data(), s, t, sigma_r, 5.0), fine, tol)
            << "footprint " << fp[0] << " at (" << s << ", " << t << ")";
    }
  }
  // Below one period the footprint is a Gaussian on the map (clamped to GLINT_NM_MAX_PERIODS
  // periods inside its cut-off box): at 1/4 period it still depends on where it sits.
  const double quarter[4] = {0.5, 0.0, 0.0, 0.5};
  EXPECT_GT(std::fabs(Pndf64(table, 0.1, 0.4, quarter, 0.1, -0.05, sigma_r, 5.0) -
                      Pndf64(table, 0.6, 0.9, quarter, 0.1, -0.05, sigma_r, 5.0)),
            0.05 * global(0.1, -0.05, 24));
}

}  // namespace
}  // namespace glint
