// What a validated request needs from a kernel: the specialisation (which
// becomes OpenCL build options) plus the packed material and light blocks in
// the layouts of kernels/smooth_brdf.h and kernels/lights.h.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"

namespace glint {

// Everything that changes the compiled kernel. Equal specs share a program.
struct KernelSpec {
  int model = 1;    // 1 smooth (models/smooth/smooth.cl), 2 binomial (models/binomial/binomial.cl)
  int ndf = 1;      // GLINT_NDF_* (kernels/ndf.h)
  int fresnel = 1;  // GLINT_FRESNEL_* (kernels/fresnel.h)
  bool probe = false;
  bool has_frame = false;
  bool has_directional = false;
  bool has_point = false;
  // Request has polygon lights: they run in a separate kernel (models/smooth/smooth_area.cl,
  // one query per work-item) and do not change the smooth kernel's build options.
  bool has_polygon = false;
  bool fp64 = false;

  bool operator==(const KernelSpec &) const = default;
  // "-DGLINT_NDF=1 ..." for clBuildProgram.
  std::string BuildOptions() const;
  // Short human-readable form for logs: "ggx/schlick/probe/fp32".
  std::string Describe() const;
};

struct EvalPlan {
  KernelSpec spec;
  std::array<float, 8> material{};  // GLINT_MATERIAL_FLOATS
  std::vector<float> directional;   // GLINT_LIGHT_FLOATS per light
  std::vector<float> point;
  uint32_t n_directional = 0;
  uint32_t n_point = 0;
  std::vector<float> polygon;  // GLINT_POLYGON_FLOATS per light (kernels/area/area_lights.h)
  uint32_t n_polygon = 0;
  int area_method = 1;    // GLINT_AREA_* (= glint.v1.AreaMethod, UNSPECIFIED -> LTC)
  int area_samples = 64;  // REFERENCE nodes per dimension per triangle; MONTE_CARLO samples
  // models/binomial/binomial_count.h parameter block (model 2 only).
  std::array<float, 8> binomial{};
  // The request seed, as the two 32-bit halves the kernels hash (kernels/rng.h).
  uint32_t seed_lo = 0, seed_hi = 0;
};

// The LTC table (64 x 64 x 8 floats, tools/ltc/README.md) for a GLINT_NDF_* value.
const float *LtcTable(int ndf);
constexpr size_t kLtcTableFloats = 64 * 64 * 8;

// Builds the plan of a request that has passed ValidateRequest. `queries` may
// differ from request.queries (stream chunks reuse the first chunk's settings).
EvalPlan MakeEvalPlan(const glint::v1::EvaluateRequest &settings,
                      const glint::v1::QueryBatch &queries);

}  // namespace glint
