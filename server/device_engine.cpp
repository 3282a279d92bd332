#include "server/device_engine.h"

#include <algorithm>
#include <initializer_list>
#include <iterator>

#include "server/kernel_source.h"
#include "server/output_range.h"

namespace glint {

struct DeviceEngine::Lane {
  cl_command_queue queue = nullptr;
  cl_mem dummy = nullptr;                    // bound to kernel arguments the request does not use
  std::map<std::string, cl_kernel> kernels;  // by kernel name + build options
  ~Lane() {
    for (auto &k : kernels) clReleaseKernel(k.second);
    if (dummy) clReleaseMemObject(dummy);
    if (queue) clReleaseCommandQueue(queue);
  }
};

namespace {

// Queries per work-item: the kernel evaluates them as the lanes of OpenCL
// vectors (kernels/compat.h, GLINT_LANES), 8 x fp32 = AVX2 register, 8 x fp64 =
// AVX-512 register. PoCL's own vectorisation across work-items does not
// survive the kernel's math (see models/smooth/smooth.cl), so the width is explicit.
constexpr cl_uint kQueriesPerWorkItem = 8;

// The spec's options plus what only the device side decides. Also the key of
// the lane's kernel map and of the program cache.
std::string DeviceBuildOptions(const KernelSpec &spec) {
  return spec.BuildOptions() + " -DGLINT_LANES=" + std::to_string(kQueriesPerWorkItem);
}

// Owns a cl_mem for the duration of one evaluation.
class Buffer {
 public:
  Buffer() = default;
  ~Buffer() {
    if (mem_) clReleaseMemObject(mem_);
  }
  Buffer(const Buffer &) = delete;
  Buffer &operator=(const Buffer &) = delete;
  cl_mem *out() { return &mem_; }
  cl_mem get() const { return mem_; }

