// The Kemppinen model's polygon lights (models/kemppinen/kemppinen_polygons.h, beyond K25) and
// its per-glint colours (K25 3.3.6) against independent references:
//   - Owen's T against Simpson quadrature of its defining integral,
//   - a facet lobe's mass over a polygon in U against Monte Carlo with normal samples,
//   - the clipped image's area against the shoelace of a hand-clipped square,
//   - the glinty radiance of a quad light against Monte Carlo over the light of the model's own
//     per-direction BRDF (every direction sees its own facets): small, large and grazing lights,
//   - colours: averaged over uv the colour is the mean colour times the smooth response, and the
//     facets' colour frequencies are 1/n (chi-square).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
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
using glint::test::Normalize;
using glint::test::Stats;
using glint::test::Summarise;
using glint::test::V3;
using Poly2 = std::vector<std::array<double, 2>>;

// Owen's T (kemppinen_image.h: 5-point Gauss-Legendre, a > 1 by Owen's identity) against
// composite Simpson on its defining integral in the angle (x = tan t), 20000 intervals. The
// bound 1e-6 absolute: each edge of a polygon adds two T values to a facet's mass, which enters
// S next to erfc terms good to 1.5e-7 (A&S 7.1.26); 1e-6 keeps a 16-edge mass within 3.2e-5.
TEST(PolygonLobeMass, OwenTAgainstSimpsonQuadrature) {
  double worst = 0;
  for (double h : {0.0, 0.01, 0.3, 1.0, 2.0, 3.5, 5.0, 8.0})
    for (double a : {0.001, 0.2, 0.7, 1.0, 1.5, 4.0, 30.0, 1e4}) {
      // x = tan(t): T = 1/(2 pi) int_0^atan(a) exp(-h^2 / (2 cos^2 t)) dt, smooth on [0, pi/2).
      const int n = 20000;
      const double tmax = std::atan(a);
      auto f = [h](double t) { return std::exp(-0.5 * h * h / (std::cos(t) * std::cos(t))); };
      double sum = f(0) + f(tmax);
      for (int k = 1; k < n; ++k) sum += (k % 2 ? 4 : 2) * f(tmax * k / n);
      double ref = sum * tmax / (3.0 * n) / (2 * M_PI);
      double got = k64::OwenT(h, a);
      worst = std::max(worst, std::fabs(got - ref));
      EXPECT_NEAR(got, ref, 1e-6) << "h " << h << " a " << a;
    }
  std::printf("Owen's T: max |error| %.2e against Simpson\n", worst);
}

// A facet lobe's mass over a polygon in U against Monte Carlo: 200000 samples of the lobe
// N(g, diag(sx^2, sy^2)) counted inside the polygon (a convex point-in-polygon test). Tolerance
// 4.5 standard errors of the binomial count plus the Owen's T bound times two per edge.
TEST(PolygonLobeMass, AgainstMonteCarloOfTheLobe) {
  const std::vector<Poly2> polys = {
      {{0.4, 0.4}, {0.6, 0.4}, {0.6, 0.6}, {0.4, 0.6}},                // square, ccw
      {{0.5, 0.3}, {0.3, 0.5}, {0.6, 0.62}},                           // triangle, cw
      {{0.45, 0.45}, {0.452, 0.45}, {0.452, 0.4505}, {0.45, 0.4505}},  // tiny
      {{0.2, 0.5}, {0.35, 0.3}, {0.6, 0.28}, {0.75, 0.45}, {0.7, 0.7}, {0.4, 0.72}}};  // hexagon
  std::mt19937_64 rng(9);
  std::normal_distribution<double> nd;
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (size_t p = 0; p < polys.size(); ++p) {
    const Poly2 &P = polys[p];
    // The signed area's sign, to make the inside test orientation-free.
    double area2 = 0;
    for (size_t k = 0; k < P.size(); ++k) {
      const auto &a = P[k], &b = P[(k + 1) % P.size()];
      area2 += a[0] * b[1] - b[0] * a[1];
    }
    auto inside = [&](double x, double y) {
      for (size_t k = 0; k < P.size(); ++k) {
        const auto &a = P[k], &b = P[(k + 1) % P.size()];
        double c = (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
        if (c * area2 < 0) return false;
      }
      return true;
    };
    for (int c = 0; c < 8; ++c) {
      double sx = std::exp(std::log(1e-3) + uni(rng) * std::log(100.0));
      double sy = sx * (0.5 + uni(rng));
      double gx = 0.2 + 0.6 * uni(rng), gy = 0.2 + 0.6 * uni(rng);
      if (c == 0) gx = P[0][0], gy = P[0][1];  // at a vertex
      const int n = 200000;
      int hit = 0;
      for (int k = 0; k < n; ++k) hit += inside(gx + sx * nd(rng), gy + sy * nd(rng));
      double ref = double(hit) / n;
      double se = std::sqrt(std::max(ref * (1 - ref), 1.0 / n) / n);
      double got = k64::ImageMass(P, gx, gy, sx, sy);
      EXPECT_NEAR(got, ref, 4.5 * se + 2.0 * double(P.size()) * 1e-6)
          << "polygon " << p << " case " << c << " sigma " << sx << "," << sy;
    }
  }
}

// The explicit block's expected lobe mass over R, E = int_R P(x + lobe in B) dx (Green's
// theorem with 8-point Gauss-Legendre per edge), against Monte Carlo: x uniform in R (rejection
// from its bounding box), one lobe sample per x, counted inside the block B, times R's area.
// Tolerance 4.5 standard errors (binomial) of the estimate.
TEST(PolygonLobeMass, BlockMassAgainstMonteCarlo) {
  const Poly2 hex = {{0.2, 0.5}, {0.35, 0.3}, {0.6, 0.28}, {0.75, 0.45}, {0.7, 0.7}, {0.4, 0.72}};
  double area2 = 0;
  for (size_t k = 0; k < hex.size(); ++k)
    area2 += hex[k][0] * hex[(k + 1) % hex.size()][1] - hex[(k + 1) % hex.size()][0] * hex[k][1];
  const double area = 0.5 * std::fabs(area2);
  auto inside = [&](double x, double y) {
    for (size_t k = 0; k < hex.size(); ++k) {
      const auto &a = hex[k], &b = hex[(k + 1) % hex.size()];
      if (((b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])) * area2 < 0) return false;
    }
    return true;
  };
  struct Block {
    double x0, x1, y0, y1, s;
  };
  const std::vector<Block> blocks = {{0.25, 0.5, 0.25, 0.5, 0.03},    // crossing R's edge
                                     {0.4, 0.55, 0.4, 0.55, 0.05},    // inside R, wide lobes
                                     {0.0, 1.0, 0.0, 1.0, 0.02},      // R inside the block
                                     {0.76, 0.9, 0.3, 0.6, 0.02},     // beside R, lobes reach
                                     {0.4, 0.55, 0.4, 0.55, 0.005}};  // deep inside R: area
  std::mt19937_64 rng(12);
  std::normal_distribution<double> nd;
  std::uniform_real_distribution<double> ux(0.2, 0.75), uy(0.28, 0.72);
  for (const Block &b : blocks) {
    const int n = 200000;
    int hit = 0, drawn = 0;
    while (drawn < n) {
      double x = ux(rng), y = uy(rng);
      if (!inside(x, y)) continue;
      ++drawn;
      double gx = x + b.s * nd(rng), gy = y + 0.7 * b.s * nd(rng);
      hit += gx >= b.x0 && gx <= b.x1 && gy >= b.y0 && gy <= b.y1;
    }
    double p = double(hit) / n, se = std::sqrt(std::max(p * (1 - p), 1.0 / n) / n);
    double got = k64::BlockMass(hex, b.x0, b.x1, b.y0, b.y1, b.s, 0.7 * b.s);
    std::printf("block mass %.5f, Monte Carlo %.5f +- %.5f\n", got, p * area, se * area);
    EXPECT_NEAR(got, p * area, 4.5 * se * area) << b.x0 << " " << b.y0;
  }
}

