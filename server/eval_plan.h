// What a validated request needs from a kernel: the specialisation (which
// becomes OpenCL build options) plus the packed material, model parameter and
// light blocks in the layouts of kernels/layout.h.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "kernels/layout.h"
#include "server/status.h"

namespace glint {

// Everything that changes the compiled kernel. Equal specs share a program.
struct KernelSpec {
  int model = glint::v1::SMOOTH;  // glint.v1.Model (the model table, server/model_table.h)
  int ndf = 1;                    // GLINT_NDF_* (kernels/layout.h)
  int fresnel = 1;                // GLINT_FRESNEL_*
  bool probe = false;
  bool has_frame = false;
  bool has_directional = false;
  bool has_point = false;
  // Request has polygon lights: decides which of a model's passes run (the smooth model's
  // polygon pass, models/smooth/smooth_area.cl); not a build option.
  bool has_polygon = false;
  bool fp64 = false;
  // Sample only (server/sample.cpp): the queries carry uv (kernels/kernel_args.h sample_uv). A
  // build option only when set, so Evaluate's programs and their cache keys are unchanged.
  bool sample_uv = false;
  // A program for one area method only (GLINT_AREA_ONLY, kernels/kernel_args.h): the GLINT_AREA_*
  // value every plan run with it has as area_method, -1 for none (every method behind the
  // kernel's runtime switch, what glintd builds). A build option only when set, like sample_uv.
  // Set by DeviceEngine::ProgramSpec (DeviceEngineOptions::ltc_only_programs), not by
  // MakeEvalPlan.
  int area_only = -1;

  bool operator==(const KernelSpec &) const = default;
  // "-DGLINT_NDF=1 ..." for clBuildProgram.
  std::string BuildOptions() const;
  // Short human-readable form for logs: "ggx/schlick/probe/fp32".
  std::string Describe() const;
};

struct EvalPlan {
  KernelSpec spec;
  std::array<float, GLINT_MATERIAL_FLOATS> material{};
  std::array<float, GLINT_MODEL_PARAM_FLOATS> params{};  // the model's pack_params
  std::vector<float> directional;                        // GLINT_LIGHT_FLOATS per light
  std::vector<float> point;
  uint32_t n_directional = 0;
  uint32_t n_point = 0;
  std::vector<float> polygon;  // GLINT_POLYGON_FLOATS per light
  uint32_t n_polygon = 0;
  int area_method = 1;    // GLINT_AREA_* (= glint.v1.AreaMethod, UNSPECIFIED -> LTC)
  int area_samples = 64;  // REFERENCE nodes per dimension per triangle; MONTE_CARLO samples;
                          // AUTO: max_relative_error in millionths
  // The request seed, as the two 32-bit halves the kernels hash (kernels/rng.h).
  uint32_t seed_lo = 0, seed_hi = 0;
  // Model::request_table (ResolveRequestTable): bound as `model_table` instead of the static
  // table; the key names its content for the device engine's buffer cache.
  std::shared_ptr<const std::vector<float>> request_table;
  std::string request_table_key;
  // The material, kept (by MakeEvalPlan) only for a model with a request table, so that the
  // host path resolves the table itself when the caller did not (HostEvaluate, HostSample).
  std::shared_ptr<const glint::v1::Material> request_table_material;
};

// The LTC table (GLINT_LTC_GRID^2 x GLINT_LTC_ENTRY floats, tools/ltc/README.md) for a
// GLINT_NDF_* value.
const float *LtcTable(int ndf);
constexpr size_t kLtcTableFloats = GLINT_LTC_GRID * GLINT_LTC_GRID * GLINT_LTC_ENTRY;

// Builds the plan of a request that has passed ValidateRequest. `queries` may
// differ from request.queries (stream chunks reuse the first chunk's settings).
EvalPlan MakeEvalPlan(const glint::v1::EvaluateRequest &settings,
                      const glint::v1::QueryBatch &queries);

// Fills plan->request_table from the material's model (Model::request_table), if it has the
// hook: NOT_FOUND when a resource the material names is missing. Call after MakeEvalPlan.
Status ResolveRequestTable(const glint::v1::Material &material, EvalPlan *plan);

}  // namespace glint
