// The normal-map generators (tools/normal_map, `glint normal-map`): deterministic from the seed,
// unit normals above the surface, and each family's defining statistic against its definition.
#include "tools/normal_map/normal_map_gen.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <tuple>

namespace glint {
namespace {

DecodedNormalMap Make(const std::string &kind, uint32_t size, uint64_t seed, double roughness) {
  DecodedNormalMap m;
  std::string error;
  EXPECT_TRUE(normal_map_gen::Generate({kind, size, seed, roughness}, &m, &error)) << error;
  return m;
}

TEST(NormalMapGen, DeterministicUnitAndAboveTheSurface) {
  for (const char *kind : {"bumpy", "flakes", "brushed", "scratches"}) {
    const DecodedNormalMap a = Make(kind, 64, 7, 0.3), b = Make(kind, 64, 7, 0.3),
                           c = Make(kind, 64, 8, 0.3);
    ASSERT_EQ(a.xyz.size(), 64u * 64u * 3u) << kind;
    EXPECT_EQ(NormalMapDigest(a), NormalMapDigest(b)) << kind;
    EXPECT_NE(NormalMapDigest(a), NormalMapDigest(c)) << kind;
    for (size_t t = 0; t < 64 * 64; ++t) {
      const float *n = &a.xyz[3 * t];
      ASSERT_NEAR(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1.0f, 1e-5f) << kind;
      ASSERT_GT(n[2], 0.0f) << kind;
    }
  }
  DecodedNormalMap m;
  std::string error;
  EXPECT_FALSE(normal_map_gen::Generate({"bumpy", 100, 1, 0.2}, &m, &error));
  EXPECT_NE(error.find("power of two"), std::string::npos) << error;
  EXPECT_FALSE(normal_map_gen::Generate({"waves", 64, 1, 0.2}, &m, &error));
  EXPECT_NE(error.find("not one of"), std::string::npos) << error;
}

// The heightfield families are scaled to the requested RMS slope (x / z, y / z of the normal).
TEST(NormalMapGen, HeightfieldsHaveTheRequestedRmsSlopeAndBrushedIsAnisotropic) {
  for (const char *kind : {"bumpy", "brushed", "scratches"}) {
    const DecodedNormalMap m = Make(kind, 128, 3, 0.25);
    double sx2 = 0, sy2 = 0;
    for (size_t t = 0; t < 128 * 128; ++t) {
      const float *n = &m.xyz[3 * t];
      sx2 += double(n[0] / n[2]) * (n[0] / n[2]);
      sy2 += double(n[1] / n[2]) * (n[1] / n[2]);
    }
    const double rms = std::sqrt((sx2 + sy2) / (128 * 128));
    EXPECT_NEAR(rms, 0.25, 1e-4) << kind;  // float rounding of the stored normals only
    if (std::string(kind) == "brushed") {
      // Long along u, short along v: the height changes mostly along v, so slopes are in y.
      EXPECT_GT(sy2, 20 * sx2);
    }
  }
}

// Flakes: one normal per Voronoi cell; the cells' slopes follow Beckmann(alpha), whose
// E[tan^2 theta] = alpha^2 (slopes are Gaussian with variance alpha^2 / 2 per axis). The sample
// mean over K cells has standard error alpha^2 / sqrt(K) (tan^2 theta ~ alpha^2 Exp(1)).
TEST(NormalMapGen, FlakesAreConstantCellsWithBeckmannSlopes) {
  const double alpha = 0.3;
  const DecodedNormalMap m = Make("flakes", 512, 11, alpha);
  std::map<std::tuple<float, float, float>, int> cells;
  for (size_t t = 0; t < 512 * 512; ++t)
    cells[{m.xyz[3 * t], m.xyz[3 * t + 1], m.xyz[3 * t + 2]}]++;
  const double K = double(cells.size());
  EXPECT_GT(K, 500);             // many flakes ...
  EXPECT_LT(K, 512 * 512 / 20);  // ... each covering many texels
  double mean = 0;
  for (const auto &[n, count] : cells) {
    const double tx = std::get<0>(n) / std::get<2>(n), ty = std::get<1>(n) / std::get<2>(n);
    mean += (tx * tx + ty * ty) / K;
  }
  EXPECT_NEAR(mean, alpha * alpha, 4 * alpha * alpha / std::sqrt(K));
}

}  // namespace
}  // namespace glint