// Standard normal CDF and its antiderivatives from libm, for the closed-form references below.
double PhiRef(double z) {
  return 0.5 * std::erfc(-z / std::sqrt(2.0));
}
double PsiRef(double z) {  // int Phi = z Phi + phi
  return z * PhiRef(z) + std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI);
}
// Mass of N(g, diag(sx^2, sy^2)) over the axis-aligned rectangle: a product of interval masses.
double RectMassRef(double x0, double x1, double y0, double y1, double gx, double gy, double sx,
                   double sy) {
  return (PhiRef((x1 - gx) / sx) - PhiRef((x0 - gx) / sx)) *
         (PhiRef((y1 - gy) / sy) - PhiRef((y0 - gy) / sy));
}

// A lobe's mass over polygons with closed forms, at every kind of position (deep inside, beyond
// an edge, near one edge, near a corner, on an edge, at a vertex; kemppinen_image_lines.h takes
// a different path for each):
//   - axis-aligned rectangles with anisotropic lobes: the product of two interval masses;
//   - rotated rectangles with isotropic lobes (rotation invariant): the same in the rotated frame;
//   - a non-convex L (two rectangles): the sum of their masses. Its points beyond the line of a
//     notch edge are inside R, which a "beyond one edge's line, so 0" shortcut gets wrong.
// Tolerance: each of the n edges adds at most two Owen's T values (within the 1e-6 asserted by
// OwenTAgainstSimpsonQuadrature) or two normal tails (A&S 7.1.26: 7.5e-8), plus n Q(5.7) = n 6e-9
// of dropped tails: 2 n (1e-6 + 7.5e-8) + n 6e-9.
TEST(PolygonLobeMass, AgainstClosedFormsConvexAndNot) {
  struct Rect {
    double x0, x1, y0, y1;
  };
  auto check = [](const Poly2 &P, const std::vector<Rect> &parts, double sx, double sy,
                  double angle, double gx, double gy, const char *what) {
    // parts are in the frame rotated by -angle about (0.5, 0.5) (isotropic lobes when angle != 0).
    double c = std::cos(angle), sn = std::sin(angle);
    double lx = 0.5 + c * (gx - 0.5) + sn * (gy - 0.5), ly = 0.5 - sn * (gx - 0.5) + c * (gy - 0.5);
    double ref = 0;
    for (const Rect &r : parts) ref += RectMassRef(r.x0, r.x1, r.y0, r.y1, lx, ly, sx, sy);
    double tol = 2.0 * double(P.size()) * (1e-6 + 7.5e-8) + double(P.size()) * 6e-9;
    double got = k64::ImageMass(P, gx, gy, sx, sy);
    EXPECT_NEAR(got, ref, tol) << what << " g " << gx << "," << gy << " sigma " << sx << "," << sy;
    return std::fabs(got - ref);
  };
  auto rotate = [](const std::vector<Rect> &parts, const Poly2 &local, double angle) {
    (void)parts;
    Poly2 out;
    double c = std::cos(angle), sn = std::sin(angle);
    for (const auto &v : local)
      out.push_back(
          {0.5 + c * (v[0] - 0.5) - sn * (v[1] - 0.5), 0.5 + sn * (v[0] - 0.5) + c * (v[1] - 0.5)});
    return out;
  };
  double worst = 0;
  int count = 0;
  // Positions: a grid through the polygon and 3 sigma beyond it, plus the vertices and edge
  // midpoints themselves (on the boundary: the interior angle / 2 pi).
  auto positions = [](const Poly2 &P, double margin) {
    std::vector<std::array<double, 2>> g;
    double x0 = 1, x1 = 0, y0 = 1, y1 = 0;
    for (const auto &v : P) {
      x0 = std::min(x0, v[0]), x1 = std::max(x1, v[0]);
      y0 = std::min(y0, v[1]), y1 = std::max(y1, v[1]);
      g.push_back(v);
    }
    for (size_t k = 0; k < P.size(); ++k)
      g.push_back(
          {0.5 * (P[k][0] + P[(k + 1) % P.size()][0]), 0.5 * (P[k][1] + P[(k + 1) % P.size()][1])});
    for (int i = 0; i <= 40; ++i)
      for (int j = 0; j <= 40; ++j)
        g.push_back({x0 - margin + (x1 - x0 + 2 * margin) * i / 40.0,
                     y0 - margin + (y1 - y0 + 2 * margin) * j / 40.0});
    return g;
  };
  const std::vector<Rect> square = {{0.4, 0.6, 0.35, 0.6}};
  const Poly2 square_p = {{0.4, 0.35}, {0.6, 0.35}, {0.6, 0.6}, {0.4, 0.6}};
  // L: [0.2, 0.6] x [0.2, 0.4] and [0.2, 0.4] x [0.4, 0.7]; reflex vertex (0.4, 0.4).
  const std::vector<Rect> ell = {{0.2, 0.6, 0.2, 0.4}, {0.2, 0.4, 0.4, 0.7}};
  const Poly2 ell_p = {{0.2, 0.2}, {0.6, 0.2}, {0.6, 0.4}, {0.4, 0.4}, {0.4, 0.7}, {0.2, 0.7}};
  EXPECT_TRUE(k64::IsConvex(square_p));
  EXPECT_FALSE(k64::IsConvex(ell_p));
  for (double s : {0.003, 0.02, 0.08}) {
    for (const auto &g : positions(square_p, 3 * s)) {
      worst = std::max(worst, check(square_p, square, s, 0.6 * s, 0.0, g[0], g[1], "square"));
      ++count;
    }
    for (const auto &g : positions(ell_p, 3 * s)) {
      worst = std::max(worst, check(ell_p, ell, 0.7 * s, s, 0.0, g[0], g[1], "L"));
      ++count;
    }
    for (double angle : {0.3, 1.1}) {
      const Poly2 rp = rotate(square, square_p, angle), rl = rotate(ell, ell_p, angle);
      for (const auto &g : positions(rp, 3 * s)) {
        worst = std::max(worst, check(rp, square, s, s, angle, g[0], g[1], "rotated square"));
        ++count;
      }
      for (const auto &g : positions(rl, 3 * s)) {
        worst = std::max(worst, check(rl, ell, s, s, angle, g[0], g[1], "rotated L"));
        ++count;
      }
    }
  }
  std::printf("lobe mass over rectangles and Ls: max |error| %.2e over %d positions\n", worst,
              count);
}

