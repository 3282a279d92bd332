// kernels/area/area_monte_carlo.h (the MONTE_CARLO area method): unbiasedness against the REFERENCE
// quadrature of kernels/area/area_lights.h, 1/sqrt(n) convergence, independent random streams
// for neighbouring queries, seeds and lights, multiple importance sampling against its two
// techniques alone, fp32 extremes, and fp32 against fp64 per estimate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <vector>

#include "tests/support/kernels_both_precisions.h"

namespace {

struct V3 {
  double x, y, z;
};
V3 Sub(V3 a, V3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3 Cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double Dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

struct Mat {
  int ndf = GLINT_NDF_GGX;
  double ax = 0.3, ay = 0.3;
  double f0 = 1.0;  // grey Schlick
};

using Poly = std::vector<V3>;

// Counter-clockwise seen from the receiver at the origin (the facing convention of polygon.h).
Poly Facing(Poly p) {
  V3 n = Cross(Sub(p[1], p[0]), Sub(p[2], p[0]));
  if (Dot(n, p[0]) > 0) std::reverse(p.begin(), p.end());
  return p;
}

// Axis-aligned square of half-size h centred at (cx, cy, z), parallel to the tangent plane.
Poly Square(double cx, double cy, double z, double h) {
  return Facing(
      {{cx - h, cy - h, z}, {cx + h, cy - h, z}, {cx + h, cy + h, z}, {cx - h, cy + h, z}});
}

V3 Wo(double theta_deg, double phi_deg = 0) {
  double t = theta_deg * M_PI / 180, p = phi_deg * M_PI / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

k64::SmoothMaterial Material64(const Mat &mat) {
  k64::SmoothMaterial m;
  m.ndf = mat.ndf;
  m.alpha_x = mat.ax;
  m.alpha_y = mat.ay;
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a = k64::make_real3(mat.f0, mat.f0, mat.f0);
  m.fresnel.b = k64::make_real3(0, 0, 0);
  return m;
}

k32::SmoothMaterial Material32(const Mat &mat) {
  k32::SmoothMaterial m;
  m.ndf = mat.ndf;
  m.alpha_x = float(mat.ax);
  m.alpha_y = float(mat.ay);
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a = k32::make_real3(float(mat.f0), float(mat.f0), float(mat.f0));
  m.fresnel.b = k32::make_real3(0, 0, 0);
  return m;
}

// A polygon in the kernels' private-array form.
struct Verts64 {
  k64::real3 v[GLINT_POLYGON_MAX_VERTICES];
  int n;
  explicit Verts64(const Poly &p) : n(int(p.size())) {
    for (int i = 0; i < n; ++i) v[i] = k64::make_real3(p[i].x, p[i].y, p[i].z);
  }
};
struct Verts32 {
  k32::real3 v[GLINT_POLYGON_MAX_VERTICES];
  int n;
  explicit Verts32(const Poly &p) : n(int(p.size())) {
    for (int i = 0; i < n; ++i) v[i] = k32::make_real3(float(p[i].x), float(p[i].y), float(p[i].z));
  }
};

k64::real3 Wo64(V3 w) {
  return k64::r3_normalize(k64::make_real3(w.x, w.y, w.z));
}
k32::real3 Wo32(V3 w) {
  return k32::r3_normalize(k32::make_real3(float(w.x), float(w.y), float(w.z)));
}

// Per-query keys as a caller would make them: a hash of (seed, stream, index).
uint Key(uint seed, uint stream, uint k) {
  return k64::rng_hash3(seed, stream, k);
}

// Red channel of the MC estimate in double; n_light / n_lobe < 0 means the default split.
double Mc64(const Mat &mat, V3 wo, const Poly &poly, int samples, uint key, int n_light = -1,
            int n_lobe = -1) {
  Verts64 p(poly);
  if (n_light < 0) return k64::area_mc_polygon(Material64(mat), Wo64(wo), p.v, p.n, samples, key).x;
  return k64::area_mc_polygon_split(Material64(mat), Wo64(wo), p.v, p.n, n_light, n_lobe, key).x;
}

double Reference(const Mat &mat, V3 wo, const Poly &poly, int nodes) {
  Verts64 p(poly);
  return k64::area_reference_polygon(Material64(mat), Wo64(wo), p.v, p.n, nodes).x;
}

struct Stats {
  double mean, se, var;
};
// Mean, its standard error and the per-estimate variance over `keys` independent estimates.
template <class F>
Stats Sample(int keys, F estimate) {
  double s = 0, s2 = 0;
  for (int k = 0; k < keys; ++k) {
    double x = estimate(uint(k));
    s += x;
    s2 += x * x;
  }
  double mean = s / keys;
  double var = std::max(s2 / keys - mean * mean, 0.0) * keys / (keys - 1);
  return {mean, std::sqrt(var / keys), var};
}

struct Config {
  const char *name;
  Mat mat;
  V3 wo;
  Poly poly;
};

const std::vector<Config> &Configs() {
  static const std::vector<Config> configs = {
      {"ggx 0.3, 30deg, overhead quad", {GLINT_NDF_GGX, 0.3, 0.3}, Wo(30), Square(0, 0, 1, 1)},
      {"ggx 0.05, normal view, big quad", {GLINT_NDF_GGX, 0.05, 0.05}, Wo(0), Square(0, 0, 0.5, 2)},
      {"ggx 1, 75deg, small triangle",
       {GLINT_NDF_GGX, 1.0, 1.0},
       Wo(75, 180),
       Facing({{-0.8, 0.2, 2}, {-0.3, 0.1, 2}, {-0.5, 0.9, 2}})},
      {"beckmann 0.3, 40deg, tilted",
       {GLINT_NDF_BECKMANN, 0.3, 0.3},
       Wo(40, 30),
       Facing({{0.5, -1, 0.5}, {0.5, 1, 0.5}, {2, 1, 1.5}, {2, -1, 1.5}})},
      {"beckmann 0.05, 60deg, off-peak quad",
       {GLINT_NDF_BECKMANN, 0.05, 0.05, 0.04},
       Wo(60),
       Square(-0.8, 0.1, 1, 0.6)},
      {"ggx aniso 0.4/0.1, partly below",
       {GLINT_NDF_GGX, 0.4, 0.1},
       Wo(40, 30),
       Facing({{-1, -1, -0.5}, {-1, 1, -0.5}, {1, 1, 1.5}, {1, -1, 1.5}})},
      {"beckmann aniso 0.1/0.5, grazing 80deg, partly below",
       {GLINT_NDF_BECKMANN, 0.1, 0.5},
       Wo(80, 10),
       Facing({{-1, -1, -0.5}, {-1, 1, -0.5}, {1, 1, 1.5}, {1, -1, 1.5}})},
      {"ggx 0.1, grazing 85deg, pentagon",
       {GLINT_NDF_GGX, 0.1, 0.1},
       Wo(85, 180),
       Facing({{1, 0, 1}, {0.31, 0.95, 1}, {-0.81, 0.59, 1}, {-0.81, -0.59, 1}, {0.31, -0.95, 1}})},
      {"ggx 0.5, small far quad",
       {GLINT_NDF_GGX, 0.5, 0.5},
       Wo(30, 200),
       Square(0.4, 0.3, 2, 0.05)},
      {"ggx 0.05, small quad at the peak",
       {GLINT_NDF_GGX, 0.05, 0.05},
       Wo(30, 180),
       Square(0.5, 0, 1, 0.1)},
  };
  return configs;
}

// (1) Unbiased: the mean over many keys matches REFERENCE within 4 standard errors (plus the
// reference's own quadrature error, estimated from 256 vs 512 nodes per dimension), at n = 8
// (even split), n = 3 (odd split: 2 light + 1 lobe) and n = 1 (the one-sample model).
TEST(AreaMonteCarlo, UnbiasedAgainstReference) {
  const int keys = 20000;
  for (size_t c = 0; c < Configs().size(); ++c) {
    const Config &cfg = Configs()[c];
    double ref = Reference(cfg.mat, cfg.wo, cfg.poly, 512);
    double quad_err = std::fabs(ref - Reference(cfg.mat, cfg.wo, cfg.poly, 256));
    EXPECT_GT(ref, 0.0) << cfg.name;
    for (int n : {8, 3, 1}) {
      // n = 1 and 3 on every other configuration only, to keep the test fast.
      if (n != 8 && c % 2 == 1) continue;
      Stats s = Sample(keys, [&](uint k) {
        return Mc64(cfg.mat, cfg.wo, cfg.poly, n, Key(1 + uint(n), uint(c), k));
      });
      std::printf("%-52s n %d ref %.6e  mc %.6e +- %.1e  (%+.2f se, quad err %.1e)\n", cfg.name, n,
                  ref, s.mean, s.se, (s.mean - ref) / s.se, quad_err);
      EXPECT_LT(s.se, 0.05 * ref) << cfg.name << " n " << n << ": too noisy to test anything";
      EXPECT_NEAR(s.mean, ref, 4 * s.se + 2 * quad_err + 1e-12) << cfg.name << " n " << n;
    }
  }
}

// (2) RMS error against REFERENCE falls like n^-1/2.
TEST(AreaMonteCarlo, ConvergesAsInverseSqrtN) {
  const int keys = 400;
  const int ns[] = {4, 16, 64, 256, 1024};
  for (size_t c : {size_t(0), size_t(4), size_t(6)}) {
    const Config &cfg = Configs()[c];
    double ref = Reference(cfg.mat, cfg.wo, cfg.poly, 512);
    std::printf("%s (reference %.6e)\n%6s %12s %12s\n", cfg.name, ref, "n", "rms error",
                "relative");
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int n : ns) {
      double e2 = 0;
      for (int k = 0; k < keys; ++k) {
        double e = Mc64(cfg.mat, cfg.wo, cfg.poly, n, Key(20, uint(n), uint(k))) - ref;
        e2 += e * e;
      }
      double rms = std::sqrt(e2 / keys);
      std::printf("%6d %12.4e %12.4e\n", n, rms, rms / ref);
      double x = std::log(double(n)), y = std::log(rms);
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
    const double m = double(std::size(ns));
    double slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
    std::printf("log-log slope %.3f\n", slope);
    EXPECT_GE(slope, -0.6) << cfg.name;
    EXPECT_LE(slope, -0.4) << cfg.name;
  }
}

// (3) Independent random streams where they must be independent. The estimate is a pure
// function of (inputs, samples, key), so "same key, same result" cannot fail; what can fail is
// the key derivation (area_query_key: the request seed and the query's own wo and position,
// never its index; area_shade_keyed: one stream per light). If any of these inputs were dropped
// or coarsened, two queries (or lights) would share noise, visible as structured noise in an
// image. Tested by the sample correlation over K = 4000 seeds between the estimates of
//  - two queries whose wo differ by one float ulp (x component), and two whose positions do;
//  - the same query under seed_lo s and s + 1, and under seed_hi 0 and 1;
//  - two identical lights in one query (light 1 = total - light 0 alone).
// Independent estimates have |r| < 4 / sqrt(K) = 0.063 but for a 6e-5 chance (K fixed: the test
// is deterministic); a shared stream gives r ~ 1.
std::vector<float> PolygonRecord(const Poly &poly) {
  std::vector<float> r(GLINT_POLYGON_FLOATS, 0.0f);
  r[0] = float(poly.size());
  r[2] = r[3] = r[4] = 1.0f;
  for (size_t i = 0; i < poly.size(); ++i) {
    r[GLINT_POLYGON_VERTEX_OFFSET + 3 * i + 0] = float(poly[i].x);
    r[GLINT_POLYGON_VERTEX_OFFSET + 3 * i + 1] = float(poly[i].y);
    r[GLINT_POLYGON_VERTEX_OFFSET + 3 * i + 2] = float(poly[i].z);
  }
  return r;
}

double Correlation(const std::vector<double> &x, const std::vector<double> &y) {
  const double n = double(x.size());
  double mx = 0, my = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    mx += x[i] / n;
    my += y[i] / n;
  }
  double sxy = 0, sxx = 0, syy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
  }
  return sxy / std::sqrt(sxx * syy);
}

TEST(AreaMonteCarlo, IndependentStreamsForNeighboursSeedsAndLights) {
  const Mat mat{GLINT_NDF_GGX, 0.3, 0.3};
  const Poly poly = Square(0.3, 0.1, 1, 0.6);
  const std::vector<float> one = PolygonRecord(poly);
  std::vector<float> two = one;
  two.insert(two.end(), one.begin(), one.end());
  const k64::SmoothMaterial m = Material64(mat);
  const k64::ShadingFrame identity = k64::frame_identity();
  const float wo[3] = {0.3f, 0.2f, 0.932737905f};
  const float p[3] = {1.5f, -2.25f, 0.125f};
  // Red channel of the MONTE_CARLO estimate (4 samples) of a query with wo, position pos.
  auto estimate = [&](uint seed_lo, uint seed_hi, const float *w, const float *pos,
                      const std::vector<float> &lights) {
    const uint key = k64::area_query_key(seed_lo, seed_hi, w, pos);
    const k64::real3 wl = k64::r3_normalize(k64::make_real3(w[0], w[1], w[2]));
    return k64::area_shade_keyed(m, nullptr, GLINT_AREA_MONTE_CARLO, 4, wl, 0, identity,
                                 k64::make_real3(0, 0, 0), lights.data(),
                                 uint(lights.size() / GLINT_POLYGON_FLOATS), key)
        .x;
  };
  float wo_ulp[3] = {std::nextafter(wo[0], 1.0f), wo[1], wo[2]};
  float p_ulp[3] = {p[0], std::nextafter(p[1], 0.0f), p[2]};
  const int K = 4000;
  const char *names[6] = {"wo one ulp apart", "position one ulp apart", "seed_lo s vs s + 1",
                          "seed_hi 0 vs 1",   "light 0 vs light 1",     "(control) same key"};
  std::vector<double> x[6], y[6];
  for (int s = 0; s < K; ++s) {
    const uint seed = uint(s) * 2u;
    x[0].push_back(estimate(seed, 0, wo, nullptr, one));
    y[0].push_back(estimate(seed, 0, wo_ulp, nullptr, one));
    x[1].push_back(estimate(seed, 0, wo, p, one));
    y[1].push_back(estimate(seed, 0, wo, p_ulp, one));
    x[2].push_back(estimate(seed, 0, wo, p, one));
    y[2].push_back(estimate(seed + 1, 0, wo, p, one));
    x[3].push_back(estimate(seed, 0, wo, p, one));
    y[3].push_back(estimate(seed, 1, wo, p, one));
    const double light0 = estimate(seed, 7, wo, p, one);
    x[4].push_back(light0);
    y[4].push_back(estimate(seed, 7, wo, p, two) - light0);
    x[5].push_back(light0);
    y[5].push_back(estimate(seed, 7, wo, p, one));
  }
  const double bound = 4 / std::sqrt(double(K));
  for (int k = 0; k < 6; ++k) {
    const double r = Correlation(x[k], y[k]);
    std::printf("%-24s correlation %+.4f\n", names[k], r);
    if (k < 5) {
      EXPECT_LT(std::fabs(r), bound) << names[k];
    } else {
      EXPECT_GT(r, 1 - 1e-12) << "the control must be perfectly correlated";
    }
  }
}

// (4) MIS against each technique alone at the same budget (16 samples): per-estimate variance.
// Measured (see the printed table): MIS with the fixed half/half split does NOT beat the better
// technique when one of them is near-ideal: light sampling for a small light on a rough surface
// (MIS ~2x its variance: half the light samples), lobe sampling for a big light on a smooth one
// (MIS ~4-40x: the light samples in the lobe's tails add variance). What MIS buys is robustness:
// it is orders of magnitude better than the worse technique, always within Veach's bound (1997,
// Theorem 9.2: sigma^2_MIS <= sigma^2 of any other combination with the same sample counts, e.g.
// the better technique alone with its n/2 samples, + (1/min n_i - 1/n) mu^2), and it beats both
// where light and lobe have comparable extents (the "medium" rows).
TEST(AreaMonteCarlo, MisAgainstSingleTechniques) {
  enum Kind { kSmallRough, kBigSmooth, kMedium };
  struct Case {
    const char *name;
    Kind kind;
    Mat mat;
    V3 wo;
    Poly poly;
  };
  const Case cases[] = {
      {"small light, rough (ggx 0.5)",
       kSmallRough,
       {GLINT_NDF_GGX, 0.5, 0.5},
       Wo(30, 200),
       Square(0.4, 0.3, 2, 0.05)},
      {"small light, rough (ggx 1)",
       kSmallRough,
       {GLINT_NDF_GGX, 1.0, 1.0},
       Wo(60),
       Square(-0.5, 0, 1, 0.1)},
      {"small light, rough (beckmann 0.5, 70deg)",
       kSmallRough,
       {GLINT_NDF_BECKMANN, 0.5, 0.5},
       Wo(70, 180),
       Square(0.8, 0, 1, 0.1)},
      {"big light, smooth (ggx 0.05)",
       kBigSmooth,
       {GLINT_NDF_GGX, 0.05, 0.05},
       Wo(0),
       Square(0, 0, 0.5, 2)},
      {"big light, smooth (beckmann 0.05, 60deg)",
       kBigSmooth,
       {GLINT_NDF_BECKMANN, 0.05, 0.05},
       Wo(60),
       Square(0, 0, 0.5, 2)},
      {"big light, smooth (ggx aniso 0.1/0.02, 45deg)",
       kBigSmooth,
       {GLINT_NDF_GGX, 0.1, 0.02},
       Wo(45, 180),
       Square(0, 0, 1, 1)},
      {"medium light, ggx 0.3, 70deg",
       kMedium,
       {GLINT_NDF_GGX, 0.3, 0.3},
       Wo(70, 180),
       Square(0.5, 0, 1, 1)},
      {"medium light, ggx 0.05, 70deg",
       kMedium,
       {GLINT_NDF_GGX, 0.05, 0.05},
       Wo(70, 180),
       Square(0.5, 0, 1, 1)},
  };
  const int keys = 4000, n = 16;
  std::printf("%-48s %11s %11s %11s %9s %9s\n", "config (variance at n = 16)", "MIS", "light",
              "lobe", "light/MIS", "lobe/MIS");
  for (size_t c = 0; c < std::size(cases); ++c) {
    const Case &cs = cases[c];
    Stats mis =
        Sample(keys, [&](uint k) { return Mc64(cs.mat, cs.wo, cs.poly, n, Key(4, uint(c), k)); });
    double light = Sample(keys, [&](uint k) {
                     return Mc64(cs.mat, cs.wo, cs.poly, n, Key(5, uint(c), k), n, 0);
                   }).var;
    double lobe = Sample(keys, [&](uint k) {
                    return Mc64(cs.mat, cs.wo, cs.poly, n, Key(6, uint(c), k), 0, n);
                  }).var;
    std::printf("%-48s %11.4e %11.4e %11.4e %9.2f %9.2f\n", cs.name, mis.var, light, lobe,
                light / mis.var, lobe / mis.var);
    double best = std::min(light, lobe), worst = std::max(light, lobe);
    // Veach's bound with the better technique alone on n/2 samples (variance 2 best).
    EXPECT_LE(mis.var, 2 * best + (1.0 / (n / 2) - 1.0 / n) * mis.mean * mis.mean) << cs.name;
    if (cs.kind != kMedium) {
      EXPECT_LT(10 * mis.var, worst) << cs.name << ": MIS avoids the bad technique's noise";
    }
    if (cs.kind == kSmallRough) {
      EXPECT_LT(light, lobe) << cs.name;
      EXPECT_LT(mis.var, 3 * light) << cs.name;
    } else if (cs.kind == kBigSmooth) {
      EXPECT_LT(lobe, light) << cs.name;
    } else {
      EXPECT_LT(1.1 * mis.var, light) << cs.name << ": MIS beats light sampling";
      EXPECT_LT(1.1 * mis.var, lobe) << cs.name << ": MIS beats lobe sampling";
    }
  }
}

// (5) fp32 extremes: finite and non-negative everywhere; 0 where nothing is visible.
TEST(AreaMonteCarlo, Fp32ExtremesFiniteNonNegative) {
  const Poly polys[] = {
      Square(0, 0, 1, 1),                                                  // overhead
      Square(0.3, 0.2, 1, 1e-4),                                           // tiny
      Square(0.3, 0.2, 1, 1e-6),                                           // tinier
      Square(0, 0, 1e-3, 1e6),                                             // fills the hemisphere
      Facing({{-1, -1, -0.5}, {-1, 1, -0.5}, {1, 1, 1.5}, {1, -1, 1.5}}),  // partly below
      Facing({{-1, -1, -1}, {-1, 1, -1}, {1, 1, -0.1}, {1, -1, -0.1}}),    // wholly below
      Square(0, 0, 0, 1),                                                  // in the tangent plane
      Facing({{5, -1, 1e-3}, {5, 1, 1e-3}, {5, 1, 1e-2}, {5, -1, 1e-2}}),  // at the horizon
      Facing({{-5, -1, 1e-3}, {-5, 1, 1e-3}, {-5, 1, 1e-1}, {-5, -1, 1e-1}}),
  };
  const double alphas[][2] = {{1e-4, 1e-4}, {1e-3, 1e-3}, {0.05, 0.05},
                              {1, 1},       {1e-4, 1},    {1, 1e-4}};
  const double thetas[] = {0, 30, 80, 89.9, 89.999, 90, 95};
  long bad = 0, total = 0;
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    for (const auto &a : alphas) {
      Mat mat{ndf, a[0], a[1], 1.0};
      k32::SmoothMaterial m = Material32(mat);
      for (double th : thetas) {
        for (double ph : {0.0, 180.0}) {
          k32::real3 wo = Wo32(Wo(th, ph));
          for (size_t pi = 0; pi < std::size(polys); ++pi) {
            Verts32 p(polys[pi]);
            for (int n : {1, 2, 3, 16}) {
              for (uint k = 0; k < 8; ++k) {
                k32::real3 r = k32::area_mc_polygon(m, wo, p.v, p.n, n, Key(7, uint(n), k));
                for (float x : {r.x, r.y, r.z}) {
                  ++total;
                  if (!(std::isfinite(x) && x >= 0.0f)) {
                    if (++bad < 10)
                      ADD_FAILURE()
                          << "ndf " << ndf << " alpha " << a[0] << "," << a[1] << " theta " << th
                          << " polygon " << pi << " n " << n << ": " << x;
                  }
                }
                if (pi == 5 || pi == 6 || th > 90) {
                  EXPECT_EQ(r.x, 0.0f) << "polygon " << pi << " theta " << th;
                }
              }
            }
          }
        }
      }
    }
  }
  EXPECT_EQ(bad, 0) << "of " << total;
}

