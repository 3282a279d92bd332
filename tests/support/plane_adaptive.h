// An independent reference for polygon-light integrals, shared by tests/area/area_lights_test.cpp
// (where it is checked against a brute-force hemisphere integration) and bench/bench_area.cpp
// (its truth): nested globally adaptive Gauss-Kronrod (7-15) over the light's own plane. The
// polygon is clipped to the horizon in its plane (a 2D half-plane clip, not polygon.h's), every
// row y has exact x-limits from the convex outline, and the plane coordinates are mapped
// x = d tan(u), y = d tan(v) (d = the plane's distance) so that huge lights stay finite:
// dw = d dA / r^3 = (1 + tan^2 u + tan^2 v)^(-3/2) sec^2 u sec^2 v du dv. Breakpoints at every
// vertex row and graded ones around the mirror direction of wo (the lobe's peak, AddGradedCuts)
// and around the polygon's point where the lobe is largest, per row and across rows (AddLobeCuts:
// the peak itself when inside, a point of the boundary when the peak lies outside) let the
// adaptivity find lobes as narrow as alpha = 0.01. No Arvo map, no triangulation.
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

// Graded breakpoints from an end of [lo, hi] into it (`at` = lo or hi): where the lobe's peak
// lies outside the region, the part inside is largest at the region's boundary (AddLobeCuts).
inline void AddOneSidedCuts(double at, double lo, double hi, std::vector<double> *cuts) {
  const double dir = at <= lo ? 1.0 : -1.0;
  for (int k = 0; k <= 30; ++k) {
    const double c = at + dir * std::ldexp(hi - lo, -k);
    if (c > lo && c < hi) cuts->push_back(c);
  }
}

// The argmax over [lo, hi] of a smooth proxy `hz` of the lobe (h.z, h = normalize(wi + wo): the
// microfacet lobe decreases with the half vector's angle from the normal), by a scan of 33 points
// and golden-section refinement around the best; then graded breakpoints there (two-sided
// inside, one-sided at an end). Needed where the mirror direction (the peak, AddGradedCuts) lies
// outside the region but the lobe reaches into it: at grazing views a narrow lobe is a sliver of
// width ~alpha (wi.z + wo.z) that rises from the mirror direction, and where a light's edge cuts
// it a row sees a spike of width ~1e-4 rad at its end, which Gauss-Kronrod nodes (none closer to
// an end than 0.4% of the interval) never sample: the adaptive estimate then reports a converged
// ~0. Beckmann alpha 0.013, wo.z 1e-4 (AUTO training set MakeConfigs(1, 1000, 8, BECKMANN)[634]
// view 7) gave 1.9e-25 for a true 0.607 (BRDF-sampling Monte Carlo, tests/area/area_truth_test).
// Returns the argmax.
template <typename Hz>
double AddLobeCuts(Hz &&hz, double lo, double hi, std::vector<double> *cuts) {
  if (!(hi > lo)) return lo;
  constexpr int kScan = 32;
  int best = 0;
  double best_v = -INFINITY;
  for (int i = 0; i <= kScan; ++i) {
    const double v = hz(lo + (hi - lo) * i / kScan);
    if (v > best_v) {
      best_v = v;
      best = i;
    }
  }
  double a = lo + (hi - lo) * std::max(best - 1, 0) / kScan;
  double b = lo + (hi - lo) * std::min(best + 1, kScan) / kScan;
  const double g = 0.5 * (std::sqrt(5.0) - 1);
  double x1 = b - g * (b - a), x2 = a + g * (b - a), f1 = hz(x1), f2 = hz(x2);
  for (int it = 0; it < 60 && b - a > 1e-15 * (hi - lo); ++it) {
    if (f1 < f2) {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + g * (b - a);
      f2 = hz(x2);
    } else {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - g * (b - a);
      f1 = hz(x1);
    }
  }
  double x = 0.5 * (a + b);
  // An end that beats the refined interior point is the argmax (the peak is outside).
  if (hz(lo) >= hz(x)) x = lo;
  if (hz(hi) > hz(x)) x = hi;
  if (x <= lo || x >= hi)
    AddOneSidedCuts(x <= lo ? lo : hi, lo, hi, cuts);
  else
    AddGradedCuts(x, lo, hi, cuts);
  return x;
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
  // The row's u range; xr > xl when the row crosses the polygon.
  auto row_range = [&](double v, double *ul, double *ur) {
    const double y = d * std::tan(v);
    double xl = INFINITY, xr = -INFINITY;
    for (size_t i = 0; i < q.size(); ++i) {
      auto a = q[i], b = q[(i + 1) % q.size()];
      double lo = std::min(a.second, b.second), hi = std::max(a.second, b.second);
      if (y < lo || y > hi || hi == lo) continue;
      double x = a.first + (y - a.second) * (b.first - a.first) / (b.second - a.second);
      xl = std::min(xl, x);
      xr = std::max(xr, x);
    }
    *ul = std::atan(xl / d);
    *ur = std::atan(xr / d);
    return xr > xl;
  };
  auto direction = [&](double u, double v) {
    return Normalize(Add(c0, Add(Scale(e1, d * std::tan(u)), Scale(e2, d * std::tan(v)))));
  };
  auto half_z = [&](Vec wi) {  // the lobe proxy of AddLobeCuts
    const Vec h = Add(wi, wo);
    const double l = std::sqrt(Dot(h, h));
    return l > 0 ? h.z / l : -1.0;
  };
  // The lobe's largest h.z along a row (an end when its peak is outside the row).
  auto row_max = [&](double v, std::vector<double> *ucuts) {
    double ul, ur;
    if (!row_range(v, &ul, &ur)) return -1.0;
    std::vector<double> scratch;
    const double u = AddLobeCuts([&](double x) { return half_z(direction(x, v)); }, ul, ur,
                                 ucuts ? ucuts : &scratch);
    return half_z(direction(u, v));
  };
  const double vlo = vcuts.front(), vhi = vcuts.back();
  if (!std::isnan(vp)) AddGradedCuts(vp, vlo, vhi, &vcuts);
  // And around the row where the lobe is largest inside the polygon (the same row as vp when
  // the peak is inside; the polygon's point nearest the lobe when it is outside).
  AddLobeCuts([&](double v) { return row_max(v, nullptr); }, vlo, vhi, &vcuts);
  std::sort(vcuts.begin(), vcuts.end());
  auto row = [&](double v) {
    const double tv = std::tan(v), y = d * tv;
    double ul, ur;
    if (!row_range(v, &ul, &ur)) return 0.0;
    std::vector<double> ucuts = {ul, ur};
    AddGradedCuts(up, ucuts[0], ucuts[1], &ucuts);
    row_max(v, &ucuts);
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
