// Runs evaluation plans on the OpenCL device. The engine has a fixed number of
// lanes, each with its own command queue and kernel objects (clSetKernelArg is
// not thread-safe on a shared cl_kernel), so calls on different lanes may run
// concurrently; calls on one lane must not.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/cl_runtime.h"
#include "server/eval_plan.h"
#include "server/status.h"

namespace glint {

struct DeviceEngineOptions {
  std::string device;     // see ClRuntime::Create
  std::string cache_dir;  // program binary cache; "" = memory only
  int lanes = 2;
  // Work-group size: explicit, because PoCL picks the largest divisor of the
  // global size otherwise (size 1 for a prime count). Global sizes are padded.
  size_t local_size = 128;
};

class DeviceEngine {
 public:
  static Status Create(const DeviceEngineOptions &options, std::unique_ptr<DeviceEngine> *out);
  ~DeviceEngine();

  const DeviceInfo &info() const { return runtime_->info(); }
  int lanes() const { return int(lanes_.size()); }
  ClRuntime &runtime() { return *runtime_; }

  // Writes 3 * queries.count() floats (RGB per query) to out_rgb.
  Status Evaluate(int lane, const EvalPlan &plan, const glint::v1::QueryBatch &queries,
                  float *out_rgb);

  // Builds the kernel for `spec` and runs it once on every lane at the
  // production local size (PoCL compiles per local size at first enqueue).
  Status Warm(const KernelSpec &spec);

 private:
  struct Lane;
  DeviceEngine() = default;
  Status KernelFor(Lane &lane, const KernelSpec &spec, cl_kernel *out);
  Status AreaKernelFor(Lane &lane, const KernelSpec &spec, cl_kernel *out);
  // The lane's kernel `name` of `source` built with `options` (built on first use).
  Status CachedKernel(Lane &lane, const std::string &source, const char *name,
                      const std::string &options, cl_kernel *out);
  // Runs models/smooth/smooth_area.cl for the plan's polygon lights on `out` (already bound), adding
  // to it when `accumulate`.
  Status EvaluateArea(Lane &lane, const EvalPlan &plan, const glint::v1::QueryBatch &q, cl_mem out,
                      bool accumulate);

  // Runs models/binomial/binomial.cl (all light kinds in one kernel) into out_rgb.
  Status EvaluateBinomial(Lane &lane, const EvalPlan &plan, const glint::v1::QueryBatch &q,
                          float *out_rgb);

  DeviceEngineOptions options_;
  std::unique_ptr<ClRuntime> runtime_;
  std::string smooth_source_;
  std::string area_source_;
  std::string binomial_source_;
  cl_mem ltc_tables_[2] = {nullptr, nullptr};  // GGX, Beckmann (read-only, shared by lanes)
  std::vector<std::unique_ptr<Lane>> lanes_;
};

}  // namespace glint
