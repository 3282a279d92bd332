// Where the device time of SMOOTH conductor probes goes (issue 13): the same N fp32 direction
// pairs (uniform on the upper hemisphere) and the material of bench/mitsuba_compare.py, timed
//   engine   DeviceEngine::Evaluate, the service's in-process path (buffers wrap the request's
//            arrays, one enqueue, map of the output, finish)
//   kernel   the same program enqueued on buffers created once, then clFinish (kernel + launch)
//   launch   the same kernel on a 1-query range (launch and finish, no work)
//   buffers  creating and releasing the 3 CL_MEM_USE_HOST_PTR buffers alone
//   copy     CL_MEM_ALLOC_HOST_PTR buffers with write, kernel, read (the non-zero-copy way)
// for each local size and lane count asked for, in interleaved rounds (medians). Extra build
// options (e.g. -D switches of an experiment) go in --options. PoCL's own settings
// (POCL_AFFINITY, POCL_WORK_GROUP_METHOD, ...) are environment variables of the run.
//
//   smooth_probe_breakdown [--n 1048576] [--rounds 7] [--local 32,128,512] [--lanes 8,16]
//                          [--material conductor|schlick] [--options "..."]
//                          [--kernel-file EXPANDED.cl[:K][,B.cl[:K],...] [--queries-per-item K]]
// Several --kernel-file entries (comma-separated) each get their own kernel rows, tagged with the
// file's position (K0, K1, ...), timed in the same interleaved rounds: an A/B of two variants of
// the entry in one process, under the same load.
#include <CL/cl.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "kernels/layout.h"
#include "server/cl_runtime.h"
#include "server/kernel_source.h"
#include "server/launch_grid.h"
#include "server/model_table.h"

namespace {

using glint::bench::Clock;

std::vector<int> ParseList(const std::string &s) {
  std::vector<int> v;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) v.push_back(std::stoi(item));
  return v;
}

void Hemisphere(std::mt19937 &rng, uint32_t n, std::vector<float> *out) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  out->resize(3 * size_t(n));
  for (uint32_t i = 0; i < n; ++i) {
    const double z = std::max(u(rng), 1e-4), r = std::sqrt(1.0 - z * z), phi = 2 * M_PI * u(rng);
    (*out)[3 * i] = float(r * std::cos(phi));
    (*out)[3 * i + 1] = float(r * std::sin(phi));
    (*out)[3 * i + 2] = float(z);
  }
}

// CPU seconds of every thread of the process (PoCL's workers included): less sensitive to other
// processes' load than wall time.
double CpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

int Fail(const std::string &why) {
  std::fprintf(stderr, "smooth_probe_breakdown: %s\n", why.c_str());
  return 1;
}