 private:
  cl_mem mem_ = nullptr;
};

// Read-only input straight from the request's memory where possible
// (CL_MEM_USE_HOST_PTR avoids a copy on CPU devices); empty arrays bind the
// lane's dummy buffer.
Status MakeInput(cl_context ctx, const float *data, size_t count, cl_mem dummy, Buffer *buf,
                 cl_mem *arg) {
  if (count == 0) {
    *arg = dummy;
    return Status::Ok();
  }
  cl_int err = CL_SUCCESS;
  *buf->out() = clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, count * sizeof(float),
                               const_cast<float *>(data), &err);
  if (err != CL_SUCCESS)
    return Status::Internal("clCreateBuffer (input) failed: " + ClErrorName(err));
  *arg = buf->get();
  return Status::Ok();
}

// One kernel input: `count` floats at `data`, bound to *arg through *buf (MakeInput).
struct Input {
  const float *data;
  size_t count;
  Buffer *buf;
  cl_mem *arg;
};

Status MakeInputs(cl_context ctx, cl_mem dummy, std::initializer_list<Input> inputs) {
  for (const Input &in : inputs) {
    Status s = MakeInput(ctx, in.data, in.count, dummy, in.buf, in.arg);
    if (!s.ok()) return s;
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

}  // namespace

Status DeviceEngine::Create(const DeviceEngineOptions &options,
                            std::unique_ptr<DeviceEngine> *out) {
  std::unique_ptr<DeviceEngine> engine(new DeviceEngine());
  engine->options_ = options;
  Status s = ClRuntime::Create(options.device, options.cache_dir, &engine->runtime_);
  if (!s.ok()) return s;
  engine->smooth_source_ = ExpandKernelSource("models/smooth/smooth.cl");
  engine->area_source_ = ExpandKernelSource("models/smooth/smooth_area.cl");
  engine->binomial_source_ = ExpandKernelSource("models/binomial/binomial.cl");
  for (int t = 0; t < 2; ++t) {
    cl_int err = CL_SUCCESS;
    // The LTC tables go to the device as buffers, not __constant arrays in the program: 128 KiB
    // each is above OpenCL's guaranteed constant memory.
    engine->ltc_tables_[t] =
        clCreateBuffer(engine->runtime_->context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                       kLtcTableFloats * sizeof(float), const_cast<float *>(LtcTable(t + 1)), &err);
    if (err != CL_SUCCESS)
      return Status::Internal("clCreateBuffer (LTC table) failed: " + ClErrorName(err));
  }
  for (int i = 0; i < std::max(1, options.lanes); ++i) {
    auto lane = std::make_unique<Lane>();
    cl_int err = CL_SUCCESS;
    lane->queue =
        clCreateCommandQueue(engine->runtime_->context(), engine->runtime_->device(), 0, &err);
    if (err != CL_SUCCESS)
      return Status::Internal("clCreateCommandQueue failed: " + ClErrorName(err));
    lane->dummy = clCreateBuffer(engine->runtime_->context(), CL_MEM_READ_ONLY, 4 * sizeof(float),
                                 nullptr, &err);
    if (err != CL_SUCCESS) return Status::Internal("clCreateBuffer failed: " + ClErrorName(err));
    engine->lanes_.push_back(std::move(lane));
  }
  *out = std::move(engine);
  return Status::Ok();
}

DeviceEngine::~DeviceEngine() {
  lanes_.clear();
  for (cl_mem t : ltc_tables_)
    if (t) clReleaseMemObject(t);
}

Status DeviceEngine::CachedKernel(Lane &lane, const std::string &source, const char *name,
                                  const std::string &options, cl_kernel *out) {
  const std::string key = std::string(name) + '\n' + options;
  auto it = lane.kernels.find(key);
  if (it != lane.kernels.end()) {
    *out = it->second;
    return Status::Ok();
  }
  cl_program program = nullptr;
  Status s = runtime_->GetProgram(source, options, &program);
  if (!s.ok()) return s;
  cl_int err = CL_SUCCESS;
  cl_kernel kernel = clCreateKernel(program, name, &err);
  if (err != CL_SUCCESS) return Status::Internal("clCreateKernel failed: " + ClErrorName(err));
  lane.kernels.emplace(key, kernel);
  *out = kernel;
  return Status::Ok();
}

Status DeviceEngine::AreaKernelFor(Lane &lane, const KernelSpec &spec, cl_kernel *out) {
  // One query per work-item: polygon.h branches per query.
  return CachedKernel(lane, area_source_, "glint_smooth_area",
                      spec.BuildOptions() + " -DGLINT_LANES=1 -DGLINT_AREA_KERNEL=1", out);
}

Status DeviceEngine::EvaluateArea(Lane &lane, const EvalPlan &plan, const glint::v1::QueryBatch &q,
                                  cl_mem a_out, bool accumulate) {
  cl_kernel kernel = nullptr;
  Status s = AreaKernelFor(lane, plan.spec, &kernel);
  if (!s.ok()) return s;
  const cl_uint n = q.count();
  cl_context ctx = runtime_->context();
  Buffer wo, pos, nrm, tan, mat, poly;
  cl_mem a_wo, a_pos, a_nrm, a_tan, a_mat, a_poly;
  s = MakeInputs(ctx, lane.dummy,
                 {{q.wo().data(), size_t(q.wo_size()), &wo, &a_wo},
                  {q.position().data(), size_t(q.position_size()), &pos, &a_pos},
                  {q.normal().data(), size_t(q.normal_size()), &nrm, &a_nrm},
                  {q.tangent().data(), size_t(q.tangent_size()), &tan, &a_tan},
                  {plan.material.data(), plan.material.size(), &mat, &a_mat},
                  {plan.polygon.data(), plan.polygon.size(), &poly, &a_poly}});
  if (!s.ok()) return s;
  cl_mem table = ltc_tables_[plan.spec.ndf == 2 ? 1 : 0];
  const cl_uint n_poly = plan.n_polygon;
  const cl_int method = plan.area_method, samples = plan.area_samples, acc = accumulate ? 1 : 0;
  cl_uint arg = 0;
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n));
  for (cl_mem *m : {&a_wo, &a_pos, &a_nrm, &a_tan, &a_mat, &a_poly})
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), m));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n_poly));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), &table));
  for (const cl_int *v : {&method, &samples})
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_int), v));
  for (const cl_uint *v : {&plan.seed_lo, &plan.seed_hi})
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), v));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_int), &acc));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), &a_out));
  const size_t local = options_.local_size;
  const size_t global = (size_t(n) + local - 1) / local * local;
  GLINT_CL_CHECK(
      clEnqueueNDRangeKernel(lane.queue, kernel, 1, nullptr, &global, &local, 0, nullptr, nullptr));
  // The input buffers above wrap request memory and die with this call: wait for the kernel.
  GLINT_CL_CHECK(clFinish(lane.queue));
  return Status::Ok();
}

