// What the Kemppinen kernel tests share before the kernels are included: the test material
// (Glinty, read by kemppinen_api.inc, GLINT_TEST_KERNEL_EXTRA) and a double vector. Included by
// kemppinen_test.cpp, kemppinen_neighborhood_test.cpp and kemppinen_polygon_test.cpp ahead of
// tests/support/kernels_both_precisions.h.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace glint::test {
struct V3 {
  double x, y, z;
};
inline V3 Normalize(V3 a) {
  double l = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
  return {a.x / l, a.y / l, a.z / l};
}
// A material and its kemppinen block.
struct Glinty {
  int ndf = 1;  // GLINT_NDF_GGX
  double ax = 0.3, ay = 0.3;
  double density = 1e6, micro = 0.02, filter = 0.7, aniso = 1.0;
  int neighbors = 4;
  unsigned seed_lo = 11, seed_hi = 0;
  std::vector<double> colors;  // flat RGB triples, 0 to 8 colours
  int neighborhood = 0;        // GLINT_KEMPPINEN_NEIGHBORHOOD_*
};
// Footprint diag(j, j) (axis aligned) such that the level lambda = log2(8 sigma_max sqrt(K_P))
// (kemppinen_ndf.h kemppinen_footprint) is `lambda`: sigma_max = f j max(a, 1/a).
inline std::array<double, 4> FootprintForLevel(const Glinty &g, double lambda) {
  double sigma = std::exp2(lambda) / (8.0 * std::sqrt(g.density));
  double j = sigma / (g.filter * std::max(g.aniso, 1.0 / g.aniso));
  return {j, 0.0, 0.0, j};
}
}  // namespace glint::test
