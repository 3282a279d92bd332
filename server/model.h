// How a BRDF model describes itself to the server: one Model value per model,
// defined in its folder (models/<name>/<name>_model.cpp) and listed once in the
// model table (models/model_table.cpp). Everything else (validation of the
// common fields, the plan, argument binding, the host loop, scheduling, the
// wire) is shared; docs/architecture.md walks through adding a model.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/host_pass.h"
#include "server/status.h"

namespace glint {

struct EvalPlan;
struct KernelSpec;

// One kernel launch of a model: an OpenCL entry taking the standard argument
// list (kernels/kernel_args.h) and the host functions that compute the same.
// A model's passes run in order on one output; each later pass adds to it.
struct ModelPass {
  const char *kernel_file;  // root-relative, e.g. "models/smooth/smooth.cl"
  const char *entry;        // __kernel function name
  // Queries per work-item (GLINT_LANES): 8 or 16 for branch-free SIMD code (`real`
  // is float8/double8 or float16/double16, kernels/simd_io.h), 1 for code that branches per
  // query.
  int simd_width;
  // Whether the plan has work for this pass (nullptr: always).
  bool (*needed)(const EvalPlan &plan);
  HostPassFn host_f32, host_f64;  // the same pass on the host (--device host, tests)
  // Queries per work-item for fp64 requests, 0 = simd_width. A double16 value takes two zmm
  // registers, so a kernel that is fastest with 16 fp32 lanes may be faster with 8 fp64 ones;
  // measure before setting it (BINOMIAL measured 8 no faster, models/binomial/README.md "fp64
  // lanes (session 16)").
  int simd_width_fp64 = 0;

  // Blocks of Width() queries per work-item for fp32 probe requests (built with -DGLINT_BLOCKS=
  // when above 1; the entry must evaluate that many blocks), 0 or 1 = one block. SMOOTH's probe
  // kernel is bound by the latency of its longest chain (the conductor Fresnel's two dependent
  // square roots and division), not its instruction count: two independent blocks in one
  // work-item give the out-of-order core twice the independent work (models/smooth/README.md).
  int probe_blocks_fp32 = 0;

  // Blocks of Width() queries per work-item for fp32 requests with lights (built with
  // -DGLINT_BLOCKS= when above 1; the entry must evaluate that many blocks), 0 or 1 = one block.
  // BINOMIAL's lane kernel regroups the count draws of its blocks by regime
  // (models/binomial/binomial_lanes.cl, on AVX-512 devices; elsewhere it runs the blocks one
  // after the other). Private memory grows with it: the regrouped path keeps per work-item a
  // deferred draw (~0.9 KB of 16-lane vectors), a result and a count per block and the packed
  // stage arrays (6 x (blocks + 1) x 16 values), ~7-8 KB at 4 blocks of 16 fp32 lanes (clang-15
  // -O2 for skylake-avx512, one quad: the kernel's frame 16.2 KB at 1 block, 22.6 KB at 4). PoCL
  // keeps private arrays per work-item of the group on its worker thread's stack (presumably:
  // 16 blocks at 128 work-items per group crashed with SIGSEGV in the kernel), so what bounds
  // it is blocks x the work-items per group: DeviceEngine launches lights passes with
  // DeviceEngineOptions::local_size / blocks work-items per group (128 / 4 = 32: ~240 KB of
  // regrouping state, ~720 KB of frames if PoCL keeps them all), and
  // a larger value here or a larger local_size must be checked against that stack.
  int lights_blocks_fp32 = 0;

  // The width the pass compiles and launches with for a request of this precision.
  int Width(bool fp64) const { return fp64 && simd_width_fp64 > 0 ? simd_width_fp64 : simd_width; }
  // Blocks per work-item for a request of this precision and kind (probe or lights).
  int Blocks(bool fp64, bool probe) const {
    if (fp64) return 1;
    const int blocks = probe ? probe_blocks_fp32 : lights_blocks_fp32;
    return blocks > 1 ? blocks : 1;
  }
};

// A model's optional importance sampling (the Sample RPC, server/sample.h): an OpenCL entry
// taking GLINT_SAMPLE_KERNEL_ARGS (kernels/sample.h), one sample per work-item, and the host
// functions that compute the same. A model without one (kernel_file nullptr) is refused with
// `unsupported_reason`.
struct ModelSampler {
  const char *kernel_file = nullptr;  // e.g. "models/smooth/smooth_sample.cl"
  const char *entry = nullptr;
  SampleHostFn host_f32 = nullptr, host_f64 = nullptr;
  // Why the model cannot be sampled, for the refusal (models without a sampler).
  const char *unsupported_reason = nullptr;
};

struct Model {
  glint::v1::Model id;  // proto enum value (also the kernel spec's model)
  const char *name;     // as in the proto, e.g. "BINOMIAL"
  // The model's own field of glint.v1.Material ("binomial"), or nullptr. A
  // request that sets another model's field is refused.
  const char *params_field;
  std::vector<ModelPass> passes;

