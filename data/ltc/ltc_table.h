// Host-side access to the checked-in LTC tables data/ltc/ltc_{ggx,beckmann}.inc: grid entries,
// the LTC density and the Fresnel recombination. Header-only and independent of
// the fitting code (tools/ltc/ltc_fit.h), so renderers and tests can use it without linking it.
//
// Layout and conventions are documented in the .inc headers and in tools/ltc/README.md:
// entry (a, t) = 8 floats at (t * 64 + a) * 8; a -> alpha = max((a/63)^2, 1e-4); t -> cos(theta_o)
// = max(1 - (t/63)^2, 1e-3); [M^-1 (0,0), (0,2), (2,0), (2,2) with M^-1[1][1] = 1, magnitude,
// fresnel, D_PR, D_H]. Directions are in the frame where the view is wo = (sin, 0, cos).
#ifndef GLINT_TOOLS_LTC_LTC_TABLE_H
#define GLINT_TOOLS_LTC_LTC_TABLE_H

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace glint::ltc_table {

namespace data {
// One definition across translation units (C++17 inline variables) instead of the .inc's
// default `static const`.
#define GLINT_LTC_STORAGE inline constexpr
#include "data/ltc/ltc_beckmann.inc"
#include "data/ltc/ltc_ggx.inc"
#undef GLINT_LTC_STORAGE
}  // namespace data

inline constexpr int kSize = GLINT_LTC_SIZE;
inline constexpr int kEntryFloats = GLINT_LTC_ENTRY_FLOATS;
static_assert(sizeof(data::glint_ltc_ggx) == sizeof(float) * kSize * kSize * kEntryFloats);
static_assert(sizeof(data::glint_ltc_beckmann) == sizeof(data::glint_ltc_ggx));

// Same values as GLINT_NDF_GGX / GLINT_NDF_BECKMANN (kernels/ndf.h).
enum class Ndf { kGgx = 1, kBeckmann = 2 };

struct Entry {
  std::array<double, 4> inv{};  // M^-1 = [[inv0, 0, inv1], [0, 1, 0], [inv2, 0, inv3]]
  double magnitude = 0;         // int f cos_i dw_i with F = 1 (FGD)
  double fresnel = 0;           // int f cos_i (1 - wo.h)^5 dw_i
  double d_pr = 0;              // Kneiphof & Klein 2024 Eq. 19
  double d_h = 0;               // total microfacet area int_H D dw_h
};

inline const float *table(Ndf ndf) {
  return ndf == Ndf::kBeckmann ? data::glint_ltc_beckmann : data::glint_ltc_ggx;
}

// The grid's parameterisation (identical to tools/ltc/ltc_fit.h grid_alpha / grid_cos_theta).
inline double grid_alpha(int a) {
  double r = a / double(kSize - 1);
  return std::max(r * r, 1e-4);
}
inline double grid_cos_theta(int t) {
  double x = t / double(kSize - 1);
  return std::max(1.0 - x * x, 1e-3);
}

inline Entry entry(Ndf ndf, int a, int t) {
  const float *e = table(ndf) + (t * kSize + a) * kEntryFloats;
  return Entry{{e[0], e[1], e[2], e[3]}, e[4], e[5], e[6], e[7]};
}

// Interpolated lookups are the kernels' (kernels/area/ltc_lookup.h area_ltc_lookup): one
// bilinear lookup for the device, the host path and the tests.

// LTC density at unit direction w (HDHN16 Eq. 3): with o = M^-1 w,
//   D(w) = D_o(o / |o|) |det M^-1| / |o|^3 = max(0, o.z) |det M^-1| / (pi |o|^4).
// Integrates to 1 over the sphere; the part below the horizon is light the LTC "leaks".
inline double density(const Entry &e, const std::array<double, 3> &w) {
  const auto &m = e.inv;
  double ox = m[0] * w[0] + m[1] * w[2], oy = w[1], oz = m[2] * w[0] + m[3] * w[2];
  double det = std::fabs(m[0] * m[3] - m[1] * m[2]);
  double l2 = ox * ox + oy * oy + oz * oz;
  return oz > 0 ? oz * det / (std::numbers::pi * l2 * l2) : 0.0;
}

// The forward matrix M (up to scale) as rows, for sampling: w = normalize(M o) with o
// cosine-distributed. M = (M^-1)^-1 acts on (x, z) as the inverse 2x2 block and leaves y.
inline std::array<double, 4> forward(const Entry &e) {
  const auto &m = e.inv;
  double det = m[0] * m[3] - m[1] * m[2];
  return {m[3] / det, -m[1] / det, -m[2] / det, m[0] / det};
}

// Directional albedo with Schlick's F = f0 + (1 - f0)(1 - wo.h)^5 (Schlick 1994 Eq. 15):
//   int f cos F = f0 * magnitude + (1 - f0) * fresnel.
// Shading a polygonal light of radiance L: L * fresnel_albedo * int_P density dw.
inline double fresnel_albedo(const Entry &e, double f0) {
  return f0 * e.magnitude + (1.0 - f0) * e.fresnel;
}

}  // namespace glint::ltc_table

#endif  // GLINT_TOOLS_LTC_LTC_TABLE_H