#define CHECK_CL(call)                                                                     \
  do {                                                                                     \
    cl_int e_ = (call);                                                                    \
    if (e_ != CL_SUCCESS) return Fail(std::string(#call) + ": " + glint::ClErrorName(e_)); \
  } while (0)

}  // namespace

int main(int argc, char **argv) {
  uint32_t n = 1u << 20;
  int rounds = 7;
  std::vector<int> locals = {128}, lanes_list = {16};
  int per_item = 0;  // queries per work-item of a --kernel-file entry; 0: its lanes
  std::string material = "conductor", extra, kernel_file;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--n")
      n = uint32_t(std::stoul(v));
    else if (a == "--rounds")
      rounds = std::stoi(v);
    else if (a == "--local")
      locals = ParseList(v);
    else if (a == "--lanes")
      lanes_list = ParseList(v);
    else if (a == "--material")
      material = v;
    else if (a == "--options")
      extra = v;
    else if (a == "--kernel-file")
      kernel_file = v;
    else if (a == "--queries-per-item")
      per_item = std::stoi(v);
    else
      return Fail("unknown option " + a);
  }
  std::mt19937 rng(13);
  std::vector<float> wo, wi;
  Hemisphere(rng, n, &wo);
  Hemisphere(rng, n, &wi);
  std::vector<float> out(3 * size_t(n), 0.0f), out2(out.size(), 0.0f);
  const bool conductor = material == "conductor";
  // kernels/layout.h GLINT_MATERIAL_FLOATS: alpha_x, alpha_y, a.rgb, b.rgb.
  std::vector<float> mat = conductor
                               ? std::vector<float>{0.3f, 0.1f, 0.2f, 0.4f, 1.4f, 3.9f, 2.4f, 1.8f}
                               : std::vector<float>{0.3f, 0.1f, 0.9f, 0.6f, 0.3f, 0, 0, 0};

  // The service's path, for reference.
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  if (conductor) {
    for (float v : {0.2f, 0.4f, 1.4f}) m->mutable_conductor()->add_eta(v);
    for (float v : {3.9f, 2.4f, 1.8f}) m->mutable_conductor()->add_k(v);
  } else {
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  }
  auto *q = r.mutable_queries();
  q->set_count(n);
  q->mutable_wo()->Add(wo.begin(), wo.end());
  q->mutable_wi()->Add(wi.begin(), wi.end());
  const glint::EvalPlan plan = glint::MakeEvalPlan(r, *q);
  std::unique_ptr<glint::DeviceEngine> engine;
  if (glint::Status s = glint::bench::CreateEngine(glint::bench::DefaultCacheDir(), &engine);
      !s.ok())
    return Fail(s.message());

  std::unique_ptr<glint::ClRuntime> rt;
  if (glint::Status s = glint::ClRuntime::Create("", glint::bench::DefaultCacheDir(), &rt); !s.ok())
    return Fail(s.message());
  cl_context ctx = rt->context();
  cl_int err = CL_SUCCESS;
  cl_command_queue queue = clCreateCommandQueue(ctx, rt->device(), 0, &err);
  CHECK_CL(err);
  // --kernel-file: self-contained (include-free) variants of the entry for experiments.
  std::vector<std::string> sources;
  std::vector<int> file_per_item;  // queries per work-item of each --kernel-file variant
  if (kernel_file.empty()) sources.push_back(glint::ExpandKernelSource("models/smooth/smooth.cl"));
  for (size_t pos = 0; !kernel_file.empty() && pos <= kernel_file.size();) {
    const size_t comma = std::min(kernel_file.find(',', pos), kernel_file.size());
    std::string file = kernel_file.substr(pos, comma - pos);
    // FILE:K: this variant evaluates K queries per work-item (else --queries-per-item).
    const size_t colon = file.rfind(':');
    file_per_item.push_back(colon == std::string::npos ? per_item
                                                       : std::stoi(file.substr(colon + 1)));
    if (colon != std::string::npos) file.resize(colon);
    std::ifstream f(file);
    if (!f) return Fail("--kernel-file " + file + ": cannot read");
    sources.emplace_back(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    pos = comma + 1;
  }

  auto make = [&](cl_mem_flags flags, void *host, size_t bytes) {
    cl_int e = CL_SUCCESS;
    cl_mem b = clCreateBuffer(ctx, flags, bytes, host, &e);
    if (e != CL_SUCCESS) std::abort();
    return b;
  };
  const size_t bytes = 3 * size_t(n) * sizeof(float);
  cl_mem b_wo = make(CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, wo.data(), bytes);
  cl_mem b_wi = make(CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, wi.data(), bytes);
  cl_mem b_mat = make(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, mat.data(), mat.size() * 4);
  cl_mem b_out = make(CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR, out.data(), bytes);
  cl_mem dummy = make(CL_MEM_READ_ONLY, nullptr, 16);
  cl_mem a_wo = make(CL_MEM_READ_ONLY | CL_MEM_ALLOC_HOST_PTR, nullptr, bytes);
  cl_mem a_wi = make(CL_MEM_READ_ONLY | CL_MEM_ALLOC_HOST_PTR, nullptr, bytes);
  cl_mem a_out = make(CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, nullptr, bytes);

  // Arguments in GLINT_KERNEL_ARGS order (kernels/kernel_args.h), probes only.
  auto bind = [&](cl_kernel k, cl_uint count, cl_mem w_o, cl_mem w_i, cl_mem o) -> cl_int {
    cl_uint idx = 0;
    cl_int e = CL_SUCCESS;
    auto val = [&](const auto &v) { e |= clSetKernelArg(k, idx++, sizeof(v), &v); };
    const cl_uint zero = 0;
    const cl_int izero = 0;
    val(count);
    for (cl_mem b : {dummy, dummy, w_o, w_i, dummy, dummy, dummy, b_mat}) val(b);
    cl_float8 mat_values{};  // the material again, by value (kernels/kernel_args.h)
    std::copy(mat.begin(), mat.end(), mat_values.s);
    val(mat_values);
    for (cl_mem b : {dummy, dummy}) val(b);
    val(zero);
    val(dummy);
    val(zero);
    val(dummy);
    val(zero);
    val(dummy);  // ltc table
    val(dummy);  // model table
    val(izero);
    val(izero);
    val(zero);
    val(zero);
    val(izero);  // accumulate
    val(o);
    return e;
  };

  struct Config {
    std::string name;
    std::function<bool()> run;
    std::vector<double> t, cpu;
  };
  std::vector<Config> configs;
  auto add = [&](const std::string &name, std::function<bool()> run) {
    configs.push_back(Config{name, std::move(run), {}, {}});
  };
  float rgb_probe[3];
  (void)rgb_probe;
  add("engine (service path)", [&] { return engine->Evaluate(0, plan, *q, out2.data()).ok(); });
  std::vector<cl_kernel> kernels;
  const glint::Model *smooth = glint::FindModel(glint::v1::SMOOTH);
  const int engine_blocks = smooth ? smooth->passes[0].Blocks(false, true) : 1;
  std::vector<size_t> checks;  // the configs that run a kernel into `out`
  for (size_t si = 0; si < sources.size(); ++si)
    for (int lanes : lanes_list) {
      const std::string &source = sources[si];
      std::string ktag;  // (appended, not "K" + ...: GCC 12's -Wrestrict false positive)
      if (sources.size() > 1) ktag.append("K").append(std::to_string(si)).append(" ");
      glint::KernelSpec spec = plan.spec;
      // The service's blocks per work-item (server/model.h probe_blocks_fp32) for this build's
      // entry; a --kernel-file variant says its own (FILE:K, GLINT_BLOCKS in --options).
      const int blocks = kernel_file.empty() ? engine_blocks : 1;
      std::string options = spec.BuildOptions() + " -DGLINT_LANES=" + std::to_string(lanes) +
                            (extra.empty() ? "" : " " + extra);
      if (blocks > 1) options += " -DGLINT_BLOCKS=" + std::to_string(blocks);
      cl_program program = nullptr;
      if (glint::Status s = rt->GetProgram(source, options, &program); !s.ok())
        return Fail(s.message());
      cl_kernel k = clCreateKernel(program, "glint_smooth", &err);
      CHECK_CL(err);
      kernels.push_back(k);
      // A --local the device or this kernel refuses would only fail as "kernel ... failed": said
      // here instead (the engine lowers its own sizes, server/work_group_size.h; this bench
      // measures the sizes asked for, so it does not).
      size_t kernel_max = 0;
      CHECK_CL(clGetKernelWorkGroupInfo(k, rt->device(), CL_KERNEL_WORK_GROUP_SIZE,
                                        sizeof kernel_max, &kernel_max, nullptr));
      for (int local : locals)
        if (local < 1 || size_t(local) > kernel_max)
          return Fail("--local " + std::to_string(local) + ": this kernel takes 1.." +
                      std::to_string(kernel_max) + " work-items per group on this device");
      for (int local : locals) {
        const int k_per = si < file_per_item.size() ? file_per_item[si] : per_item;
        const size_t q_per = size_t(k_per > 0 ? k_per : lanes * blocks);
        const size_t wis = (n + q_per - 1) / q_per;
        // The device engine's 2D grid (server/launch_grid.h): no large-grid recompile in a round.
        const glint::LaunchGrid grid = glint::GridFor(wis, size_t(local));
        char tag_text[64];
        std::snprintf(tag_text, sizeof tag_text, "L%d local %d", lanes, local);
        const std::string tag = ktag + tag_text;
        checks.push_back(configs.size());
        add("kernel " + tag, [=, &queue] {
          if (bind(k, n, b_wo, b_wi, b_out) != CL_SUCCESS) return false;
          if (clEnqueueNDRangeKernel(queue, k, 2, nullptr, grid.global, grid.local, 0, nullptr,
                                     nullptr) != CL_SUCCESS)
            return false;
          return clFinish(queue) == CL_SUCCESS;
        });
        add("copy " + tag, [=, &queue, &wo, &wi, &out] {
          clEnqueueWriteBuffer(queue, a_wo, CL_FALSE, 0, bytes, wo.data(), 0, nullptr, nullptr);
          clEnqueueWriteBuffer(queue, a_wi, CL_FALSE, 0, bytes, wi.data(), 0, nullptr, nullptr);
          if (bind(k, n, a_wo, a_wi, a_out) != CL_SUCCESS) return false;
          clEnqueueNDRangeKernel(queue, k, 2, nullptr, grid.global, grid.local, 0, nullptr,
                                 nullptr);
          return clEnqueueReadBuffer(queue, a_out, CL_TRUE, 0, bytes, out.data(), 0, nullptr,
                                     nullptr) == CL_SUCCESS;
        });
      }
      const size_t one = 1;
      add(ktag + "launch L" + std::to_string(lanes) + " (1 query)", [=, &queue] {
        if (bind(k, 1, b_wo, b_wi, b_out) != CL_SUCCESS) return false;
        clEnqueueNDRangeKernel(queue, k, 1, nullptr, &one, &one, 0, nullptr, nullptr);
        return clFinish(queue) == CL_SUCCESS;
      });
    }
  add("buffers (create + release 3)", [&] {
    cl_mem a = make(CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, wo.data(), bytes);
    cl_mem b = make(CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, wi.data(), bytes);
    cl_mem c = make(CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR, out.data(), bytes);
    clReleaseMemObject(a);
    clReleaseMemObject(b);
    clReleaseMemObject(c);
    return true;
  });
  for (auto &c : configs)
    if (!c.run()) return Fail(c.name + " failed");  // compile, warm
  for (int round = 0; round < rounds; ++round)
    for (auto &c : configs)
      for (int j = 0; j < 3; ++j) {
        const auto t0 = Clock::now();
        const double c0 = CpuSeconds();
        if (!c.run()) return Fail(c.name + " failed");
        c.t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
        c.cpu.push_back(CpuSeconds() - c0);
      }
  std::printf("n = %u, %s, options '%s', %d interleaved rounds x 3 (medians)\n\n", n,
              material.c_str(), extra.c_str(), rounds);
  std::printf(
      "| what | wall ms | M evals/s | CPU ms (all threads) | M evals per CPU-s |\n"
      "|---|---|---|---|---|\n");
  for (auto &c : configs) {
    std::sort(c.t.begin(), c.t.end());
    std::sort(c.cpu.begin(), c.cpu.end());
    const double t = c.t[c.t.size() / 2], cpu = c.cpu[c.cpu.size() / 2];
    std::printf("| %s | %.3f | %.0f | %.3f | %.0f |\n", c.name.c_str(), 1e3 * t, n / t / 1e6,
                1e3 * cpu, cpu > 0 ? n / cpu / 1e6 : 0.0);
  }
  // The engine and the kernel agree (same program, same inputs): a sanity check of the set-up.
  // With several --kernel-file variants, whether each gives the service's bits.
  std::printf("\n");
  for (size_t c : checks) {
    std::fill(out.begin(), out.end(), 0.0f);
    if (!configs[c].run()) return Fail(configs[c].name + " failed");
    size_t differ = 0;
    for (size_t i = 0; i < out.size(); ++i) differ += out[i] != out2[i];
    std::printf("engine vs %s outputs differing: %zu of %zu\n", configs[c].name.c_str(), differ,
                out.size());
  }
  for (cl_kernel k : kernels) clReleaseKernel(k);
  for (cl_mem b : {b_wo, b_wi, b_mat, b_out, dummy, a_wo, a_wi, a_out}) clReleaseMemObject(b);
  clReleaseCommandQueue(queue);
  return 0;
}