Status DeviceEngine::EvaluateBinomial(Lane &lane, const EvalPlan &plan,
                                      const glint::v1::QueryBatch &q, float *out_rgb) {
  cl_kernel kernel = nullptr;
  // One query per work-item: the counting loops branch per query.
  Status s = CachedKernel(lane, binomial_source_, "glint_binomial",
                          plan.spec.BuildOptions() + " -DGLINT_LANES=1", &kernel);
  if (!s.ok()) return s;
  const cl_uint n = q.count();
  cl_context ctx = runtime_->context();
  Buffer uv, fp, wo, pos, nrm, tan, mat, bin, dir, pnt, poly, out;
  cl_mem a_uv, a_fp, a_wo, a_pos, a_nrm, a_tan, a_mat, a_bin, a_dir, a_pnt, a_poly;
  s = MakeInputs(ctx, lane.dummy,
                 {{q.uv().data(), size_t(q.uv_size()), &uv, &a_uv},
                  {q.footprint().data(), size_t(q.footprint_size()), &fp, &a_fp},
                  {q.wo().data(), size_t(q.wo_size()), &wo, &a_wo},
                  {q.position().data(), size_t(q.position_size()), &pos, &a_pos},
                  {q.normal().data(), size_t(q.normal_size()), &nrm, &a_nrm},
                  {q.tangent().data(), size_t(q.tangent_size()), &tan, &a_tan},
                  {plan.material.data(), plan.material.size(), &mat, &a_mat},
                  {plan.binomial.data(), plan.binomial.size(), &bin, &a_bin},
                  {plan.directional.data(), plan.directional.size(), &dir, &a_dir},
                  {plan.point.data(), plan.point.size(), &pnt, &a_pnt},
                  {plan.polygon.data(), plan.polygon.size(), &poly, &a_poly}});
  if (!s.ok()) return s;
  cl_int err = CL_SUCCESS;
  const size_t out_bytes = size_t(n) * 3 * sizeof(float);
  *out.out() =
      clCreateBuffer(ctx, CL_MEM_WRITE_ONLY | CL_MEM_USE_HOST_PTR, out_bytes, out_rgb, &err);
  if (err != CL_SUCCESS)
    return Status::Internal("clCreateBuffer (output) failed: " + ClErrorName(err));
  cl_mem a_out = out.get();
  cl_mem table = ltc_tables_[plan.spec.ndf == 2 ? 1 : 0];
  const cl_uint n_dir = plan.n_directional, n_pnt = plan.n_point, n_poly = plan.n_polygon;
  const cl_int method = plan.area_method, samples = plan.area_samples;
  cl_uint arg = 0;
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n));
  for (cl_mem *m : {&a_uv, &a_fp, &a_wo, &a_pos, &a_nrm, &a_tan, &a_mat, &a_bin, &a_dir})
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), m));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n_dir));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), &a_pnt));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n_pnt));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), &a_poly));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n_poly));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), &table));
  for (const cl_int *v : {&method, &samples})
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_int), v));
  for (const cl_uint *v : {&plan.seed_lo, &plan.seed_hi})
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), v));
  GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), &a_out));
  const size_t local = options_.local_size;
  const size_t global = (size_t(n) + local - 1) / local * local;
  GLINT_CL_CHECK(
      clEnqueueNDRangeKernel(lane.queue, kernel, 1, nullptr, &global, &local, 0, nullptr, nullptr));
  return ReadBackAndFinish(lane.queue, a_out, out_bytes);
}

Status DeviceEngine::KernelFor(Lane &lane, const KernelSpec &spec, cl_kernel *out) {
  if (spec.fp64 && !runtime_->info().fp64) {
    return Status::InvalidArgument("precision: FP64 requested but " + runtime_->info().name +
                                   " has no cl_khr_fp64");
  }
  return CachedKernel(lane, smooth_source_, "glint_smooth", DeviceBuildOptions(spec), out);
}