  // Validation of what is specific to the model; each returns OK or an
  // INVALID_ARGUMENT naming the field (and query index) and what was expected.
  // The material's params block (its defaults applied by pack_params).
  Status (*validate_params)(const glint::v1::Material &m) = nullptr;
  // One light (`field` is e.g. "lights[2]"), after the common light checks.
  Status (*validate_light)(const glint::v1::Material &m, const glint::v1::Light &light,
                           const std::string &field) = nullptr;
  // A query batch (after the common query checks), `first_query` = its offset in a stream.
  Status (*validate_queries)(const glint::v1::EvaluateRequest &settings,
                             const glint::v1::QueryBatch &queries, uint64_t first_query) = nullptr;

  // A read-only table of static data the model's kernels read as `in.model_table`
  // (kernels/kernel_args.h), e.g. the Chermain dictionary: returns it and its size in
  // floats. The device engine uploads it once as a buffer, like the LTC tables; the host
  // path passes the pointer. nullptr: the model has none (kernels see the dummy buffer).
  const float *(*table)(size_t *floats) = nullptr;

  // Packs the params block (GLINT_MODEL_PARAM_FLOATS floats, zero-initialised).
  void (*pack_params)(const glint::v1::Material &m, float *params) = nullptr;

  // A valid material and query shape of this model for warm-up: fills the
  // params field and, where the model needs them, uv and footprint.
  void (*example)(glint::v1::Material *m, glint::v1::QueryBatch *one_query) = nullptr;
  // Kernel variants compiled and run before the server reports SERVING.
  std::vector<KernelSpec> (*warm_specs)() = nullptr;

  // Importance sampling, optional (docs/architecture.md "Adding a model", step 6).
  ModelSampler sample = {};
  // False for a model with its own NDF (NORMAL_MAP): material.ndf, alpha_x and alpha_y are
  // then neither required nor checked.
  bool uses_ndf = true;

  // Per-request data its kernels read as `in.model_table` instead of the static `table`, e.g.
  // the uploaded normal map a NORMAL_MAP material names (docs/architecture.md "Model tables").
  // Returns the table and a key naming its content (the device engine uploads each distinct
  // key once and keeps the buffer while the table lives), or a refusal: NOT_FOUND naming a
  // missing resource, INVALID_ARGUMENT. Called once per request (or stream settings).
  Status (*request_table)(const glint::v1::Material &m,
                          std::shared_ptr<const std::vector<float>> *table,
                          std::string *key) = nullptr;
  // Admission cost (server/request_cost.h): how many smooth BRDF evaluations one evaluation of
  // this model with material `m` costs (>= 1; nullptr: 1, the smooth model).
  double (*cost_factor)(const glint::v1::Material &m) = nullptr;
  // Admission cost of one polygon light beyond the smooth area integral, in units (nullptr: the
  // smooth integral times min(cost_factor, 8), server/request_cost.cpp).
  double (*polygon_cost)(const glint::v1::Material &m) = nullptr;
  // Admission cost when it depends on each query (NORMAL_MAP: the footprint's cut-off box):
  // the largest and the summed cost in units of the queries `q` with all of `settings`' lights
  // (settings.queries() is not read), and what it counts (for the refusal, naming the dearest
  // query as `first_query` + its index in q). Replaces the estimate from cost_factor and
  // polygon_cost wherever the server holds the queries (EstimateQueriesCost,
  // server/request_cost.h); false (or nullptr): use those.
  bool (*query_costs)(const glint::v1::EvaluateRequest &settings, const glint::v1::QueryBatch &q,
                      uint64_t first_query, double *max_units, double *sum_units,
                      std::string *parts) = nullptr;
  // How the model integrates polygon lights when it does not use settings.area_method (NORMAL_MAP:
  // its own MIS of light and P-NDF samples), in the words the cost and its refusal print after
  // "polygon lights (up to N vertices) by "; nullptr: the area method's name.
  std::string (*polygon_method)(const glint::v1::EvaluateRequest &settings) = nullptr;
};

}  // namespace glint
