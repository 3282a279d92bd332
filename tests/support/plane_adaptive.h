// An independent reference for polygon-light integrals, shared by tests/area/area_lights_test.cpp
// (where it is checked against a brute-force hemisphere integration) and bench/bench_area.cpp
// (its truth): nested globally adaptive Gauss-Kronrod (7-15) over the light's own plane. The
// polygon is clipped to the horizon in its plane (a 2D half-plane clip, not polygon.h's), every
// row y has exact x-limits from the convex outline, and the plane coordinates are mapped
// x = d tan(u), y = d tan(v) (d = the plane's distance) so that huge lights stay finite:
// dw = d dA / r^3 = (1 + tan^2 u + tan^2 v)^(-3/2) sec^2 u sec^2 v du dv. Breakpoints at every
// vertex row and graded ones around the mirror direction of wo (the lobe's peak, AddGradedCuts)
// let the adaptivity find lobes as narrow as alpha = 0.01. No Arvo map, no triangulation.
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace glint::test::plane {

struct Vec {
  double x, y, z;
};
inline Vec Add(Vec a, Vec b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline Vec Sub(Vec a, Vec b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline Vec Scale(Vec a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
inline Vec Cross(Vec a, Vec b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double Dot(Vec a, Vec b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline Vec Normalize(Vec a) {
  return Scale(a, 1.0 / std::sqrt(Dot(a, a)));
}

struct Segment {
  double a, b, value, error;
  bool operator<(const Segment &o) const { return error < o.error; }
};

template <typename F>
Segment Gk15(F &&f, double a, double b) {
  static const double xk[8] = {
      0.991455371120812639, 0.949107912342758525, 0.864864423359769073, 0.741531185599394440,
      0.586087235467691130, 0.405845151377397167, 0.207784955007898468, 0.0};
  static const double wk[8] = {0.022935322010529225, 0.063092092629978553, 0.104790010322250184,
                               0.140653259715525919, 0.169004726639267903, 0.190350578064785410,
                               0.204432940075298892, 0.209482141084727828};
  static const double wg[4] = {0.129484966168869693, 0.279705391489276668, 0.381830050505118945,
                               0.417959183673469388};
  const double c = 0.5 * (a + b), h = 0.5 * (b - a);
  double fc = f(c), k = fc * wk[7], g = fc * wg[3];
  for (int i = 0; i < 7; ++i) {
    double s = f(c - h * xk[i]) + f(c + h * xk[i]);
    k += wk[i] * s;
    if (i % 2 == 1) g += wg[i / 2] * s;
  }
  return {a, b, k * h, std::fabs((k - g) * h)};
}

// int over [cuts.front(), cuts.back()] (sorted breakpoints) to max(abs_tol, rel_tol |I|).
template <typename F>
double Adaptive(F &&f, const std::vector<double> &cuts, double rel_tol, double abs_tol,
                int max_segments = 4000) {
  std::vector<Segment> heap;
  double value = 0, error = 0;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    if (!(cuts[i + 1] > cuts[i])) continue;
    heap.push_back(Gk15(f, cuts[i], cuts[i + 1]));
    value += heap.back().value;
    error += heap.back().error;
  }
  std::make_heap(heap.begin(), heap.end());
  while (!heap.empty() && error > std::max(abs_tol, rel_tol * std::fabs(value)) &&
         int(heap.size()) < max_segments) {
    std::pop_heap(heap.begin(), heap.end());
    Segment s = heap.back();
    heap.pop_back();
    double m = 0.5 * (s.a + s.b);
    Segment l = Gk15(f, s.a, m), r = Gk15(f, m, s.b);
    value += l.value + r.value - s.value;
    error += l.error + r.error - s.error;
    for (const Segment &t : {l, r}) {
      heap.push_back(t);
      std::push_heap(heap.begin(), heap.end());
    }
  }
  return value;
}

// Breakpoints at `peak` and at peak +- 2^-k (k = 0..30) inside (lo, hi): Gauss-Kronrod nodes
// never sit on an interval's end, so a lobe much narrower than the interval next to a lone
// breakpoint (Beckmann, alpha = 0.01, grazing: ~1e-4 rad) would be missed entirely (a Gaussian
// has no tail for the error estimate to see); geometric grading puts nodes at every scale.
inline void AddGradedCuts(double peak, double lo, double hi, std::vector<double> *cuts) {
  if (!(peak > lo && peak < hi)) return;
  cuts->push_back(peak);
  for (int k = 0; k <= 30; ++k) {
    const double d = std::ldexp(1.0, -k);
    if (peak - d > lo) cuts->push_back(peak - d);
    if (peak + d < hi) cuts->push_back(peak + d);
  }
}

// int_P f_cos(wi, wo) dwi over the polygon (vertices relative to the shading point, local frame,
// either winding) clipped to the upper hemisphere; f_cos(Vec wi, Vec wo) -> double.
template <typename FCos>
double PlaneAdaptive(FCos &&f_cos, Vec wo_in, const std::vector<Vec> &poly, double rel_tol = 1e-8) {
  const Vec wo = Normalize(wo_in);
  Vec nn = {0, 0, 0};
  for (size_t i = 0; i < poly.size(); ++i)
    nn = Add(nn, Cross(poly[i], poly[(i + 1) % poly.size()]));
  nn = Normalize(nn);
  double d = Dot(nn, poly[0]);
  if (d < 0) {
    nn = Scale(nn, -1);
    d = -d;
  }
  const Vec c0 = Scale(nn, d);
  const Vec e1 = Normalize(Sub(poly[1], poly[0])), e2 = Cross(nn, e1);
  // 2D outline, clipped to the horizon half-plane z(x, y) = c0.z + x e1.z + y e2.z >= 0.
  std::vector<std::pair<double, double>> in, q;
  for (Vec p : poly) in.push_back({Dot(Sub(p, c0), e1), Dot(Sub(p, c0), e2)});
  auto z = [&](std::pair<double, double> p) { return c0.z + p.first * e1.z + p.second * e2.z; };
  for (size_t i = 0; i < in.size(); ++i) {
    auto a = in[i], b = in[(i + 1) % in.size()];
    double za = z(a), zb = z(b);
    if (za >= 0) q.push_back(a);
    if ((za >= 0) != (zb >= 0)) {
      double t = za / (za - zb);
      q.push_back({a.first + t * (b.first - a.first), a.second + t * (b.second - a.second)});
    }
  }
  if (q.size() < 3) return 0;
  // Peak of the lobe: the mirror direction of wo, where it meets the plane.
  const Vec mirror = {-wo.x, -wo.y, wo.z};
  const double md = Dot(mirror, nn);
  double up = NAN, vp = NAN;
  if (md > 1e-12) {
    Vec hit = Sub(Scale(mirror, d / md), c0);
    up = std::atan(Dot(hit, e1) / d);
    vp = std::atan(Dot(hit, e2) / d);
  }
  std::vector<double> vcuts;
  for (auto p : q) vcuts.push_back(std::atan(p.second / d));
  std::sort(vcuts.begin(), vcuts.end());
  if (!std::isnan(vp)) AddGradedCuts(vp, vcuts.front(), vcuts.back(), &vcuts);
  std::sort(vcuts.begin(), vcuts.end());
  auto row = [&](double v) {
    const double tv = std::tan(v), y = d * tv;
    double xl = INFINITY, xr = -INFINITY;
    for (size_t i = 0; i < q.size(); ++i) {
      auto a = q[i], b = q[(i + 1) % q.size()];
      double lo = std::min(a.second, b.second), hi = std::max(a.second, b.second);
      if (y < lo || y > hi || hi == lo) continue;
      double x = a.first + (y - a.second) * (b.first - a.first) / (b.second - a.second);
      xl = std::min(xl, x);
      xr = std::max(xr, x);
    }
    if (!(xr > xl)) return 0.0;
    std::vector<double> ucuts = {std::atan(xl / d), std::atan(xr / d)};
    AddGradedCuts(up, ucuts[0], ucuts[1], &ucuts);
    std::sort(ucuts.begin(), ucuts.end());
    auto g = [&](double u) {
      const double tu = std::tan(u), s = 1 + tu * tu + tv * tv;
      Vec wi = Normalize(Add(c0, Add(Scale(e1, d * tu), Scale(e2, y))));
      return f_cos(wi, wo) * (1 + tu * tu) * (1 + tv * tv) / (s * std::sqrt(s));
    };
    return Adaptive(g, ucuts, 0.1 * rel_tol, 1e-15);
  };
  return Adaptive(row, vcuts, rel_tol, 1e-13);
}

}  // namespace glint::test::plane