// The closed-form pieces of the block mass (kemppinen_image.h) against composite Simpson (20000
// intervals) of their integrands with libm's erfc:
//   int_ya^yb (q0 + r (y - ym)) Phi((c - y) / s) dy  and  int_za^zb psi(z) dz,
// over ranges crossing the transition and reaching 30 standard deviations into both tails.
// Tolerance from A&S 7.1.26 (|error of Phi| <= 7.5e-8, phi exact): psi is off by at most
// |z| 7.5e-8, chi and ups by (z^2 + 1) / 2 7.5e-8, at each end.
TEST(PolygonLobeMass, ClosedFormPiecesAgainstSimpson) {
  const double e = 7.5e-8;
  auto simpson = [](auto f, double a, double b) {
    const int n = 20000;
    double h = (b - a) / n, sum = f(a) + f(b);
    for (int k = 1; k < n; ++k) sum += (k % 2 ? 4 : 2) * f(a + k * h);
    return sum * h / 3;
  };
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (int c = 0; c < 40; ++c) {
    double s = 0.002 + 0.03 * uni(rng), cc = 0.2 + 0.6 * uni(rng);
    double ya = cc + s * (-30 + 60 * uni(rng)), yb = cc + s * (-30 + 60 * uni(rng));
    double ym = 0.5 * (ya + yb), q0 = -0.3 + 0.6 * uni(rng), r = c % 3 == 0 ? 0 : -1 + 2 * uni(rng);
    double ref =
        simpson([&](double y) { return (q0 + r * (y - ym)) * PhiRef((cc - y) / s); }, ya, yb);
    double got = k64::LinPhiInt(q0, r, ym, cc, s, yb) - k64::LinPhiInt(q0, r, ym, cc, s, ya);
    double zmax = std::max(std::fabs(cc - ya), std::fabs(cc - yb)) / s;
    double tol = 2 * (s * (std::fabs(q0) + std::fabs(r) * std::fabs(cc - ym)) * zmax * e +
                      s * s * std::fabs(r) * 0.5 * (zmax * zmax + 1) * e);
    EXPECT_NEAR(got, ref, tol + 1e-12) << "case " << c;
    double za = -30 + 60 * uni(rng), zb = -30 + 60 * uni(rng);
    double uref = simpson(PsiRef, za, zb);
    double utol = 2 * 0.5 * (900 + 1) * e;
    EXPECT_NEAR(k64::Ups(zb) - k64::Ups(za), uref, utol) << "ups case " << c;
  }
}

// The block mass for an axis-aligned rectangle R, whose edges the block mass integrates in
// closed form (vertical edges: Qx constant), against the separable closed form
//   E = [int_Rx qx dx] [int_Ry qy dy],  int (Phi((b - x) / s) - Phi((a - x) / s)) dx by psi,
// for blocks crossing R's sides and corners, inside it, containing it and beside it, lobes from
// 0.1 to 3 times the block. Tolerance: as ClosedFormPiecesAgainstSimpson, psi within
// (|z| + 1) 7.5e-8 at 4 ends of 2 edges, times s and the block width.
TEST(PolygonLobeMass, BlockMassOfARectangleAgainstClosedForm) {
  const double rx0 = 0.3, rx1 = 0.65, ry0 = 0.25, ry1 = 0.55;
  const Poly2 R = {{rx0, ry0}, {rx1, ry0}, {rx1, ry1}, {rx0, ry1}};
  auto interval = [](double r0, double r1, double b0, double b1, double s) {
    // int_r0^r1 Phi((b1 - x) / s) - Phi((b0 - x) / s) dx = -s [psi((b1 - x) / s) - ...]
    auto F = [&](double x) { return -s * (PsiRef((b1 - x) / s) - PsiRef((b0 - x) / s)); };
    return F(r1) - F(r0);
  };
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (int c = 0; c < 60; ++c) {
    double w = 0.03 + 0.3 * uni(rng), h = 0.03 + 0.3 * uni(rng);
    double bx0 = 0.1 + 0.6 * uni(rng), by0 = 0.1 + 0.6 * uni(rng);
    double sx = std::min(w, h) * std::exp(std::log(0.1) + uni(rng) * std::log(30.0)), sy = 0.8 * sx;
    double ref = interval(rx0, rx1, bx0, bx0 + w, sx) * interval(ry0, ry1, by0, by0 + h, sy);
    double got = k64::BlockMass(R, bx0, bx0 + w, by0, by0 + h, sx, sy);
    double zmax = 1.0 / sy;
    double tol = 8 * sx * w * (zmax + 1) * 7.5e-8;
    EXPECT_NEAR(got, ref, tol + 1e-12) << "case " << c << " block " << bx0 << "," << by0 << " " << w
                                       << "x" << h << " sigma " << sx;
  }
}

