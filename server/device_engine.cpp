#include "server/device_engine.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <iostream>
#include <tuple>

#include "server/kernel_source.h"
#include "server/launch_grid.h"
#include "server/model_table.h"
#include "server/shm_guard.h"
#include "server/sliced_eval.h"
#include "server/work_group_size.h"

namespace glint {

struct DeviceEngine::QueueKernel {
  ClKernel kernel;
  size_t max_local = 0;  // CL_KERNEL_WORK_GROUP_SIZE on the device (0: not reported)
  size_t local = 0;      // the work-group size it launches with; 0 until its first launch
};

struct DeviceEngine::Queue {
  ClQueue queue;
  ClBuffer dummy;                              // bound to the inputs a request does not carry
  std::map<std::string, QueueKernel> kernels;  // by kernel file + entry + build options
  std::vector<size_t> launched_local;          // LastLaunchLocalSizes
};

namespace {

// The buffers of one evaluation, in the order of kernels/kernel_args.h. Inputs
// wrap the request's memory (CL_MEM_USE_HOST_PTR: no copy on CPU devices), so
// they must not outlive the call; absent inputs are bound to the dummy buffer.
struct KernelArguments {
  cl_uint n = 0;
  ClBuffer uv, footprint, wo, wi, position, normal, tangent, material, params;
  cl_float8 material_values{};  // the material block again, by value (kernels/kernel_args.h)
  ClBuffer directional, point, polygons, out;
  cl_uint n_directional = 0, n_point = 0, n_polygon = 0;
  cl_mem ltc_table = nullptr;
  cl_mem model_table = nullptr;  // nullptr: bound to the dummy buffer
  cl_int area_method = 0, area_samples = 0;
  cl_uint seed_lo = 0, seed_hi = 0;
};

Status MakeInput(cl_context ctx, const float *data, size_t count, ClBuffer *buf) {
  if (count == 0) return Status::Ok();
  cl_int err = CL_SUCCESS;
  buf->reset(clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, count * sizeof(float),
                            const_cast<float *>(data), &err));
  if (err != CL_SUCCESS)
    return Status::Internal("clCreateBuffer (input) failed: " + ClErrorName(err));
  return Status::Ok();
}

template <class Array>
Status MakeInput(cl_context ctx, const Array &a, ClBuffer *buf) {
  return MakeInput(ctx, a.data(), size_t(a.size()), buf);
}

Status MakeArguments(cl_context ctx, const EvalPlan &plan, const QueryView &q, cl_mem ltc_table,
                     cl_mem model_table, float *out_rgb, KernelArguments *a) {
  a->n = q.count;
  // Floats per query of each array (an absent one, null, binds the dummy buffer).
  for (auto [input, per, buf] : {std::tuple{q.uv, 2u, &a->uv},
                                 {q.footprint, 4u, &a->footprint},
                                 {q.wo, 3u, &a->wo},
                                 {q.wi, 3u, &a->wi},
                                 {q.position, 3u, &a->position},
                                 {q.normal, 3u, &a->normal},
                                 {q.tangent, 3u, &a->tangent}}) {
    Status s = MakeInput(ctx, input, input ? size_t(q.count) * per : 0, buf);
    if (!s.ok()) return s;
  }
  for (Status s :
       {MakeInput(ctx, plan.material, &a->material), MakeInput(ctx, plan.params, &a->params),
        MakeInput(ctx, plan.directional, &a->directional), MakeInput(ctx, plan.point, &a->point),
        MakeInput(ctx, plan.polygon, &a->polygons)})
    if (!s.ok()) return s;
  static_assert(sizeof(cl_float8) == sizeof(plan.material), "GLINT_MATERIAL_FLOATS is 8");
  std::memcpy(&a->material_values, plan.material.data(), sizeof(cl_float8));
  a->n_directional = plan.n_directional;
  a->n_point = plan.n_point;
  a->n_polygon = plan.n_polygon;
  a->ltc_table = ltc_table;
  a->model_table = model_table;
  a->area_method = plan.area_method;
  a->area_samples = plan.area_samples;
  a->seed_lo = plan.seed_lo;
  a->seed_hi = plan.seed_hi;
  // The kernels write the caller's array directly (CPU device: no separate allocation, no copy
  // back); read-write because a later pass adds to an earlier one's output.
  cl_int err = CL_SUCCESS;
  a->out.reset(clCreateBuffer(ctx, CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR,
                              size_t(a->n) * 3 * sizeof(float), out_rgb, &err));
  if (err != CL_SUCCESS)
    return Status::Internal("clCreateBuffer (output) failed: " + ClErrorName(err));
  return Status::Ok();
}

// Arguments in GLINT_KERNEL_ARGS (kernels/kernel_args.h); a sample pass's K follows them.
constexpr cl_uint kKernelArgCount = 25;

// The one place where kernel arguments are bound: GLINT_KERNEL_ARGS order.
Status BindKernelArguments(cl_kernel kernel, const KernelArguments &a, cl_mem dummy,
                           bool accumulate) {
  cl_uint index = 0;
  auto value = [&](const auto &v) { return clSetKernelArg(kernel, index++, sizeof(v), &v); };
  auto buffer = [&](const ClBuffer &b) {
    cl_mem m = b ? b.get() : dummy;
    return clSetKernelArg(kernel, index++, sizeof(cl_mem), &m);
  };
  const cl_int acc = accumulate ? 1 : 0;
  const cl_mem model_table = a.model_table ? a.model_table : dummy;
  for (cl_int err : {value(a.n),
                     buffer(a.uv),
                     buffer(a.footprint),
                     buffer(a.wo),
                     buffer(a.wi),
                     buffer(a.position),
                     buffer(a.normal),
                     buffer(a.tangent),
                     buffer(a.material),
                     value(a.material_values),
                     buffer(a.params),
                     buffer(a.directional),
                     value(a.n_directional),
                     buffer(a.point),
                     value(a.n_point),
                     buffer(a.polygons),
                     value(a.n_polygon),
                     value(a.ltc_table),
                     value(model_table),
                     value(a.area_method),
                     value(a.area_samples),
                     value(a.seed_lo),
                     value(a.seed_hi),
                     value(acc),
                     buffer(a.out)}) {
    if (err != CL_SUCCESS)
      return Status::Internal("clSetKernelArg " + std::to_string(index) +
                              " failed: " + ClErrorName(err));
  }
  return Status::Ok();
}

// Mapping a CL_MEM_USE_HOST_PTR output buffer makes the caller's array hold the results (a
// no-op on PoCL's CPU device, a copy on devices that needed their own memory); then waits for
// the queue, because the input buffers wrap request memory that dies with the call.
Status ReadBackAndFinish(cl_command_queue queue, cl_mem out, size_t bytes) {
  cl_int err = CL_SUCCESS;
  void *mapped =
      clEnqueueMapBuffer(queue, out, CL_TRUE, CL_MAP_READ, 0, bytes, 0, nullptr, nullptr, &err);
  if (err != CL_SUCCESS)
    return Status::Internal("clEnqueueMapBuffer (output) failed: " + ClErrorName(err));
  GLINT_CL_CHECK(clEnqueueUnmapMemObject(queue, out, mapped, 0, nullptr, nullptr));
  GLINT_CL_CHECK(clFinish(queue));
  return Status::Ok();
}

Status Fp64Unavailable(const DeviceInfo &info) {
  return Status::InvalidArgument("precision: FP64 requested but " + info.name +
                                 " has no cl_khr_fp64");
}

}  // namespace