Status DeviceEngine::Evaluate(int lane_index, const EvalPlan &plan, const glint::v1::QueryBatch &q,
                              float *out_rgb) {
  Lane &lane = *lanes_.at(size_t(lane_index));
  if (plan.spec.fp64 && !runtime_->info().fp64) {
    return Status::InvalidArgument("precision: FP64 requested but " + runtime_->info().name +
                                   " has no cl_khr_fp64");
  }
  if (plan.spec.model == 2) {
    Status s = q.count() ? EvaluateBinomial(lane, plan, q, out_rgb) : Status::Ok();
    if (s.ok()) SaturateRadiance(out_rgb, 3 * size_t(q.count()));
    return s;
  }
  const bool smooth_lights = plan.spec.probe || plan.n_directional > 0 || plan.n_point > 0;
  cl_kernel kernel = nullptr;
  Status s =
      smooth_lights || plan.n_polygon == 0 ? KernelFor(lane, plan.spec, &kernel) : Status::Ok();
  if (!s.ok()) return s;
  if (plan.spec.fp64 && !runtime_->info().fp64) {
    return Status::InvalidArgument("precision: FP64 requested but " + runtime_->info().name +
                                   " has no cl_khr_fp64");
  }
  const cl_uint n = q.count();
  if (n == 0) return Status::Ok();
  cl_context ctx = runtime_->context();

  Buffer wo, wi, pos, nrm, tan, mat, dir, pnt, out;
  cl_mem a_wo, a_wi, a_pos, a_nrm, a_tan, a_mat, a_dir, a_pnt;
  s = MakeInputs(ctx, lane.dummy,
                 {{q.wo().data(), size_t(q.wo_size()), &wo, &a_wo},
                  {q.wi().data(), size_t(q.wi_size()), &wi, &a_wi},
                  {q.position().data(), size_t(q.position_size()), &pos, &a_pos},
                  {q.normal().data(), size_t(q.normal_size()), &nrm, &a_nrm},
                  {q.tangent().data(), size_t(q.tangent_size()), &tan, &a_tan},
                  {plan.material.data(), plan.material.size(), &mat, &a_mat},
                  {plan.directional.data(), plan.directional.size(), &dir, &a_dir},
                  {plan.point.data(), plan.point.size(), &pnt, &a_pnt}});
  if (!s.ok()) return s;
  cl_int err = CL_SUCCESS;
  // The kernel writes the caller's array directly (CPU device: no separate
  // allocation to fault in, no copy back); the map below synchronises it.
  const size_t out_bytes = size_t(n) * 3 * sizeof(float);
  // Read-write when the polygon kernel adds to what glint_smooth wrote.
  const cl_mem_flags out_flags = plan.n_polygon > 0 ? CL_MEM_READ_WRITE : CL_MEM_WRITE_ONLY;
  *out.out() = clCreateBuffer(ctx, out_flags | CL_MEM_USE_HOST_PTR, out_bytes, out_rgb, &err);
  if (err != CL_SUCCESS)
    return Status::Internal("clCreateBuffer (output) failed: " + ClErrorName(err));
  cl_mem a_out = out.get();
  const cl_uint n_dir = plan.n_directional, n_pnt = plan.n_point;

  if (kernel) {
    cl_uint arg = 0;
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n));
    for (cl_mem *m : {&a_wo, &a_wi, &a_pos, &a_nrm, &a_tan, &a_mat, &a_dir})
      GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), m));
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n_dir));
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), &a_pnt));
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_uint), &n_pnt));
    GLINT_CL_CHECK(clSetKernelArg(kernel, arg++, sizeof(cl_mem), &a_out));

    const size_t local = options_.local_size;
    const size_t work_items = (size_t(n) + kQueriesPerWorkItem - 1) / kQueriesPerWorkItem;
    const size_t global = (work_items + local - 1) / local * local;
    GLINT_CL_CHECK(clEnqueueNDRangeKernel(lane.queue, kernel, 1, nullptr, &global, &local, 0,
                                          nullptr, nullptr));
  }
  // In-order queue: the polygon kernel runs after glint_smooth and adds to its output.
  if (plan.n_polygon > 0) {
    s = EvaluateArea(lane, plan, q, a_out, kernel != nullptr);
    if (!s.ok()) return s;
  }
  s = ReadBackAndFinish(lane.queue, a_out, out_bytes);
  if (s.ok()) SaturateRadiance(out_rgb, 3 * size_t(n));
  return s;
}

Status DeviceEngine::Warm(const KernelSpec &spec) {
  // A tiny plan of the right shape: one probe or one light of each kind used.
  glint::v1::QueryBatch q;
  q.set_count(1);
  for (float v : {0.0f, 0.0f, 1.0f}) q.add_wo(v);
  if (spec.probe)
    for (float v : {0.0f, 0.0f, 1.0f}) q.add_wi(v);
  if (spec.has_frame) {
    for (float v : {0.0f, 0.0f, 0.0f}) q.add_position(v);
    for (float v : {0.0f, 0.0f, 1.0f}) q.add_normal(v);
    for (float v : {1.0f, 0.0f, 0.0f}) q.add_tangent(v);
  }
  EvalPlan plan;
  plan.spec = spec;
  plan.material = {0.5f, 0.5f, 0.04f, 0.04f, 0.04f, 0.0f, 0.0f, 0.0f};
  if (spec.has_directional) {
    plan.directional = {0, 0, 1, 1, 1, 1, 1, 0};
    plan.n_directional = 1;
  }
  if (spec.has_point) {
    plan.point = {0, 0, 1, 1, 1, 1, 0.1f, 0};
    plan.n_point = 1;
  }
  if (spec.has_polygon) {
    plan.polygon.assign(56, 0.0f);  // GLINT_POLYGON_FLOATS: a unit-radiance triangle overhead
    const float record[] = {3, 1, 1, 1, 1, 0, 0, 0, -1, -1, 2, 1, -1, 2, 0, 1, 2};
    std::copy(std::begin(record), std::end(record), plan.polygon.begin());
    plan.n_polygon = 1;
  }
  if (spec.model == 2) {
    for (float v : {0.5f, 0.5f}) q.add_uv(v);
    for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) q.add_footprint(v);
    plan.binomial = {1e6f, 1, 1, 9, 0.05f, 0, 0, 0};
  }
  float rgb[3];
  for (int lane = 0; lane < lanes(); ++lane) {
    Status s = Evaluate(lane, plan, q, rgb);
    if (!s.ok()) return s;
  }
  return Status::Ok();
}

}  // namespace glint
