// What the Kemppinen kernel tests share before the kernels are included: the test material
// (Glinty, read by kemppinen_api.inc, GLINT_TEST_KERNEL_EXTRA) and a double vector. Included by
// kemppinen_test.cpp, kemppinen_neighborhood_test.cpp and kemppinen_polygon_test.cpp ahead of
// tests/support/kernels_both_precisions.h.
#pragma once

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
}  // namespace glint::test
