// The polygon loader's power-of-two rescale (kernels/area/polygon_scale.h, area_polygon_load_n
// in kernels/area/area_ltc.h), in fp32 and fp64 on the host:
//  - ordinary lights (vertex lengths between 5e-9 and 2e8 from the shading point) come out of
//    the loader exactly as the plain load gives them: every method's result on them is the one
//    before the rescale existed, bit for bit;
//  - far and near lights (1e-30 .. 1e30) come out as an exact power-of-two multiple of the plain
//    load, their largest coordinate in [2^-16, 2^16] (the range polygon_scale.h promises);
//  - fp32 vertices whose difference from the shading point overflows (opposite signs beyond
//    FLT_MAX / 2) come out as the exact power-of-two multiple of the same configuration scaled
//    down by 2^-127, with and without a frame;
//  - every area method through area_shade_keyed with one random-number key, MONTE_CARLO
//    included: such a light gives the radiance of its copy at distance ~1 bit for bit (scale
//    invariance: the integrands depend on directions only; the service test
//    tests/service/area_far_light_test.cpp checks the same on the device and for the glint
//    models, where MONTE_CARLO's key differs with the position).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "data/ltc/ltc_table.h"
#include "tests/support/kernels_both_precisions.h"

namespace {

// What the tests need of one precision's kernel namespace; the kernel functions themselves are
// found by argument-dependent lookup on k32::real3 / k64::real3.
struct K32 {
  using real = float;
  using real3 = k32::real3;
  using Frame = k32::ShadingFrame;
  using Material = k32::SmoothMaterial;
  static constexpr const char *kName = "fp32";
  static real3 Make(double x, double y, double z) {
    return k32::make_real3(float(x), float(y), float(z));
  }
  static Frame Identity() { return k32::frame_identity(); }
};
struct K64 {
  using real = double;
  using real3 = k64::real3;
  using Frame = k64::ShadingFrame;
  using Material = k64::SmoothMaterial;
  static constexpr const char *kName = "fp64";
  static real3 Make(double x, double y, double z) { return k64::make_real3(x, y, z); }
  static Frame Identity() { return k64::frame_identity(); }
};

// A polygon record of world vertices xyz (as server/eval_plan.cpp packs it).
std::vector<float> Record(const std::vector<double> &xyz, bool two_sided) {
  std::vector<float> r(GLINT_POLYGON_FLOATS, 0.0f);
  r[0] = float(xyz.size() / 3);
  r[1] = two_sided ? 1.0f : 0.0f;
  r[2] = 1.0f, r[3] = 0.7f, r[4] = 0.4f;
  for (size_t i = 0; i < xyz.size(); ++i) r[GLINT_POLYGON_VERTEX_OFFSET + i] = float(xyz[i]);
  return r;
}

// A rotated orthonormal frame (exactly orthonormal in double; rounded in fp32).
template <class K>
typename K::Frame Rotated() {
  typename K::Frame f;
  const double s = std::sqrt(0.5), c = std::sqrt(1.0 / 3.0);
  f.t = K::Make(s, -s, 0);
  f.b = K::Make(c * s * 1.0, c * s, -2 * c * s);
  f.n = K::Make(c, c, c);
  return f;
}

template <class K>
bool SameBits(typename K::real a, typename K::real b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// The exponent j with w = 2^j v in every coordinate (v, w finite), or -9999.
template <class K>
int PowerOfTwo(const typename K::real3 *v, const typename K::real3 *w, int n) {
  int j = -9999;
  for (int i = 0; i < n; ++i) {
    const typename K::real a[3] = {v[i].x, v[i].y, v[i].z}, b[3] = {w[i].x, w[i].y, w[i].z};
    for (int c = 0; c < 3; ++c) {
      if (a[c] == 0 && b[c] == 0) continue;
      if (a[c] == 0 || b[c] == 0 || !std::isfinite(a[c]) || !std::isfinite(b[c])) return -9999;
      int ea, eb;
      std::frexp(a[c], &ea);
      std::frexp(b[c], &eb);
      if (j == -9999) j = eb - ea;
      if (eb - ea != j || b[c] != std::ldexp(a[c], j)) return -9999;
    }
  }
  return j;
}

template <class K>
void OrdinaryLightsAreUntouched() {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1), lg(-8, std::log10(1e8));
  int compared = 0;
  for (int t = 0; t < 4000; ++t) {
    const double d = std::pow(10.0, lg(rng));
    double dir[3] = {u(rng), u(rng), u(rng)};
    const double l = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    // A square of half-size 0.3 d around the point d * dir, seen from p (shading point near
    // the origin on the light's scale), in a plane spanned by two fixed axes.
    const double p[3] = {0.5 * d * u(rng), 0.5 * d * u(rng), 0.5 * d * u(rng)};
    std::vector<double> xyz;
    const double corner[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (const auto &s : corner) {
      xyz.push_back(p[0] + d * (dir[0] / l + 0.3 * s[0]));
      xyz.push_back(p[1] + d * (dir[1] / l + 0.3 * s[1]));
      xyz.push_back(p[2] + d * (dir[2] / l));
    }
    const std::vector<float> rec = Record(xyz, false);
    for (bool framed : {false, true}) {
      const typename K::Frame f = framed ? Rotated<K>() : K::Identity();
      const typename K::real3 pp = K::Make(float(p[0]), float(p[1]), float(p[2]));
      typename K::real3 raw[GLINT_POLYGON_MAX_VERTICES], v[GLINT_POLYGON_MAX_VERTICES];
      area_polygon_load_raw(rec.data(), 4, framed, f, pp, raw);
      area_polygon_load_n(rec.data(), 4, framed, f, pp, v);
      for (int i = 0; i < 4; ++i) {
        ASSERT_TRUE(SameBits<K>(v[i].x, raw[i].x) && SameBits<K>(v[i].y, raw[i].y) &&
                    SameBits<K>(v[i].z, raw[i].z))
            << K::kName << " d " << d << " framed " << framed << " vertex " << i;
      }
      ++compared;
    }
  }
  EXPECT_EQ(compared, 8000);
}
TEST(PolygonScale, OrdinaryLightsAreLoadedUntouchedFp32) {
  OrdinaryLightsAreUntouched<K32>();
}
TEST(PolygonScale, OrdinaryLightsAreLoadedUntouchedFp64) {
  OrdinaryLightsAreUntouched<K64>();
}

// The loader's output for the quad `base` (world, relative to the origin) times d, seen from
// the origin: an exact power of two times the plain load, largest coordinate in [2^-16, 2^16].
template <class K>
void FarAndNearLightsArePowerOfTwoMultiples() {
  const std::vector<double> base = {2.5, -1, -0.5, 2.5, 1, -0.5, 2.5, 1, 1.5, 2.5, -1, 1.5};
  for (int e = -30; e <= 30; ++e) {
    if (std::abs(e) <= 8) continue;  // ordinary: the test above
    const double d = std::pow(10.0, e);
    std::vector<double> xyz;
    for (double x : base) xyz.push_back(x * d);
    const std::vector<float> rec = Record(xyz, true);
    for (bool framed : {false, true}) {
      const typename K::Frame f = framed ? Rotated<K>() : K::Identity();
      typename K::real3 raw[GLINT_POLYGON_MAX_VERTICES], v[GLINT_POLYGON_MAX_VERTICES];
      // The plain load's coordinates are normal floats down to 1e-30; its products are not.
      area_polygon_load_raw(rec.data(), 4, framed, f, K::Make(0, 0, 0), raw);
      area_polygon_load_n(rec.data(), 4, framed, f, K::Make(0, 0, 0), v);
      const int j = PowerOfTwo<K>(raw, v, 4);
      ASSERT_NE(j, -9999) << K::kName << " d 1e" << e << " framed " << framed;
      double m = 0;
      for (int i = 0; i < 4; ++i)
        m = std::max(
            {m, std::fabs(double(v[i].x)), std::fabs(double(v[i].y)), std::fabs(double(v[i].z))});
      // |e| = 9 may or may not be out of range (the test is on the sum of squared lengths);
      // beyond it every light is.
      if (std::abs(e) >= 10) {
        EXPECT_NE(j, 0) << K::kName << " d 1e" << e << ": not rescaled";
      }
      if (j == 0) continue;
      EXPECT_GE(m, std::ldexp(1.0, -16)) << K::kName << " d 1e" << e;
      EXPECT_LE(m, std::ldexp(1.0, 16)) << K::kName << " d 1e" << e;
    }
  }
}
TEST(PolygonScale, FarAndNearLightsArePowerOfTwoMultiplesFp32) {
  FarAndNearLightsArePowerOfTwoMultiples<K32>();
}
TEST(PolygonScale, FarAndNearLightsArePowerOfTwoMultiplesFp64) {
  FarAndNearLightsArePowerOfTwoMultiples<K64>();
}

// A shading point at -(1, 0.5, 0.75) 2^e and a quad around (1.5, 0.5, 1.25) 2^e (dyadic: exact
// at every e). At e = 127 the fp32 world differences exceed FLT_MAX.
const double kP[3] = {-1, -0.5, -0.75};
const std::vector<double> kQuad = {1.125, 0.125, 1.25, 1.875, 0.125, 1.25,
                                   1.875, 0.875, 1.25, 1.125, 0.875, 1.25};

template <class K>
std::vector<float> ScaledRecord(const std::vector<double> &xyz, int e, bool two_sided) {
  std::vector<double> s;
  for (double x : xyz) s.push_back(std::ldexp(x, e));
  return Record(s, two_sided);
}

template <class K>
void OverflowedDifferencesAreReloaded() {
  for (bool framed : {false, true}) {
    const typename K::Frame f = framed ? Rotated<K>() : K::Identity();
    typename K::real3 v0[GLINT_POLYGON_MAX_VERTICES], v[GLINT_POLYGON_MAX_VERTICES];
    const std::vector<float> r0 = ScaledRecord<K>(kQuad, 0, false);
    const std::vector<float> r127 = ScaledRecord<K>(kQuad, 127, false);
    area_polygon_load_n(r0.data(), 4, framed, f, K::Make(kP[0], kP[1], kP[2]), v0);
    const typename K::real3 p127 =
        K::Make(std::ldexp(kP[0], 127), std::ldexp(kP[1], 127), std::ldexp(kP[2], 127));
    if (std::strcmp(K::kName, "fp32") == 0) {
      // The plain fp32 load overflows: the case at hand.
      area_polygon_load_raw(r127.data(), 4, framed, f, p127, v);
      ASSERT_FALSE(std::isfinite(v[1].x) && std::isfinite(v[1].y) && std::isfinite(v[1].z))
          << "the test must overflow the plain load";
    }
    area_polygon_load_n(r127.data(), 4, framed, f, p127, v);
    EXPECT_NE(PowerOfTwo<K>(v0, v, 4), -9999) << K::kName << " framed " << framed;
  }
}
TEST(PolygonScale, OverflowedDifferencesAreReloadedFp32) {
  OverflowedDifferencesAreReloaded<K32>();
}
TEST(PolygonScale, OverflowedDifferencesAreReloadedFp64) {
  OverflowedDifferencesAreReloaded<K64>();
}

// Only some vertices overflow, the overflowed ones first, under an explicit identity frame: the
// frame's zero components turn (Inf, y, z) into (Inf, NaN, NaN), and the largest-magnitude scan
// must keep that NaN past the later finite vertices (fmax(NaN, c) = c) for the lane to be
// reloaded (session 10 review: it was lost, and the light came out 0 or NaN).
template <class K>
void PartlyOverflowedLightsAreReloaded() {
  // x: 1.875 and 0.125 (times 2^e); at e = 127 the first two differences from the shading
  // point's -2^127 exceed FLT_MAX in fp32, the last two do not.
  const std::vector<double> quad = {1.875, 0.125, 0.25, 1.875, 0.875, 0.25,
                                    0.125, 0.875, 0.25, 0.125, 0.125, 0.25};
  const double p[3] = {-1, -0.5, -0.75};
  for (bool framed : {false, true}) {
    const typename K::Frame f = K::Identity();
    typename K::real3 v0[GLINT_POLYGON_MAX_VERTICES], v[GLINT_POLYGON_MAX_VERTICES];
    const std::vector<float> r0 = ScaledRecord<K>(quad, 0, false);
    const std::vector<float> r127 = ScaledRecord<K>(quad, 127, false);
    area_polygon_load_n(r0.data(), 4, framed, f, K::Make(p[0], p[1], p[2]), v0);
    const typename K::real3 p127 =
        K::Make(std::ldexp(p[0], 127), std::ldexp(p[1], 127), std::ldexp(p[2], 127));
    if (std::strcmp(K::kName, "fp32") == 0) {
      area_polygon_load_raw(r127.data(), 4, framed, f, p127, v);
      ASSERT_FALSE(std::isfinite(v[0].x)) << "the test must overflow the first vertex";
      ASSERT_TRUE(std::isfinite(v[3].x) && std::isfinite(v[3].y) && std::isfinite(v[3].z))
          << "and leave the last one finite";
    }
    area_polygon_load_n(r127.data(), 4, framed, f, p127, v);
    EXPECT_NE(PowerOfTwo<K>(v0, v, 4), -9999) << K::kName << " framed " << framed;
  }
}
TEST(PolygonScale, PartlyOverflowedLightsAreReloadedFp32) {
  PartlyOverflowedLightsAreReloaded<K32>();
}
TEST(PolygonScale, PartlyOverflowedLightsAreReloadedFp64) {
  PartlyOverflowedLightsAreReloaded<K64>();
}

template <class K>
typename K::Material Material() {
  typename K::Material m;
  m.ndf = GLINT_NDF_GGX;
  m.alpha_x = typename K::real(0.3);
  m.alpha_y = typename K::real(0.2);
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a = K::Make(0.9, 0.6, 0.3);
  m.fresnel.b = K::Make(0, 0, 0);
  return m;
}

// Every method, through area_shade_keyed with one key: the light at 2^e (a shading point of
// opposite sign, a frame: the fp32 overflow at e = 127) and at 10^e times a quad seen from the
// origin give the radiance of their copies at distance ~1 bit for bit.
template <class K>
void EveryMethodIsScaleInvariant() {
  const typename K::Material m = Material<K>();
  const float *table = glint::ltc_table::table(glint::ltc_table::Ndf::kGgx);
  const int methods[] = {GLINT_AREA_LTC,         GLINT_AREA_LECOCQ,    GLINT_AREA_LECOCQ_PEARSON,
                         GLINT_AREA_MONTE_CARLO, GLINT_AREA_REFERENCE, GLINT_AREA_AUTO};
  const int samples[] = {0, 0, 0, 16, 8, 50000};  // AUTO: the budget in millionths
  const double views[][3] = {{0, 0, 1}, {0.5, 0.1, 0.86}, {-0.6, 0.3, 0.74}, {0.9, -0.2, 0.38}};
  const std::vector<double> across = {2.5, -1, -0.5, 2.5, 1, -0.5, 2.5, 1, 1.5, 2.5, -1, 1.5};
  int lit = 0, compared = 0;
  for (int k = 0; k < 6; ++k) {
    for (const auto &w : views) {
      const double wl = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      const typename K::real3 wo = K::Make(w[0] / wl, w[1] / wl, w[2] / wl);
      for (bool framed : {false, true}) {
        const typename K::Frame f = framed ? Rotated<K>() : K::Identity();
        // Case 1: the overflow configuration, 2^127 against 2^0.
        const typename K::real3 p0 = K::Make(kP[0], kP[1], kP[2]);
        const typename K::real3 p127 =
            K::Make(std::ldexp(kP[0], 127), std::ldexp(kP[1], 127), std::ldexp(kP[2], 127));
        std::vector<float> r0 = ScaledRecord<K>(kQuad, 0, false),
                           r127 = ScaledRecord<K>(kQuad, 127, false);
        const typename K::real3 a = area_shade_keyed(m, table, methods[k], samples[k], wo, framed,
                                                     f, p0, r0.data(), 1, 77u);
        const typename K::real3 b = area_shade_keyed(m, table, methods[k], samples[k], wo, framed,
                                                     f, p127, r127.data(), 1, 77u);
        lit += a.x > 0;
        ++compared;
        EXPECT_TRUE(SameBits<K>(a.x, b.x) && SameBits<K>(a.y, b.y) && SameBits<K>(a.z, b.z))
            << K::kName << " method " << methods[k] << " framed " << framed << ": " << a.x << " vs "
            << b.x;
        // Case 2: 10^e times a two-sided quad across the horizon, from the origin. 3e-10,
        // 1e-9, 5e7 and 1.5e8 are lights the loader leaves alone (vertex lengths between 9e-10
        // and 4.7e8: the squared lengths sum to within [2^-60, 2^60]) but that MONTE_CARLO
        // normalised on its own when they were longer than 1e8 or shorter than 1e-8 (inexact
        // divisions: not bit-identical to the light at ~1).
        for (double d : {1e-25, 1e-20, 3e-10, 1e-9, 5e7, 1.5e8, 1e20, 1e30}) {
          const int e = int(std::lround(std::log2(d)));
          std::vector<double> far, near;
          for (double x : across) {
            far.push_back(double(float(x * d)));
            near.push_back(std::ldexp(far.back(), -e));
          }
          const std::vector<float> rf = Record(far, true), rn = Record(near, true);
          const typename K::real3 o = K::Make(0, 0, 0);
          const typename K::real3 x = area_shade_keyed(m, table, methods[k], samples[k], wo, framed,
                                                       f, o, rn.data(), 1, 78u);
          const typename K::real3 y = area_shade_keyed(m, table, methods[k], samples[k], wo, framed,
                                                       f, o, rf.data(), 1, 78u);
          lit += x.x > 0;
          ++compared;
          EXPECT_TRUE(std::isfinite(y.x) && y.x >= 0 && std::isfinite(y.y) && y.y >= 0 &&
                      std::isfinite(y.z) && y.z >= 0);
          EXPECT_TRUE(SameBits<K>(x.x, y.x) && SameBits<K>(x.y, y.y) && SameBits<K>(x.z, y.z))
              << K::kName << " method " << methods[k] << " framed " << framed << " d " << d << ": "
              << x.x << " vs " << y.x;
        }
      }
    }
  }
  EXPECT_GT(lit, compared / 2) << "the comparisons must see light";
}
TEST(PolygonScale, EveryMethodIsScaleInvariantFp32) {
  EveryMethodIsScaleInvariant<K32>();
}
TEST(PolygonScale, EveryMethodIsScaleInvariantFp64) {
  EveryMethodIsScaleInvariant<K64>();
}

}  // namespace