// The block mass of a rotated square (edges at 30 and 120 degrees, so every edge takes the
// Gauss-Legendre pieces and the slanted closed forms of kemppinen_image_block_mass) with
// isotropic lobes, against E = int_B M(g) dg (the symmetry stated there), M(g) the lobe's mass
// over the square in closed form (a product of interval masses in the square's frame, libm
// erfc), integrated over the axis-aligned block by composite 8-point Gauss-Legendre with panels
// of at most sigma / 2 (M is analytic with derivatives ~ sigma^-k: each panel is exact to
// ~1e-12). Blocks from 0.5 to 8 sigma wide crossing edges and corners, lobes as in the polygon
// pass (the four-quad rig's images are 3-5 lobes wide). Tolerance: what E already carries from
// A&S 7.1.26 (|error of Phi| <= 7.5e-8) along the line integral, whose integrand Qx qy has
// Qx = sx (psi - psi) off by 2 sx (zmax + 1) 7.5e-8 (zmax = (width + 5.7 sigma) / sigma) and qy
// off by 2 7.5e-8 times |Qx| <= width, over at most the perimeter: the pieces' quadrature is
// asked to add no more than that (8 nodes: max error 6.9e-10 here; 5 nodes gave 3.3e-7 and
// fail). Cases 40-59: blocks 12-20 sigma wide (one column and one row transition per corner
// piece).
TEST(PolygonLobeMass, BlockMassOfARotatedSquareAgainstQuadrature) {
  const double c30 = std::cos(M_PI / 6), s30 = std::sin(M_PI / 6), half = 0.05;
  const double cx = 0.5, cy = 0.5;
  Poly2 R;
  for (int k = 0; k < 4; ++k) {
    double u = (k == 1 || k == 2) ? half : -half, v = k >= 2 ? half : -half;
    R.push_back({cx + c30 * u - s30 * v, cy + s30 * u + c30 * v});
  }
  auto M = [&](double gx, double gy, double s) {
    double u = c30 * (gx - cx) + s30 * (gy - cy), v = -s30 * (gx - cx) + c30 * (gy - cy);
    return (PhiRef((half - u) / s) - PhiRef((-half - u) / s)) *
           (PhiRef((half - v) / s) - PhiRef((-half - v) / s));
  };
  const double xg[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                        0.9602898564975363};
  const double wg[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                        0.1012285362903763};
  auto integrate = [&](double x0, double x1, double y0, double y1, double s) {
    int nx = int(std::ceil((x1 - x0) / (0.5 * s))), ny = int(std::ceil((y1 - y0) / (0.5 * s)));
    double hx = (x1 - x0) / nx, hy = (y1 - y0) / ny, sum = 0;
    for (int i = 0; i < nx; ++i)
      for (int a = 0; a < 8; ++a) {
        double xa = a < 4 ? -xg[3 - a] : xg[a - 4], wa = a < 4 ? wg[3 - a] : wg[a - 4];
        double x = x0 + hx * (i + 0.5 * (1 + xa));
        for (int j = 0; j < ny; ++j)
          for (int b = 0; b < 8; ++b) {
            double yb = b < 4 ? -xg[3 - b] : xg[b - 4], wb = b < 4 ? wg[3 - b] : wg[b - 4];
            sum += wa * wb * M(x, y0 + hy * (j + 0.5 * (1 + yb)), s);
          }
      }
    return sum * 0.25 * hx * hy;
  };
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  double worst = 0, worst_rel = 0;
  for (int c = 0; c < 60; ++c) {
    double s = 0.01 + 0.03 * uni(rng);
    double w = s * (0.5 + 7.5 * uni(rng)), h = s * (0.5 + 7.5 * uni(rng));
    if (c >= 40) {
      // Blocks wider than the two transitions of a side (2 x 5.7 sigma): a piece near a
      // corner lies in one column transition and one row transition, and the pieces drop
      // the other two to their asymptotes (kemppinen_image_block_mass).
      s = 0.01 + 0.01 * uni(rng);
      w = s * (12.0 + 8.0 * uni(rng));
      h = s * (12.0 + 8.0 * uni(rng));
    }
    double bx0 = cx - 0.1 + 0.2 * uni(rng) - 0.5 * w, by0 = cy - 0.1 + 0.2 * uni(rng) - 0.5 * h;
    double ref = integrate(bx0, bx0 + w, by0, by0 + h, s);
    double got = k64::BlockMass(R, bx0, bx0 + w, by0, by0 + h, s, s);
    double wm = std::max(w, h), zmax = (wm + 5.7 * s) / s;
    double tol = 8 * half * (2 * s * (zmax + 1) + 2 * wm) * 7.5e-8;
    worst = std::max(worst, std::fabs(got - ref));
    if (ref > 1e-4 * w * h) worst_rel = std::max(worst_rel, std::fabs(got - ref) / ref);
    EXPECT_NEAR(got, ref, tol) << "case " << c << " block " << bx0 << "," << by0 << " " << w << "x"
                               << h << " sigma " << s;
  }
  std::printf("rotated square: block mass max |error| %.3g, max relative %.3g\n", worst, worst_rel);
}

// The pixel-filter cut of the polygon pass (kemppinen_polygons.h): the per-cell lower bound of
// the filter exponent q(d) = qxx dx^2 + qxy dx dy + qyy dy^2 over a spatial cell's facets
// (offsets in [0, 1)^2), the exact minimum over the cell scaled by 1 - 1e-5, against brute
// force: a 201 x 201 grid of the cell (the bound must not exceed its minimum) and, for cells
// not holding d = 0 (a convex function's minimum over a rectangle then lies on its boundary),
// 100001 points along each side, whose minimum is within G h / 2 of the true one (h = 1e-5, G the
// gradient's norm, at most 2 l1 |d|): the bound must be within its 1e-5 scaling plus that slack
// of it. Session 11's looser bound (the smallest eigenvalue times the distance squared) fails
// the second check. Random positive definite filters from isotropic to 1:1000, cells near and
// far.
TEST(PolygonLights, FilterCutCellBoundIsTheCellMinimum) {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  auto q = [](double qxx, double qxy, double qyy, double dx, double dy) {
    return qxx * dx * dx + qxy * dx * dy + qyy * dy * dy;
  };
  int loose = 0, boundary = 0;
  for (int c = 0; c < 300; ++c) {
    double l1 = std::exp(-3 + 6 * uni(rng)), l2 = l1 * std::exp(std::log(1e-3) * uni(rng));
    double th = M_PI * uni(rng), co = std::cos(th), si = std::sin(th);
    // [[qxx, qxy / 2], [qxy / 2, qyy]] = Rot diag(l1, l2) Rot^T
    double qxx = l1 * co * co + l2 * si * si, qyy = l1 * si * si + l2 * co * co;
    double qxy = 2 * (l1 - l2) * co * si;
    double dxc = -3 + 6 * uni(rng), dyc = -3 + 6 * uni(rng);
    double bound = k64::kemppinen_filter_cell_min(qxx, qxy, qyy, dxc, dyc), grid = 1e300;
    for (int i = 0; i <= 200; ++i)
      for (int j = 0; j <= 200; ++j)
        grid = std::min(grid, q(qxx, qxy, qyy, dxc - i / 200.0, dyc - j / 200.0));
    EXPECT_LE(bound, grid * (1 + 1e-12)) << "case " << c;
    if (dxc >= 0 && dxc <= 1 && dyc >= 0 && dyc <= 1) {
      EXPECT_EQ(bound, 0.0) << "case " << c;
      continue;
    }
    ++boundary;
    const int n = 100000;
    double side = 1e300;
    for (int i = 0; i <= n; ++i) {
      double t = double(i) / n;
      side = std::min({side, q(qxx, qxy, qyy, dxc - 1, dyc - t), q(qxx, qxy, qyy, dxc, dyc - t),
                       q(qxx, qxy, qyy, dxc - t, dyc - 1), q(qxx, qxy, qyy, dxc - t, dyc)});
    }
    double dmax = std::hypot(std::fabs(dxc) + 1, std::fabs(dyc) + 1);
    double slack = 2 * l1 * dmax * 0.5 / n;
    EXPECT_LE(bound, side * (1 + 1e-12)) << "case " << c;
    EXPECT_GE(bound, side * (1 - 1e-5) - slack - 1e-12) << "case " << c;
    double dx = std::max({dxc - 1, -dxc, 0.0}), dy = std::max({dyc - 1, -dyc, 0.0});
    if (std::min(l1, l2) * (dx * dx + dy * dy) < side * (1 - 1e-5) - slack) ++loose;
  }
  std::printf("cells not holding 0: %d of 300; the eigenvalue bound is looser in %d\n", boundary,
              loose);
}