Status DeviceEngine::Create(const DeviceEngineOptions &options,
                            std::unique_ptr<DeviceEngine> *out) {
  if (options.local_size < 1 || options.local_size >= kPoclSmallGridLimit)
    return Status::InvalidArgument("DeviceEngineOptions.local_size " +
                                   std::to_string(options.local_size) + ": expected 1.." +
                                   std::to_string(kPoclSmallGridLimit - 1));
  std::unique_ptr<DeviceEngine> engine(new DeviceEngine());
  engine->options_ = options;
  // The SIGBUS guard before the first OpenCL call and in front again after it: LLVM, inside PoCL,
  // installs its handlers while the devices are enumerated, saving the guard as what it displaced
  // (server/shm_guard.cpp KeepSigbusGuardFirst).
  KeepSigbusGuardFirst();
  Status s = ClRuntime::Create(options.device, options.cache_dir, &engine->runtime_);
  KeepSigbusGuardFirst();
  if (!s.ok()) return s;
  {
    // The device's bounds on any kernel's work-group size (a 2D launch of {local, 1}: the total
    // and the first dimension); OpenCL requires both to be reported, 0 stays "none" otherwise.
    cl_device_id device = engine->runtime_->device();
    size_t max_group = 0;
    cl_uint dims = 0;
    if (clGetDeviceInfo(device, CL_DEVICE_MAX_WORK_GROUP_SIZE, sizeof max_group, &max_group,
                        nullptr) != CL_SUCCESS)
      max_group = 0;
    size_t max_x = 0;
    if (clGetDeviceInfo(device, CL_DEVICE_MAX_WORK_ITEM_DIMENSIONS, sizeof dims, &dims, nullptr) ==
            CL_SUCCESS &&
        dims > 0) {
      std::vector<size_t> sizes(dims);
      if (clGetDeviceInfo(device, CL_DEVICE_MAX_WORK_ITEM_SIZES, dims * sizeof(size_t),
                          sizes.data(), nullptr) == CL_SUCCESS)
        max_x = sizes[0];
    }
    engine->device_max_local_ =
        max_group == 0 || max_x == 0 ? std::max(max_group, max_x) : std::min(max_group, max_x);
  }
  for (const Model *model : Models())
    for (const ModelPass &pass : model->passes)
      if (!engine->sources_.count(pass.kernel_file))
        engine->sources_[pass.kernel_file] = ExpandKernelSource(pass.kernel_file);
  for (const Model *model : Models())
    if (model->sample.kernel_file)
      engine->sources_[model->sample.kernel_file] = ExpandKernelSource(model->sample.kernel_file);
  cl_context ctx = engine->runtime_->context();
  for (int t = 0; t < 2; ++t) {
    cl_int err = CL_SUCCESS;
    // The LTC tables go to the device as buffers, not __constant arrays in the program: 128 KiB
    // each is above OpenCL's guaranteed constant memory.
    engine->ltc_tables_[t].reset(clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                                                kLtcTableFloats * sizeof(float),
                                                const_cast<float *>(LtcTable(t + 1)), &err));
    if (err != CL_SUCCESS)
      return Status::Internal("clCreateBuffer (LTC table) failed: " + ClErrorName(err));
  }
  for (const Model *model : Models()) {
    if (!model->table) continue;
    size_t floats = 0;
    const float *table = model->table(&floats);
    cl_int err = CL_SUCCESS;
    engine->model_tables_[model->id].reset(
        clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, floats * sizeof(float),
                       const_cast<float *>(table), &err));
    if (err != CL_SUCCESS)
      return Status::Internal(std::string("clCreateBuffer (") + model->name +
                              " table) failed: " + ClErrorName(err));
  }
  for (int i = 0; i < std::max(1, options.workers); ++i) {
    auto queue = std::make_unique<Queue>();
    cl_int err = CL_SUCCESS;
    queue->queue.reset(clCreateCommandQueue(ctx, engine->runtime_->device(), 0, &err));
    if (err != CL_SUCCESS)
      return Status::Internal("clCreateCommandQueue failed: " + ClErrorName(err));
    queue->dummy.reset(clCreateBuffer(ctx, CL_MEM_READ_ONLY, 4 * sizeof(float), nullptr, &err));
    if (err != CL_SUCCESS) return Status::Internal("clCreateBuffer failed: " + ClErrorName(err));
    engine->queues_.push_back(std::move(queue));
  }
  *out = std::move(engine);
  return Status::Ok();
}

