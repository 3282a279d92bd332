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
  int ndf = 1;      // GLINT_NDF_* (kernels/ndf.h)
  int fresnel = 1;  // GLINT_FRESNEL_* (kernels/fresnel.h)
  bool probe = false;
  bool has_frame = false;
  bool has_directional = false;
  bool has_point = false;
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
};

// Builds the plan of a request that has passed ValidateRequest. `queries` may
// differ from request.queries (stream chunks reuse the first chunk's settings).
EvalPlan MakeEvalPlan(const glint::v1::EvaluateRequest &settings,
                      const glint::v1::QueryBatch &queries);

}  // namespace glint