// The image clipped to a rectangle: a square [0.4, 0.6]^2 clipped to [0.5, 0.9] x [0.3, 0.55]
// is [0.5, 0.6] x [0.4, 0.55]: area 0.015, centroid (0.55, 0.475) (by hand).
TEST(PolygonLobeMass, ClipToRectangleByHand) {
  const Poly2 sq = {{0.4, 0.4}, {0.6, 0.4}, {0.6, 0.6}, {0.4, 0.6}};
  auto r = k64::ClipRect(sq, 0.5, 0.9, 0.3, 0.55);
  EXPECT_NEAR(r[0], 0.015, 1e-12);
  EXPECT_NEAR(r[1], 0.55, 1e-12);
  EXPECT_NEAR(r[2], 0.475, 1e-12);
  EXPECT_EQ(k64::ClipRect(sq, 0.7, 0.9, 0.3, 0.55)[0], 0.0);  // disjoint
}

// A square light of half-size `half` at distance `dist` in direction `dir` (unit), facing the
// shading point, as four vertices in the local frame.
std::vector<V3> SquareLight(V3 dir, double dist, double half) {
  V3 a = std::fabs(dir.z) < 0.9 ? V3{0, 0, 1} : V3{1, 0, 0};  // not parallel to dir
  V3 t =
      Normalize({a.y * dir.z - a.z * dir.y, a.z * dir.x - a.x * dir.z, a.x * dir.y - a.y * dir.x});
  V3 b = {dir.y * t.z - dir.z * t.y, dir.z * t.x - dir.x * t.z, dir.x * t.y - dir.y * t.x};
  std::vector<V3> q;
  for (auto [su, sv] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}})
    q.push_back({dir.x * dist + half * (su * t.x + sv * b.x),
                 dir.y * dist + half * (su * t.y + sv * b.y),
                 dir.z * dist + half * (su * t.z + sv * b.z)});
  return q;
}

// Polygon lights (kemppinen_polygons.h) against Monte Carlo over the light: per query, n_mc
// directions drawn uniformly by area on the square (pdf d^2 / (A cos_l) in solid angle), each
// evaluated with the model's own per-direction glinty BRDF (a probe: D_star at that direction's
// half-vector, every direction sees its own facets), so the estimate converges to the exact
// glinty reflection of the light. Configurations: a small light (~1 degree), a 10-degree one, a
// large ~50-degree one, and grazing wo at 80 degrees; densities 1e5 and 1e7 (footprint 1e-3).
// Asserted:
//   - unbiased over uv and patterns: the mean difference (model - MC) over the queries is
//     within 4.5 standard errors of that mean;
//   - per query, the RMS difference with the MC noise removed (mean squared difference minus
//     the mean squared MC standard error), relative to the mean: for the small light below
//     0.05 (every approximation of kemppinen_polygons.h becomes exact as the light shrinks to a
//     point, where it is the point-light evaluation; 0.05 is the budget stated in the README),
//     and for the others below that of the previous approximation (the smooth integral times
//     D_star / D at the light's centre half-vector), computed here against the same MC.
// Per neighbourhood (material.kemppinen.neighborhood, session 20): the MC's per-direction BRDF
// is the point pass with the same setting, so per query both see the same dithered level (and
// with ONE_CELL the same spatial cell): the small light's per-query budget holds only if the
// polygon pass picks what the point pass picks. The cheap settings' erfc (A&S 7.1.27, |error|
// <= eps = 5e-4) can bias the reference's S by kCheapErfcBiasBound = 10 eps and the polygon's
// 1 - P_s by 2 eps (two per-axis tails, kemppinen_outside_width), times rho A_l <= the light's
// smooth radiance (rho ~constant over the light's image, the test's own approximation): the
// bias tolerance adds (10 + 2) eps times the mean reference.
// SAMPLE (session 20, issue 9): 4 glint patterns (seeds) x 60 uv, 1024 directions each, pooled.
// At density 1e5 the per-query difference is skewed and heavy-tailed (medium light, ONE_CELL:
// skewness +1.4 / -6.5, kurtosis ~500-850): most queries see no glint and there the polygon
// pass sits below the MC by far more than the MC noise (over 20 patterns: -10% of the queries
// under 0.1 of the smooth radiance, -0.8% of those at 0.1-0.5; cause not isolated, one of the
// README's approximations, e.g. rho at the centroid in the subtracted rho_l P_s A_l), while the
// ~3% that hold a glint brighter than the smooth radiance carry the mean and its spread. The
// mean stays unbiased (E over uv of the explicit part is rho_l P_s A_l), but 60 queries of one
// pattern hold no bright glint in ~0.973^60 = 20% of draws, and then the standard error
// collapses with the mean left at the dim queries' offset. Measured over 800 patterns x 60 uv
// (medium light, 1e5, ONE_CELL, 2048 directions): (polygon - MC) / mean = +0.0013 +- 0.0011
// on session 20's hash and -0.0006 +- 0.0012 with 8ea7062's column key (branch s20-kcell), SE
// over patterns: no bias; yet the 60-query test failed 71 and 59 of those 800 patterns.
// Resampling their queries, the 4.5 SE test fails 8% of 60-query samples, 1.5% of 120, 0.1%
// of 240, none of 2000 of 480. The spread of the per-pattern means over patterns equals the
// within-pattern standard error (ratio 1.01 and 0.97: one pattern's uv draws are as
// independent as patterns), so the 240 queries form one sample and its standard error. 1024
// directions (not 2048) keep the test's time at twice session 20's: the MC noise is in each
// difference, so in the bias's standard error, and is subtracted from the RMS.
struct LightCase {
  const char *name;
  V3 wo;
  double half;
  double density;
};

struct LightCaseResult {
  double bias, se, mean, rms, rms_old, mc_noise, spread;
  double excess, excess_se;  // mean over queries of diff^2 - MC SE^2 (rms^2 mean^2), its SE
};