// Kernels and queues before the runtime's programs and context.
DeviceEngine::~DeviceEngine() {
  queues_.clear();
  for (ClBuffer &t : ltc_tables_) t.reset();
  model_tables_.clear();
}

std::string PassBuildOptions(const ModelPass &pass, const KernelSpec &spec) {
  std::string options =
      spec.BuildOptions() + " -DGLINT_LANES=" + std::to_string(pass.Width(spec.fp64));
  // Only when above 1, so that every other program keeps its options (and its cache key).
  const int blocks = pass.Blocks(spec.fp64, spec.probe);
  if (blocks > 1) options += " -DGLINT_BLOCKS=" + std::to_string(blocks);
  return options;
}

namespace {

// The key of a queue's kernel map.
std::string PassKey(const ModelPass &pass, const KernelSpec &spec) {
  return std::string(pass.kernel_file) + '\n' + pass.entry + '\n' + PassBuildOptions(pass, spec);
}

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

bool DeviceEngine::Ready(int worker, const EvalPlan &plan, bool sample) const {
  const Queue &queue = *queues_.at(size_t(worker));
  const Model *model = FindModel(plan.spec.model);
  if (!model) return true;  // Evaluate / Sample refuse it; nothing to build
  if (sample) {
    if (!model->sample.kernel_file) return true;
    const ModelPass pass = {
        model->sample.kernel_file, model->sample.entry, 1, nullptr, nullptr, nullptr};
    return queue.kernels.count(PassKey(pass, plan.spec)) > 0;
  }
  const KernelSpec spec = ProgramSpec(plan);
  for (const ModelPass &pass : model->passes)
    if ((!pass.needed || pass.needed(plan)) && !queue.kernels.count(PassKey(pass, spec)))
      return false;
  return true;
}

KernelSpec DeviceEngine::ProgramSpec(const EvalPlan &plan) const {
  // Decided here alone, from the argument the kernels get (plan.area_method), so a program's
  // constant always equals it.
  KernelSpec spec = plan.spec;
  spec.area_only =
      options_.ltc_only_programs && spec.has_polygon && plan.area_method == GLINT_AREA_LTC
          ? plan.area_method
          : -1;
  return spec;
}

Status DeviceEngine::Prepare(int worker, const EvalPlan &plan, const QueryView &queries,
                             double *ms) {
  *ms = 0;
  if (queries.count == 0 || Ready(worker, plan, false)) return Status::Ok();
  const auto t0 = std::chrono::steady_clock::now();
  float rgb[3];
  Status s = Evaluate(worker, plan, queries.Slice(0, 1), rgb);
  *ms = MsSince(t0);
  return s;
}

Status DeviceEngine::PrepareSample(int worker, const EvalPlan &plan,
                                   const glint::v1::QueryBatch &queries, double *ms) {
  *ms = 0;
  if (queries.count() == 0 || Ready(worker, plan, true)) return Status::Ok();
  const auto t0 = std::chrono::steady_clock::now();
  glint::v1::QueryBatch first;
  CopyQuerySlice(queries, 0, 1, &first);
  float out[kSampleFloats];
  Status s = Sample(worker, plan, first, 1, out);
  *ms = MsSince(t0);
  return s;
}

Status DeviceEngine::KernelFor(Queue &queue, const ModelPass &pass, const KernelSpec &spec,
                               QueueKernel **out) {
  const std::string options = PassBuildOptions(pass, spec);
  const std::string key = PassKey(pass, spec);
  auto it = queue.kernels.find(key);
  if (it != queue.kernels.end()) {
    *out = &it->second;
    return Status::Ok();
  }
  cl_program program = nullptr;
  Status s = runtime_->GetProgram(sources_.at(pass.kernel_file), options, &program);
  if (!s.ok()) return s;
  cl_int err = CL_SUCCESS;
  ClKernel kernel(clCreateKernel(program, pass.entry, &err));
  if (err != CL_SUCCESS)
    return Status::Internal(std::string("clCreateKernel ") + pass.entry +
                            " failed: " + ClErrorName(err));
  // The built kernel's own bound (registers, private memory); asked once, kept with the kernel.
  size_t max_local = 0;
  if (clGetKernelWorkGroupInfo(kernel.get(), runtime_->device(), CL_KERNEL_WORK_GROUP_SIZE,
                               sizeof max_local, &max_local, nullptr) != CL_SUCCESS)
    max_local = 0;
  QueueKernel &entry = queue.kernels[key];
  entry.kernel = std::move(kernel);
  entry.max_local = max_local;
  *out = &entry;
  return Status::Ok();
}

std::vector<size_t> DeviceEngine::LastLaunchLocalSizes(int worker) const {
  return queues_.at(size_t(worker))->launched_local;
}

Status DeviceEngine::Launch(Queue &queue, QueueKernel &kernel, const Model &model,
                            const ModelPass &pass, size_t work_items, size_t blocks) {
  const WorkGroupLimits limits = {kernel.max_local, device_max_local_, options_.max_local_size};
  if (kernel.local == 0) kernel.local = LocalSizeFor(options_.local_size, blocks, limits);
  size_t local = kernel.local;
  const cl_int err = EnqueueShrinkingGroups(work_items, &local, [&](const LaunchGrid &grid) {
    return clEnqueueNDRangeKernel(queue.queue.get(), kernel.kernel.get(), 2, nullptr, grid.global,
                                  grid.local, 0, nullptr, nullptr);
  });
  if (err == CL_SUCCESS) {
    // A size the device refused is not tried again on this queue. Said once per kernel and queue
    // (it stays lowered), since a driver may also report an earlier command's failure this way.
    if (local < kernel.local)
      std::cerr << "glint: " << model.name << " kernel " << pass.entry << " (" << pass.kernel_file
                << "): the device refused work-groups of " << kernel.local << "; now " << local
                << "\n";
    kernel.local = local;
    queue.launched_local.push_back(local);
    return Status::Ok();
  }
  // Earlier passes of the call may be running on the request's memory: done before returning.
  clFinish(queue.queue.get());
  const std::string what =
      std::string(model.name) + " kernel " + pass.entry + " (" + pass.kernel_file + ")";
  if (!SmallerGroupsMayHelp(err))
    return Status::Internal(what + ": clEnqueueNDRangeKernel failed: " + ClErrorName(err) +
                            " (work-group size " + std::to_string(local) + ")");
  // Not even one work-item per group fits: nothing this server can change; the device cannot run
  // the variant (every request of it gets this, the other variants are unaffected).
  cl_ulong private_bytes = 0;
  clGetKernelWorkGroupInfo(kernel.kernel.get(), runtime_->device(), CL_KERNEL_PRIVATE_MEM_SIZE,
                           sizeof private_bytes, &private_bytes, nullptr);
  auto limit = [](size_t v) { return v ? std::to_string(v) : std::string("not reported"); };
  return Status::FailedPrecondition(
      what + " cannot run on " + runtime_->info().name +
      ", not even in work-groups of 1: clEnqueueNDRangeKernel failed with " + ClErrorName(err) +
      " (the kernel's CL_KERNEL_WORK_GROUP_SIZE " + limit(kernel.max_local) +
      ", the device's maximum work-group size " + limit(device_max_local_) +
      ", CL_KERNEL_PRIVATE_MEM_SIZE " + std::to_string(private_bytes) +
      " bytes per work-item; configured work-group size " + std::to_string(options_.local_size) +
      ")");
}

Status DeviceEngine::Evaluate(int worker, const EvalPlan &plan, const glint::v1::QueryBatch &q,
                              float *out_rgb) {
  return Evaluate(worker, plan, QueryView::Of(q), out_rgb);
}

Status DeviceEngine::Evaluate(int worker, const EvalPlan &plan, const QueryView &q,
                              float *out_rgb) {
  Queue &queue = *queues_.at(size_t(worker));
  if (plan.spec.fp64 && !runtime_->info().fp64) return Fp64Unavailable(runtime_->info());
  const Model *model = FindModel(plan.spec.model);
  if (!model)
    return Status::Internal("no model with id " + std::to_string(plan.spec.model) +
                            " in the model table");
  if (model->request_table && !plan.request_table)
    return Status::Internal(std::string(model->name) +
                            ": the plan has no request table (ResolveRequestTable not called)");
  const cl_uint n = q.count;
  if (n == 0) return Status::Ok();

  std::vector<const ModelPass *> passes;
  for (const ModelPass &pass : model->passes)
    if (!pass.needed || pass.needed(plan)) passes.push_back(&pass);
  if (passes.empty()) {
    std::memset(out_rgb, 0, size_t(n) * 3 * sizeof(float));
    return Status::Ok();
  }

  KernelArguments args;
  auto table = model_tables_.find(model->id);
  cl_mem model_table = table == model_tables_.end() ? nullptr : table->second.get();
  ClBuffer request_table;  // held until the kernels have run (ReadBackAndFinish)
  if (plan.request_table) {
    Status t = RequestTableBufferFor(plan, &request_table);
    if (!t.ok()) return t;
    model_table = request_table.get();
  }
  Status s = MakeArguments(runtime_->context(), plan, q,
                           ltc_tables_[plan.spec.ndf == GLINT_NDF_BECKMANN ? 1 : 0].get(),
                           model_table, out_rgb, &args);
  if (!s.ok()) return s;
  // Every pass's kernel before any runs: a build may have LLVM install its SIGBUS handler over the
  // guard of the shared-memory regions the kernels may read in place; the guard goes back in
  // front before they run (one system call; server/shm_guard.h).
  std::vector<QueueKernel *> kernels(passes.size());
  const KernelSpec spec = ProgramSpec(plan);
  for (size_t k = 0; k < passes.size(); ++k) {
    s = KernelFor(queue, *passes[k], spec, &kernels[k]);
    if (!s.ok()) return s;
  }
  KeepSigbusGuardFirst();
  queue.launched_local.clear();
  for (size_t k = 0; k < passes.size(); ++k) {
    // In-order queue: each later pass runs after the earlier ones and adds to their output.
    s = BindKernelArguments(kernels[k]->kernel.get(), args, queue.dummy.get(), k > 0);
    if (!s.ok()) {
      clFinish(queue.queue.get());  // the earlier passes read request memory
      return s;
    }
    // A 2D grid below PoCL's small-grid limit: the work-group function the one-query warm-up
    // compiled runs every batch (server/launch_grid.h).
    const size_t blocks = size_t(passes[k]->Blocks(spec.fp64, spec.probe));
    const size_t width = size_t(passes[k]->Width(spec.fp64)) * blocks;
    // A pass with several blocks per work-item for lights (BINOMIAL's regrouped draws) keeps the
    // queries per work-group: local_size / blocks work-items of `blocks` blocks. Otherwise a
    // batch of up to local_size x width queries (8192 for BINOMIAL's 4 x 16) would be one
    // work-group, i.e. run on one of PoCL's threads. Probes keep local_size (SMOOTH's 2 blocks
    // were measured so).
    s = Launch(queue, *kernels[k], *model, *passes[k], (size_t(n) + width - 1) / width,
               spec.probe ? 1 : blocks);
    if (!s.ok()) return s;
  }
  s = ReadBackAndFinish(queue.queue.get(), args.out.get(), size_t(n) * 3 * sizeof(float));
  return s;
}

// The sample pass: the standard arguments (an output of kSampleFloats per sample) plus
// samples_per_query after `out` (kernels/sample.h GLINT_SAMPLE_KERNEL_ARGS), one sample per
// work-item.
Status DeviceEngine::Sample(int worker, const EvalPlan &plan, const glint::v1::QueryBatch &q,
                            uint32_t samples_per_query, float *out) {
  Queue &queue = *queues_.at(size_t(worker));
  if (plan.spec.fp64 && !runtime_->info().fp64) return Fp64Unavailable(runtime_->info());
  const Model *model = FindModel(plan.spec.model);
  if (!model || !model->sample.kernel_file)
    return Status::Internal("no sample pass for model id " + std::to_string(plan.spec.model));
  const size_t samples = size_t(q.count()) * samples_per_query;
  if (samples == 0) return Status::Ok();
  KernelArguments args;
  auto table = model_tables_.find(model->id);
  cl_mem model_table = table == model_tables_.end() ? nullptr : table->second.get();
  ClBuffer request_table;  // the plan's Model::request_table (NORMAL_MAP), held until read back
  if (model->request_table && !plan.request_table)
    return Status::Internal(std::string(model->name) +
                            ": the plan has no request table (ResolveRequestTable not called)");
  if (plan.request_table) {
    Status t = RequestTableBufferFor(plan, &request_table);
    if (!t.ok()) return t;
    model_table = request_table.get();
  }
  Status s = MakeArguments(runtime_->context(), plan, QueryView::Of(q),
                           ltc_tables_[plan.spec.ndf == GLINT_NDF_BECKMANN ? 1 : 0].get(),
                           model_table, out, &args);
  if (!s.ok()) return s;
  cl_int err = CL_SUCCESS;
  args.out.reset(clCreateBuffer(runtime_->context(), CL_MEM_WRITE_ONLY | CL_MEM_USE_HOST_PTR,
                                samples * kSampleFloats * sizeof(float), out, &err));
  if (err != CL_SUCCESS)
    return Status::Internal("clCreateBuffer (samples) failed: " + ClErrorName(err));
  const ModelPass pass = {
      model->sample.kernel_file, model->sample.entry, 1, nullptr, nullptr, nullptr};
  QueueKernel *kernel = nullptr;
  s = KernelFor(queue, pass, plan.spec, &kernel);
  if (!s.ok()) return s;
  s = BindKernelArguments(kernel->kernel.get(), args, queue.dummy.get(), false);
  if (!s.ok()) return s;
  const cl_uint k = samples_per_query;
  GLINT_CL_CHECK(clSetKernelArg(kernel->kernel.get(), kKernelArgCount, sizeof(k), &k));
  queue.launched_local.clear();
  s = Launch(queue, *kernel, *model, pass, samples, 1);
  if (!s.ok()) return s;
  return ReadBackAndFinish(queue.queue.get(), args.out.get(),
                           samples * kSampleFloats * sizeof(float));
}

Status DeviceEngine::Warm(const KernelSpec &spec, int worker) {
  const Model *model = FindModel(spec.model);
  if (!model) return Status::Internal("Warm: no model with id " + std::to_string(spec.model));
  // A one-query request of the spec's shape: one probe or one light of each kind it uses.
  glint::v1::EvaluateRequest r;
  glint::v1::Material *m = r.mutable_material();
  m->set_model(glint::v1::Model(spec.model));
  m->set_ndf(spec.ndf == GLINT_NDF_BECKMANN ? glint::v1::BECKMANN : glint::v1::GGX);
  m->set_alpha_x(0.5f);
  m->set_alpha_y(0.5f);
  if (spec.fresnel == GLINT_FRESNEL_CONDUCTOR) {
    for (int c = 0; c < 3; ++c) m->mutable_conductor()->add_eta(1.0f);
    for (int c = 0; c < 3; ++c) m->mutable_conductor()->add_k(1.0f);
  } else if (spec.fresnel == GLINT_FRESNEL_DIELECTRIC) {
    m->mutable_dielectric()->set_ior(1.5f);
  } else {
    for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(0.04f);
  }
  glint::v1::QueryBatch *q = r.mutable_queries();
  q->set_count(1);
  auto add3 = [](auto *field, float x, float y, float z) {
    field->Add(x);
    field->Add(y);
    field->Add(z);
  };
  add3(q->mutable_wo(), 0, 0, 1);
  if (spec.probe) add3(q->mutable_wi(), 0, 0, 1);
  if (spec.has_frame) {
    add3(q->mutable_position(), 0, 0, 0);
    add3(q->mutable_normal(), 0, 0, 1);
    add3(q->mutable_tangent(), 1, 0, 0);
  }
  if (spec.has_directional) {
    auto *d = r.add_lights()->mutable_directional();
    add3(d->mutable_direction(), 0, 0, 1);
    add3(d->mutable_irradiance(), 1, 1, 1);
    d->set_cone_half_angle_deg(1.0f);
  }
  if (spec.has_point) {
    auto *p = r.add_lights()->mutable_point();
    add3(p->mutable_position(), 0, 0, 1);
    add3(p->mutable_intensity(), 1, 1, 1);
    p->set_radius(0.1f);
  }
  if (spec.has_polygon) {  // a unit-radiance triangle overhead
    auto *p = r.add_lights()->mutable_polygon();
    for (float v : {-1.0f, -1.0f, 2.0f, 1.0f, -1.0f, 2.0f, 0.0f, 1.0f, 2.0f}) p->add_vertices(v);
    add3(p->mutable_radiance(), 1, 1, 1);
    p->set_two_sided(true);
  }
  if (model->example) model->example(m, q);
  r.set_precision(spec.fp64 ? glint::v1::FP64 : glint::v1::FP32);
  EvalPlan plan = MakeEvalPlan(r, *q);
  if (Status t = ResolveRequestTable(*m, &plan); !t.ok()) return t;
  if (!(plan.spec == spec))
    return Status::Internal("Warm: the example request of " + spec.Describe() + " plans as " +
                            plan.spec.Describe());
  float rgb[3];
  for (int w = worker < 0 ? 0 : worker; w < (worker < 0 ? workers() : worker + 1); ++w) {
    Status s = Evaluate(w, plan, *q, rgb);
    if (!s.ok()) return s;
  }
  return Status::Ok();
}

}  // namespace glint
