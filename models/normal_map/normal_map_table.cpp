#include "models/normal_map/normal_map_table.h"

#include <algorithm>
#include <cmath>

#include "models/normal_map/normal_map_params.h"

namespace glint {
namespace {

// Catmull-Rom weights for the 4 samples around fraction f in [0, 1).
void CatmullRomWeights(double f, double w[4]) {
  const double f2 = f * f, f3 = f2 * f;
  w[0] = 0.5 * (-f3 + 2.0 * f2 - f);
  w[1] = 0.5 * (3.0 * f3 - 5.0 * f2 + 2.0);
  w[2] = 0.5 * (-3.0 * f3 + 4.0 * f2 + f);
  w[3] = 0.5 * (f3 - f2);
}

// Sec. 5: "subdivide texels into 4 x 4 sub-texels using bicubic Catmull-Rom interpolation" of
// (s, t), periodic like the map. Sub-vertex I sits at uv (I + 0.5) / (4 W), i.e. at the input
// vertex coordinate (I + 0.5) / 4 - 0.5. The result is pulled back inside the unit disk
// (Catmull-Rom overshoots): the model's (s, t) must name a normal.
std::vector<float> Subdivide4(uint32_t w, uint32_t h, const std::vector<float> &st) {
  const uint32_t W = 4 * w, H = 4 * h;
  std::vector<float> out(size_t(W) * H * 2);
  auto at = [&](int64_t i, int64_t j, int c) {
    const int64_t ii = ((i % w) + w) % w, jj = ((j % h) + h) % h;
    return double(st[(size_t(jj) * w + size_t(ii)) * 2 + size_t(c)]);
  };
  for (uint32_t J = 0; J < H; ++J) {
    const double y = (J + 0.5) / 4.0 - 0.5;
    const double jy = std::floor(y);
    double wy[4];
    CatmullRomWeights(y - jy, wy);
    for (uint32_t I = 0; I < W; ++I) {
      const double x = (I + 0.5) / 4.0 - 0.5;
      const double ix = std::floor(x);
      double wx[4];
      CatmullRomWeights(x - ix, wx);
      double v[2] = {0.0, 0.0};
      for (int c = 0; c < 2; ++c)
        for (int b = 0; b < 4; ++b)
          for (int a = 0; a < 4; ++a)
            v[c] += wx[a] * wy[b] * at(int64_t(ix) - 1 + a, int64_t(jy) - 1 + b, c);
      const double r = std::sqrt(v[0] * v[0] + v[1] * v[1]);
      const double rmax = 0.9999;
      const double scale = r > rmax ? rmax / r : 1.0;
      out[(size_t(J) * W + I) * 2] = float(v[0] * scale);
      out[(size_t(J) * W + I) * 2 + 1] = float(v[1] * scale);
    }
  }
  return out;
}

}  // namespace

int NormalMapLevels(uint32_t width, uint32_t height) {
  const uint32_t side = std::max(width, height);
  int levels = 1;
  while ((uint64_t{1} << (levels - 1)) < side) ++levels;
  return levels;
}

std::vector<float> BuildNormalMapTable(uint32_t width, uint32_t height,
                                       const std::vector<float> &st_in, int subdivision) {
  const std::vector<float> sub = subdivision == 4 ? Subdivide4(width, height, st_in) : st_in;
  const uint32_t W = subdivision == 4 ? 4 * width : width;
  const uint32_t H = subdivision == 4 ? 4 * height : height;
  const int levels = NormalMapLevels(W, H);
  size_t tree = 0;
  for (int k = 1; k < levels; ++k)
    tree += size_t((W + (1u << k) - 1) >> k) * ((H + (1u << k) - 1) >> k) * 4;
  std::vector<float> t(GLINT_NM_HEADER_FLOATS + size_t(W) * H * 2 + tree, 0.0f);
  t[0] = float(W);
  t[1] = float(H);
  t[2] = float(levels);
  t[3] = float(subdivision);
  std::copy(sub.begin(), sub.end(), t.begin() + GLINT_NM_HEADER_FLOATS);
  const float *v = t.data() + GLINT_NM_HEADER_FLOATS;
  size_t offset = GLINT_NM_HEADER_FLOATS + size_t(W) * H * 2;
  size_t prev = 0;  // offset of level k - 1 (k >= 2)
  for (int k = 1; k < levels; ++k) {
    const uint32_t nw = (W + (1u << k) - 1) >> k, nh = (H + (1u << k) - 1) >> k;
    const uint32_t pw = (W + (1u << (k - 1)) - 1) >> (k - 1);
    const uint32_t ph = (H + (1u << (k - 1)) - 1) >> (k - 1);
    for (uint32_t y = 0; y < nh; ++y) {
      for (uint32_t x = 0; x < nw; ++x) {
        float b[4] = {INFINITY, -INFINITY, INFINITY, -INFINITY};
        if (k == 1) {
          // Cells 2x, 2x + 1 (clipped) and their vertices up to 2x + 2 (periodic).
          const uint32_t cx1 = std::min(2 * x + 2, W), cy1 = std::min(2 * y + 2, H);
          for (uint32_t j = 2 * y; j <= cy1; ++j)
            for (uint32_t i = 2 * x; i <= cx1; ++i) {
              const float *p = v + (size_t(j % H) * W + (i % W)) * 2;
              b[0] = std::min(b[0], p[0]);
              b[1] = std::max(b[1], p[0]);
              b[2] = std::min(b[2], p[1]);
              b[3] = std::max(b[3], p[1]);
            }
        } else {
          for (uint32_t cy = 2 * y; cy < std::min(2 * y + 2, ph); ++cy)
            for (uint32_t cx = 2 * x; cx < std::min(2 * x + 2, pw); ++cx) {
              const float *c = t.data() + prev + (size_t(cy) * pw + cx) * 4;
              b[0] = std::min(b[0], c[0]);
              b[1] = std::max(b[1], c[1]);
              b[2] = std::min(b[2], c[2]);
              b[3] = std::max(b[3], c[3]);
            }
        }
        std::copy(b, b + 4, t.begin() + offset + (size_t(y) * nw + x) * 4);
      }
    }
    prev = offset;
    offset += size_t(nw) * nh * 4;
  }
  return t;
}

}  // namespace glint