// One configuration over `n_seeds` glint patterns (seed_lo = first_seed, ...) of `count` uv each.
LightCaseResult RunLightCase(const LightCase &c, int hood, unsigned first_seed, int n_seeds,
                             int count, int n_mc, uint64_t uv_seed) {
  const double fp[4] = {1e-3, 0, 0, 1e-3}, dist = 3.0;
  Glinty g;
  g.density = c.density;
  g.neighborhood = hood;
  const V3 mirror = {-c.wo.x, -c.wo.y, c.wo.z};
  const std::vector<V3> quad = SquareLight(mirror, dist, c.half);
  const V3 e1 = {quad[1].x - quad[0].x, quad[1].y - quad[0].y, quad[1].z - quad[0].z};
  const V3 e2 = {quad[3].x - quad[0].x, quad[3].y - quad[0].y, quad[3].z - quad[0].z};
  const double area = 4 * c.half * c.half;
  const V3 hc = Normalize({mirror.x + c.wo.x, mirror.y + c.wo.y, mirror.z + c.wo.z});
  std::mt19937_64 rng(uv_seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const size_t total = size_t(n_seeds) * size_t(count);
  std::vector<double> diff(total), diff_old(total), ref(total), excess(total);
  double se2 = 0;
  size_t i = 0;
  for (int s = 0; s < n_seeds; ++s) {
    g.seed_lo = first_seed + unsigned(s);
    for (int q = 0; q < count; ++q, ++i) {
      double u = 100 * uni(rng), v = 100 * uni(rng);
      std::vector<double> x(static_cast<size_t>(n_mc));
      double smooth = 0;
      for (int k = 0; k < n_mc; ++k) {
        double a = uni(rng), b = uni(rng);
        V3 p = {quad[0].x + a * e1.x + b * e2.x, quad[0].y + a * e1.y + b * e2.y,
                quad[0].z + a * e1.z + b * e2.z};
        double d2 = p.x * p.x + p.y * p.y + p.z * p.z, d = std::sqrt(d2);
        V3 wi = {p.x / d, p.y / d, p.z / d};
        double jac = area * std::fabs(wi.x * mirror.x + wi.y * mirror.y + wi.z * mirror.z) / d2;
        x[size_t(k)] = k64::Query(g, u, v, fp, c.wo, wi, true)[0] * jac;
        smooth += k64::SmoothProbe(g, c.wo, wi) * jac / n_mc;
      }
      Stats sx = Summarise(x);
      ref[i] = sx.mean;
      se2 += sx.se() * sx.se() / double(total);
      diff[i] = k64::QueryPolygon(g, u, v, fp, c.wo, quad, GLINT_AREA_REFERENCE, 16) - sx.mean;
      diff_old[i] = smooth * k64::GlintFactor(g, u, v, fp, hc) - sx.mean;
      excess[i] = diff[i] * diff[i] - sx.se() * sx.se();
    }
  }
  Stats sd = Summarise(diff), so = Summarise(diff_old), sr = Summarise(ref), se = Summarise(excess);
  auto rms = [&](const Stats &st) {
    double ms = st.var * double(total - 1) / double(total) + st.mean * st.mean;
    return std::sqrt(std::max(0.0, ms - se2)) / sr.mean;
  };
  return {sd.mean,     sd.se(), sr.mean, rms(sd), rms(so), std::sqrt(se2) / sr.mean,
          sr.spread(), se.mean, se.se()};
}

const std::vector<LightCase> &LightCases() {
  static const V3 wo10 = Normalize({0.3, 0.0, 1.0});
  static const V3 wo80 = {std::sin(80 * M_PI / 180), 0.0, std::cos(80 * M_PI / 180)};
  static const std::vector<LightCase> cases = {
      {"small", wo10, 0.03, 1e5},   {"small", wo10, 0.03, 1e7},   {"medium", wo10, 0.25, 1e5},
      {"medium", wo10, 0.25, 1e7},  {"large", wo10, 1.5, 1e5},    {"large", wo10, 1.5, 1e7},
      {"grazing", wo80, 0.25, 1e5}, {"grazing", wo80, 0.25, 1e7},
  };
  return cases;
}

double ErfcBias(int hood) {
  return hood == GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER ? 0.0
                                                    : kCheapErfcBiasBound + 2 * kCheapErfcBound;
}

constexpr int kPatterns = 4, kUvPerPattern = 60, kDirections = 1024;

// The small light's per-query budget: RMS 0.05 of the mean, i.e. E[diff^2 - MC SE^2] (each term
// unbiased for that query's squared model error: the MC's sample variance is unbiased) at most
// (0.05 mean)^2, up to 4.5 standard errors of the queries' mean excess. That mean is as skewed as
// the bias's (a query holding a glint narrower than the light has a few MC hits on it, so its
// diff^2 and sample variance both swing by orders of magnitude): without its standard error the
// assertion failed 1 of 40 sets of session 20's sample (60 uv, 2048 directions) and 5 of 20 of
// the pooled one (2 of 20 with 2048 directions), at RMS 0.06-0.10 of the mean with the MC noise
// at 0.04-0.08; with it, none of 40 and 20 (DISABLED_ThePooledSampleIsNotFragile).
bool SmallLightWithinBudget(const LightCaseResult &r) {
  const double budget = 0.05 * r.mean;
  return r.excess < budget * budget + 4.5 * r.excess_se;
}

class PolygonLightsByNeighborhood : public ::testing::TestWithParam<int> {};

TEST_P(PolygonLightsByNeighborhood, AgainstMonteCarloOverTheLight) {
  const int hood = GetParam();
  for (const LightCase &c : LightCases()) {
    LightCaseResult r = RunLightCase(c, hood, 11, kPatterns, kUvPerPattern, kDirections, 5);
    std::printf(
        "%-9s %-7s light, density %.0e: bias %+.4f +- %.4f of the mean; per-query RMS %.3f of "
        "the mean (centre-S approximation %.3f; MC noise %.3f removed; spread of the glints "
        "%.3f)\n",
        HoodName(hood), c.name, c.density, r.bias / r.mean, r.se / r.mean, r.rms, r.rms_old,
        r.mc_noise, r.spread);
    EXPECT_NEAR(r.bias, 0.0, 4.5 * r.se + ErfcBias(hood) * r.mean)
        << HoodName(hood) << " " << c.name << " " << c.density;
    if (c.half < 0.1)
      EXPECT_TRUE(SmallLightWithinBudget(r))
          << HoodName(hood) << " " << c.name << " " << c.density << ": RMS " << r.rms << ", excess "
          << r.excess << " +- " << r.excess_se;
    else
      EXPECT_LT(r.rms, r.rms_old) << HoodName(hood) << " " << c.name << " " << c.density;
  }
}

// The test above on other patterns and uv (GLINT_PROBE_SETS sets of kPatterns seeds, default
// 20; a few minutes): counts the sets where either assertion fails, per configuration. Run with
// --gtest_also_run_disabled_tests after changing a hash; the count should be ~0. GLINT_PROBE_
// PATTERNS, _UV, _DIRECTIONS change the sample (session 20's test: 1, 60, 2048), _HALF keeps one
// light size, _VERBOSE prints every set.
TEST_P(PolygonLightsByNeighborhood, DISABLED_ThePooledSampleIsNotFragile) {
  const int hood = GetParam();
  const char *env = std::getenv("GLINT_PROBE_SETS");
  const int sets = env ? std::atoi(env) : 20;
  auto env_int = [](const char *name, int fallback) {
    const char *e = std::getenv(name);
    return e ? std::atoi(e) : fallback;
  };
  const int patterns = env_int("GLINT_PROBE_PATTERNS", kPatterns);
  const int uv = env_int("GLINT_PROBE_UV", kUvPerPattern);
  const int dirs = env_int("GLINT_PROBE_DIRECTIONS", kDirections);
  const double only =
      std::getenv("GLINT_PROBE_HALF") ? std::atof(std::getenv("GLINT_PROBE_HALF")) : 0;
  for (const LightCase &c : LightCases()) {
    if (only > 0 && c.half != only) continue;
    int fail_bias = 0, fail_rms = 0;
    for (int k = 0; k < sets; ++k) {
      LightCaseResult r = RunLightCase(c, hood, 1000 + unsigned(k * patterns), patterns, uv, dirs,
                                       77 + uint64_t(k));
      if (std::getenv("GLINT_PROBE_VERBOSE"))
        std::printf("  set %d: bias %+.4f +- %.4f, RMS %.3f (centre-S %.3f, MC noise %.3f)\n", k,
                    r.bias / r.mean, r.se / r.mean, r.rms, r.rms_old, r.mc_noise);
      fail_bias += std::fabs(r.bias) > 4.5 * r.se + ErfcBias(hood) * r.mean;
      fail_rms += !(c.half < 0.1 ? SmallLightWithinBudget(r) : r.rms < r.rms_old);
    }
    std::printf("%-9s %-7s light, density %.0e: %d of %d sets fail the bias, %d the RMS\n",
                HoodName(hood), c.name, c.density, fail_bias, sets, fail_rms);
    EXPECT_EQ(fail_bias + fail_rms, 0) << HoodName(hood) << " " << c.name << " " << c.density;
  }
}

INSTANTIATE_TEST_SUITE_P(Neighborhoods, PolygonLightsByNeighborhood,
                         ::testing::Values(GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER,
                                           GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL,
                                           GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL),
                         [](const ::testing::TestParamInfo<int> &i) {
                           return std::string(HoodName(i.param));
                         });

// The polygon pass dithers to the point pass's level (kemppinen_dithered_level, one function of
// the footprint for both passes). A tiny square light (half-size 0.003 at distance 3, 0.06
// degrees) in the mirror direction against the point pass at its centre's half-vector h, k = 4
// (a light that small has a 2 x 2 explicit angular block in the polygon pass too, so both
// passes evaluate the same facets), footprints at lambda = l + 1/2 so half the queries take
// each level. Per query the polygon's S = radiance / smooth radiance (the smooth part by an
// 8 x 8 midpoint rule over the light of the smooth BRDF) against the point pass's S at h
// (GlintFactor, its own dither): as the light shrinks every approximation of
// kemppinen_polygons.h vanishes (the lobe mass over R tends to the lobe times R's area, rho and
// |J_T| at R's centroid to their values at h), so the two agree per query within the small
// light's budget of AgainstMonteCarloOverTheLight, 0.05 of max(1, S) (a light 10x smaller, its
// approximations 100x smaller). Were the polygon pass to pick its level otherwise, about half of
// the queries would see the other level's facets: the test also counts the queries whose other
// level's S differs from the picked one's by more than twice that budget (where a wrong pick
// could not pass) and asserts they are at least a quarter.
TEST(PolygonLights, OneLevelPicksThePointPassLevel) {
  const V3 wo = Normalize({0.3, 0.0, 1.0});
  const V3 mirror = {-wo.x, -wo.y, wo.z};
  const double dist = 3.0, half = 0.003;
  const std::vector<V3> quad = SquareLight(mirror, dist, half);
  const V3 hc = Normalize({mirror.x + wo.x, mirror.y + wo.y, mirror.z + wo.z});
  for (int hood : {GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL, GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL})
    for (double density : {1e5, 1e7}) {
      Glinty g;
      g.density = density;
      g.neighborhood = hood;
      g.neighbors = 4;
      const auto fp = FootprintForLevel(g, 5.5);
      const double lf = std::floor(k64::Lambda(g, fp.data()));
      // The smooth radiance of the light: midpoint rule over the square (uniform in area, the
      // Jacobian A cos_l / d^2 per sample).
      const V3 e1 = {quad[1].x - quad[0].x, quad[1].y - quad[0].y, quad[1].z - quad[0].z};
      const V3 e2 = {quad[3].x - quad[0].x, quad[3].y - quad[0].y, quad[3].z - quad[0].z};
      double smooth = 0;
      const int m = 8;
      for (int a = 0; a < m; ++a)
        for (int b = 0; b < m; ++b) {
          double sa = (a + 0.5) / m, sb = (b + 0.5) / m;
          V3 p = {quad[0].x + sa * e1.x + sb * e2.x, quad[0].y + sa * e1.y + sb * e2.y,
                  quad[0].z + sa * e1.z + sb * e2.z};
          double d2 = p.x * p.x + p.y * p.y + p.z * p.z, d = std::sqrt(d2);
          V3 wi = {p.x / d, p.y / d, p.z / d};
          double cos_l = std::fabs(wi.x * mirror.x + wi.y * mirror.y + wi.z * mirror.z);
          smooth += k64::SmoothProbe(g, wo, wi) * 4 * half * half * cos_l / d2 / (m * m);
        }
      std::mt19937_64 rng(23);
      std::uniform_real_distribution<double> uni(0.0, 100.0);
      const int count = 400;
      int decisive = 0, coarser = 0;
      double worst = 0;
      for (int i = 0; i < count; ++i) {
        double u = uni(rng), v = uni(rng);
        double s_poly =
            k64::QueryPolygon(g, u, v, fp.data(), wo, quad, GLINT_AREA_REFERENCE, 16) / smooth;
        double s_point = k64::GlintFactor(g, u, v, fp.data(), hc);
        double picked = k64::PickedLevel(g, u, v, fp.data());
        coarser += picked > lf;
        double s_other = k64::LevelEstimate(g, u, v, fp.data(), hc, int(picked > lf ? lf : lf + 1));
        double budget = 0.05 * std::max(1.0, s_point);
        worst = std::max(worst, std::fabs(s_poly - s_point) / std::max(1.0, s_point));
        decisive += std::fabs(s_other - s_point) > 2 * budget;
        EXPECT_NEAR(s_poly, s_point, budget)
            << HoodName(hood) << " density " << density << " query " << i << " uv " << u << "," << v
            << " level " << picked << " (other level's S " << s_other << ")";
      }
      std::printf(
          "%-9s density %.0e, lambda %.2f: polygon S against the point pass's, max |difference| "
          "%.2e of max(1, S); coarser level in %d of %d queries, %d where the other level's S "
          "differs by more than 0.1 of max(1, S)\n",
          HoodName(hood), density, k64::Lambda(g, fp.data()), worst, coarser, count, decisive);
      EXPECT_GE(decisive, count / 4) << HoodName(hood) << " density " << density;
    }
}

// Per-glint colours (K25 3.3.6) with more than two colours: each facet takes colour
// floor(pick n) of n from its cell's hash, the compensation their mean.
//   - Frequencies: the colours of 40000 facets (distinct cells of two levels) against 1/n each,
//     chi-square with n - 1 degrees of freedom below its 0.9999 quantile (n = 3, 5, 8; pick is
//     a 16-bit uniform, so each probability is 1/n within 2^-16: 0.6 expected counts here).
//   - Averaged over uv, D_star / D per channel is the mean colour (Eq. 2 per channel, 4.5
//     standard errors), and so is the polygon light's radiance over its smooth radiance.
TEST(Colours, FacetColourFrequenciesAreOneOverN) {
  const double palette[8][3] = {{1, 0.2, 0.1},   {1, 0.9, 0.2}, {0.1, 0.4, 1}, {0.3, 1, 0.3},
                                {0.9, 0.9, 0.9}, {0.5, 0, 0.5}, {0, 0.6, 0.6}, {0.7, 0.5, 0.2}};
  // Chi-square 0.9999 quantiles by degrees of freedom n - 1, indexed by n.
  const double quantile_9999[9] = {0, 0, 15.14, 18.42, 21.11, 23.51, 25.74, 27.86, 29.88};
  for (int n : {3, 5, 8}) {
    Glinty g;
    for (int c = 0; c < n; ++c)
      for (int ch = 0; ch < 3; ++ch) g.colors.push_back(palette[c][ch]);
    std::vector<int> counts(size_t(n), 0);
    int total = 0;
    for (int level : {3, 9})
      for (int cx = 0; cx < 50; ++cx)
        for (int ix = 0; ix < 20; ++ix)
          for (int iy = 0; iy < 20; ++iy) {
            auto c = k64::FacetColor(g, level, cx, 7 * cx + 1, ix, iy);
            int found = -1;
            for (int k = 0; k < n; ++k)
              if (std::fabs(c[0] - palette[k][0]) + std::fabs(c[1] - palette[k][1]) +
                      std::fabs(c[2] - palette[k][2]) <
                  1e-6)  // colours are stored as floats
                found = k;
            ASSERT_GE(found, 0) << "a facet colour outside the palette";
            ++counts[size_t(found)];
            ++total;
          }
    double chi2 = 0, e = double(total) / n;
    for (int k = 0; k < n; ++k) chi2 += (counts[size_t(k)] - e) * (counts[size_t(k)] - e) / e;
    std::printf("%d colours over %d facets: chi-square %.2f (%d dof, 0.9999 quantile %.2f)\n", n,
                total, chi2, n - 1, quantile_9999[n]);
    EXPECT_LT(chi2, quantile_9999[n]) << n << " colours";
  }
}

// Per neighbourhood: the cheap settings' erfc adds at most kCheapErfcBiasBound to D_star / D
// and 2 kCheapErfcBound to the polygon's ratio (its 1 - P_s, AgainstMonteCarloOverTheLight);
// the smooth reference stays the paper's setting.
class ColoursByNeighborhood : public ::testing::TestWithParam<int> {};

TEST_P(ColoursByNeighborhood, AveragedOverUvTheColourIsTheMeanColour) {
  const int hood = GetParam();
  const bool cheap = hood != GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER;
  Glinty g;
  g.neighborhood = hood;
  g.colors = {1, 0.2, 0.1, 1, 0.9, 0.2, 0.1, 0.4, 1, 0.3, 1, 0.3, 0.5, 0, 0.5};  // 5 colours
  std::array<double, 3> mean{};
  for (size_t i = 0; i < g.colors.size(); ++i) mean[i % 3] += g.colors[i] / 5.0;
  const V3 h = Normalize({0.1, -0.05, 1});
  const double fp[4] = {1e-3, 0, 0, 1e-3};
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> uni(0.0, 100.0);
  std::array<std::vector<double>, 3> s, poly;
  const V3 wo = Normalize({0.3, 0.0, 1.0});
  const std::vector<V3> quad = SquareLight({-wo.x, -wo.y, wo.z}, 3.0, 0.25);
  Glinty white = g;
  white.colors.clear();
  white.neighborhood = GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER;
  white.density = 1e14;  // converged: the smooth radiance of the light
  const double smooth = k64::QueryPolygonRgb(white, 0.3, 0.4, fp, wo, quad)[0];
  g.density = 1e7;
  for (int i = 0; i < 20000; ++i) {
    double u = uni(rng), v = uni(rng);
    auto c = k64::GlintFactorRgb(g, u, v, fp, h);
    for (int ch = 0; ch < 3; ++ch) s[size_t(ch)].push_back(c[size_t(ch)]);
    if (i < 4000) {
      auto p = k64::QueryPolygonRgb(g, u, v, fp, wo, quad);
      for (int ch = 0; ch < 3; ++ch) poly[size_t(ch)].push_back(p[size_t(ch)] / smooth);
    }
  }
  for (int ch = 0; ch < 3; ++ch) {
    Stats st = Summarise(s[size_t(ch)]), sp = Summarise(poly[size_t(ch)]);
    std::printf(
        "%-9s 5 colours, channel %d: mean D*/D %.4f +- %.4f, polygon / smooth %.4f +- %.4f, "
        "mean colour %.4f\n",
        HoodName(hood), ch, st.mean, st.se(), sp.mean, sp.se(), mean[size_t(ch)]);
    EXPECT_NEAR(st.mean, mean[size_t(ch)],
                4.5 * st.se() + (cheap ? kCheapErfcBiasBound * mean[size_t(ch)] : 0.0))
        << HoodName(hood) << " channel " << ch;
    EXPECT_NEAR(sp.mean, mean[size_t(ch)],
                4.5 * sp.se() + (cheap ? 2 * kCheapErfcBound * mean[size_t(ch)] : 0.0))
        << HoodName(hood) << " polygon, channel " << ch;
  }
}

INSTANTIATE_TEST_SUITE_P(Neighborhoods, ColoursByNeighborhood,
                         ::testing::Values(GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER,
                                           GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL,
                                           GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL),
                         [](const ::testing::TestParamInfo<int> &i) {
                           return std::string(HoodName(i.param));
                         });

}  // namespace
