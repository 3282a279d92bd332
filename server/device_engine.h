// Runs evaluation plans on the OpenCL device. The engine has a fixed number of
// command queues, one per scheduler worker, each with its own kernel objects
// (clSetKernelArg is not thread-safe on a shared cl_kernel): calls with
// different `worker` indices may run concurrently, calls with one must not.
//
// Every model runs through the same code: its passes (server/model.h) are
// kernels with the standard argument list (kernels/kernel_args.h), bound in
// one place (BindKernelArguments in device_engine.cpp).
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/cl_handle.h"
#include "server/cl_runtime.h"
#include "server/eval_plan.h"
#include "server/model.h"
#include "server/query_view.h"
#include "server/status.h"

namespace glint {

// The build options DeviceEngine compiles `pass` with for `spec`: the spec's options plus the SIMD
// width and blocks per work-item, which only the pass decides. Also (with the source) the key of
// the program cache; benchmarks that build the engine's programs themselves use it too.
std::string PassBuildOptions(const ModelPass &pass, const KernelSpec &spec);

struct DeviceEngineOptions {
  std::string device;     // see ClRuntime::Create
  std::string cache_dir;  // program binary cache; "" = memory only
  int workers = 2;        // command queues (concurrent Evaluate calls)
  // Work-group size: explicit, because PoCL picks the largest divisor of the
  // global size otherwise (size 1 for a prime count). Global sizes are padded.
  // A kernel launches with the largest size not above this (divided by a lights pass's blocks
  // per work-item) that the device and the built kernel accept, and smaller still if an enqueue
  // fails for the size (server/work_group_size.h); results do not depend on it.
  size_t local_size = 128;
  // A further limit on every kernel's work-group size, 0 = none: tests impose a small device's
  // limits on PoCL with it (and an operator could where a driver misreports its own).
  size_t max_local_size = 0;
  // Build an LTC polygon plan's programs for LTC alone (KernelSpec::area_only, -DGLINT_AREA_ONLY)
  // instead of the one program with every area method behind the runtime switch: the glint
  // models' one-query-per-item polygon programs then carry none of the per-query integrators
  // (AUTO's choice, REFERENCE, MONTE_CARLO, LECOCQ), about half their cold compile; results
  // unchanged. Plans of the other methods keep the shared program: a program per method costs
  // more than the shared one when a run uses several (SMOOTH's four in bench_models --quick:
  // 29 CPU-s in all against 17.5 for the shared one, fp32, loaded). Off in glintd (one polygon
  // program per spec, whatever method a request names); on in bench_models --quick, which compiles
  // each of its rows' programs cold (bench/README.md).
  bool ltc_only_programs = false;
};

class DeviceEngine {
 public:
  static Status Create(const DeviceEngineOptions &options, std::unique_ptr<DeviceEngine> *out);
  ~DeviceEngine();

  const DeviceInfo &info() const { return runtime_->info(); }
  int workers() const { return int(queues_.size()); }
  ClRuntime &runtime() { return *runtime_; }

  // Writes 3 * queries.count() floats (RGB per query) to out_rgb, on the
  // command queue of `worker`.
  Status Evaluate(int worker, const EvalPlan &plan, const glint::v1::QueryBatch &queries,
                  float *out_rgb);
  // The same on raw arrays (server/query_view.h), wrapped in place (CL_MEM_USE_HOST_PTR): the
  // arrays must stay mapped and float-aligned until the call returns.
  Status Evaluate(int worker, const EvalPlan &plan, const QueryView &queries, float *out_rgb);

  // Runs the model's sample pass (server/model.h ModelSampler): writes kSampleFloats (7) floats
  // per sample, samples_per_query per query, to `out` (server/sample.h checks the request).
  Status Sample(int worker, const EvalPlan &plan, const glint::v1::QueryBatch &queries,
                uint32_t samples_per_query, float *out);

  // Whether every kernel `plan` runs (its evaluation passes, or with `sample` its sample pass)
  // is built on `worker`'s queue already, so a call builds nothing.
  bool Ready(int worker, const EvalPlan &plan, bool sample) const;
  // Readies a variant before the timed work of a request (EvaluateStats.compile_ms): when a
  // kernel `plan` runs is not built on `worker`'s queue yet, builds it (or loads it from the
  // cache) and runs the plan on the first query alone, output discarded, since PoCL compiles a
  // kernel's work-group function at its first launch; *ms = the time that took. *ms = 0 and
  // nothing runs when all are ready. The request then runs every query as usual (results are
  // unaffected), and its compute time no longer carries the compile.
  Status Prepare(int worker, const EvalPlan &plan, const QueryView &queries, double *ms);
  // The same for the sample pass (one sample of the first query).
  Status PrepareSample(int worker, const EvalPlan &plan, const glint::v1::QueryBatch &queries,
                       double *ms);

  // Builds the kernels for `spec` and runs them once on every queue at the
  // production local size (PoCL compiles per local size at first enqueue).
  // worker >= 0: on that queue only (concurrent calls with different workers
  // may run in parallel, as for Evaluate; server/warmup.h).
  Status Warm(const KernelSpec &spec, int worker = -1);

  // The work-group size of each kernel launch of `worker`'s latest Evaluate or Sample call, in
  // launch order (tests check that DeviceEngineOptions::max_local_size reached the launches).
  std::vector<size_t> LastLaunchLocalSizes(int worker) const;

  // The spec the plan's programs are built for: plan.spec, with area_only = LTC when
  // DeviceEngineOptions::ltc_only_programs asks for it.
  KernelSpec ProgramSpec(const EvalPlan &plan) const;

 private:
  struct Queue;
  struct QueueKernel;
  DeviceEngine() = default;
  // The queue's kernel for `pass` specialised by `spec` (built on first use).
  Status KernelFor(Queue &queue, const ModelPass &pass, const KernelSpec &spec, QueueKernel **out);
  // Enqueues `kernel` (of `model`'s `pass`) over `work_items` work-items in groups of its
  // work-group size (computed at its first launch from `blocks` and the limits, lowered for good
  // when the device refuses it: server/work_group_size.h). On an error, waits for the queue (the
  // earlier passes' inputs wrap request memory) and says which kernel and limit.
  Status Launch(Queue &queue, QueueKernel &kernel, const Model &model, const ModelPass &pass,
                size_t work_items, size_t blocks);

  DeviceEngineOptions options_;
  std::unique_ptr<ClRuntime> runtime_;
  // min(CL_DEVICE_MAX_WORK_GROUP_SIZE, CL_DEVICE_MAX_WORK_ITEM_SIZES[0]), 0 = not reported.
  size_t device_max_local_ = 0;
  std::map<std::string, std::string> sources_;  // expanded kernel source per pass file
  ClBuffer ltc_tables_[2];                      // GGX, Beckmann (read-only, shared by queues)
  std::map<int, ClBuffer> model_tables_;        // Model::table by model id (read-only, shared)
  std::vector<std::unique_ptr<Queue>> queues_;
  // Model::request_table buffers by EvalPlan::request_table_key (server/device_engine_tables.cpp):
  // each distinct table is wrapped once and dropped when the table itself has died.
  struct RequestTableBuffer {
    std::weak_ptr<const std::vector<float>> table;
    ClBuffer buffer;
  };
  std::mutex request_tables_mutex_;
  std::map<std::string, RequestTableBuffer> request_tables_;
  Status RequestTableBufferFor(const EvalPlan &plan, ClBuffer *out);
};

}  // namespace glint