// At alpha 1e-4 a light covering the mirror direction reflects ~ F G2 = 1 (f0 = 1): the lobe
// technique carries the estimate, in float as in double, with almost no noise.
TEST(AreaMonteCarlo, NearMirrorBigLight) {
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    Mat mat{ndf, 1e-4, 1e-4, 1.0};
    for (double th : {0.0, 30.0, 60.0}) {
      V3 wo = Wo(th, 180);
      Poly poly = Square(0, 0, 1, 3);
      Verts32 p(poly);
      for (uint k = 0; k < 16; ++k) {
        EXPECT_NEAR(Mc64(mat, wo, poly, 16, Key(8, 0, k)), 1.0, 2e-3) << ndf << " " << th;
        float x = k32::area_mc_polygon(Material32(mat), Wo32(wo), p.v, p.n, 16, Key(8, 0, k)).x;
        EXPECT_NEAR(x, 1.0f, 2e-3f) << ndf << " " << th;
      }
    }
  }
}

// fp32 against fp64 per estimate, on identical inputs (float-rounded vertices, wo and alpha)
// and the same keys, so both draw the same random numbers (rng_u01 is exact in both): the
// configurations above and tiny lights down to 1e-6 rad. Tolerance from float epsilon and stated
// condition factors, relative:
//   64 eps (1 + 2 / alpha + [Beckmann] 2 x 80)  +  (2 / alpha) min(4 eps / theta, sqrt(8 eps)).
//  - A sample's f cos moves by eps times the lobe's log-slope, ~2 / alpha (GGX: |d log D /
//    d theta_h| <= 2 / alpha, theta_h moving at half the rate of wi), and for Beckmann by eps
//    times its exponent t^2 (condition of exp(-t^2)), up to 80 before the cut-off. The solid
//    angle (Van Oosterom & Strackee on edge vectors of the unnormalised vertices) and the MIS
//    weights are smooth in the same quantities; 64 covers the tens of roundings per sample.
//  - Arvo's map (arvo_arc / arvo_point, kernels/area/spherical_triangle.h) works on NORMALISED
//  vertices and on the cosine q of the arc
//    a c': an error of a few eps in q moves the arc by ~eps / sin(arc), and by up to
//    sqrt(2 dq) as the arc -> 0 (acos at 1). So in fp32 the samples of a light of angular size
//    theta are displaced by ~min(4 eps / theta, sqrt(8 eps)) rad (measured: 9e-5 rad on a
//    1.7e-3 rad light, 1.2e-4 on 1.7e-4, 2.7e-4 on 1.7e-5: 16 times the light's size, i.e.
//    samples land outside lights below ~3e-4 rad). The estimate moves by the lobe's log-slope
//    times that. (A known fp32 limit of the sampler, harmless while the lobe is much wider than
//    3e-4 rad; the solid angle itself stays exact to a few eps.)
// Not compared: an estimate in which a lobe sample lands within rounding of the polygon's edge
// (mc_inside flips between the precisions) or a uniform number within rounding of a triangle's
// CDF boundary (probability ~eps per sample; none among these keys).
TEST(AreaMonteCarlo, Fp32MatchesFp64WhereWellConditioned) {
  const double eps32 = std::ldexp(1.0, -24);
  auto round = [](const Poly &p) {
    Poly r;
    for (V3 v : p) r.push_back({double(float(v.x)), double(float(v.y)), double(float(v.z))});
    return r;
  };
  struct Case {
    const char *name;
    Mat mat;
    V3 wo;
    Poly poly;
  };
  std::vector<Case> cases;
  for (const Config &c : Configs()) cases.push_back({c.name, c.mat, c.wo, c.poly});
  for (double h : {1e-3, 1e-4, 1e-5, 1e-6})
    cases.push_back({"tiny light", {GLINT_NDF_GGX, 0.3, 0.3}, Wo(30, 180), Square(0.5, 0.1, 1, h)});
  for (const Case &c : cases) {
    Mat mat = c.mat;
    mat.ax = double(float(mat.ax));
    mat.ay = double(float(mat.ay));
    mat.f0 = double(float(mat.f0));
    const V3 wo = {double(float(c.wo.x)), double(float(c.wo.y)), double(float(c.wo.z))};
    const Poly poly = round(c.poly);
    const Verts32 p(poly);
    const Verts64 p64(poly);
    k64::McPolygon P;
    ASSERT_TRUE(k64::mc_polygon_setup(p64.v, p64.n, &P)) << c.name;
    const double theta = std::sqrt(P.omega), slope = 2 / std::min(mat.ax, mat.ay);
    const double tol = 64 * eps32 * (1 + slope + (mat.ndf == GLINT_NDF_BECKMANN ? 160 : 0)) +
                       slope * std::min(4 * eps32 / theta, std::sqrt(8 * eps32));
    double worst = 0;
    for (uint k = 0; k < 200; ++k) {
      const uint key = Key(9, 0, k);
      const double x64 = Mc64(mat, wo, poly, 16, key);
      const double x32 = k32::area_mc_polygon(Material32(mat), Wo32(wo), p.v, p.n, 16, key).x;
      if (x64 == 0 && x32 == 0) continue;
      const double rel = std::fabs(x32 - x64) / x64;
      worst = std::max(worst, rel);
      EXPECT_LT(rel, tol) << c.name << " key " << k << " fp64 " << x64 << " fp32 " << x32;
    }
    std::printf("%-52s theta %.1e: worst fp32 vs fp64 %.1e (tolerance %.1e)\n", c.name, theta,
                worst, tol);
  }
}

}  // namespace
