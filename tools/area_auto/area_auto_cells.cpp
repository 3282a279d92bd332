// Cells() in its own translation unit: the kernel headers in float (the fp32 kernels' binning),
// apart from area_auto_data.cpp's double BRDF.
#include <algorithm>
#include <cassert>
#include <cmath>

#include "tools/area_auto/area_auto_data.h"

namespace kf {
#define GLINT_USE_DOUBLE 0
#include "kernels/area/area_auto.h"
#undef GLINT_USE_DOUBLE
}  // namespace kf

namespace glint::area_auto {

namespace {

// The light and views as the fp32 kernel sees them: float vertices, the float wo normalised
// (kernels/query.h shading_point), alpha = sqrt(alpha_x alpha_y) in float.
template <typename F>
void ForEachView(const Config &c, F &&f) {
  kf::real3 v[GLINT_POLYGON_MAX_VERTICES];
  int n = 0;
  for (const V3 &p : c.polygon) v[n++] = kf::make_real3(float(p[0]), float(p[1]), float(p[2]));
  const float alpha = float(c.alpha);
  for (const V3 &w : c.wo) {
    kf::real3 wo = kf::r3_normalize(kf::make_real3(float(w[0]), float(w[1]), float(w[2])));
    f(std::sqrt(alpha * alpha), wo, v, n);
  }
}

}  // namespace

std::vector<int> Cells(const Config &c) {
  std::vector<int> cells;
  ForEachView(c, [&](float alpha, kf::real3 wo, const kf::real3 *v, int n) {
    cells.push_back(kf::area_auto_cell(alpha, wo, v, n));
  });
  return cells;
}

std::vector<Choice> Choices(const Config &c, float budget) {
  std::vector<Choice> out;
  ForEachView(c, [&](float alpha, kf::real3 wo, const kf::real3 *v, int n) {
    // As the kernel: the budget through its millionths (server/eval_plan.cpp).
    const float b = float(std::max(1.0, std::round(double(budget) * 1e6))) * 1e-6f;
    kf::AreaChoice a = kf::area_auto_choose(c.ndf, alpha, wo, v, n, b);
    out.push_back({a.method, a.samples, a.predicted});
  });
  return out;
}

}  // namespace glint::area_auto
