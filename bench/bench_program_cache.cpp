// What a program-binary disk cache costs and buys on this OpenCL platform (issue 13, first
// compile cost). For real kernel programs of the model table (the passes of glintd's --warm common
// variants), interleaved rounds, in one process, on a fresh PoCL cache directory of its own:
//   build        clCreateProgramWithSource + clBuildProgram, cold (each build a new -D salt, so
//                neither PoCL's kernel cache nor any earlier round helps)
//   binaries     clGetProgramInfo(CL_PROGRAM_BINARY_SIZES, CL_PROGRAM_BINARIES) after a cold build:
//                what ClRuntime's .clbin cache adds to every compile (PoCL 3.1 compiles a generic
//                work-group function of every kernel of the program for its binary)
//   rebuild      a second clCreateProgramWithSource + clBuildProgram of a program built before, in
//                a new cl_program (PoCL's own cache answers: what a restart costs without .clbin)
//   load         clCreateProgramWithBinary + clBuildProgram from those binaries (the .clbin load)
// The kernels are not enqueued: the work-group function PoCL compiles at a kernel's first enqueue
// (local size 128, specialised) is the same work in every arm. Prints medians per program and the
// ratio binaries / build; --json PATH writes them. Label the numbers "loaded" on a shared machine.
//
//   build/bench/bench_program_cache [--rounds R] [--match TEXT] [--json PATH]
// --match selects programs whose "<variant> <entry>" contains TEXT (default: the first SMOOTH
// probe program, the SMOOTH LTC polygon program and the first BINOMIAL program).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "server/cl_runtime.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/kernel_source.h"
#include "server/model_table.h"
#include "server/warmup.h"

namespace glint {
namespace {

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct Program {
  std::string name, kernel_file, options;
};

// The programs glintd's --warm common builds: every needed pass of every declared variant.
std::vector<Program> WarmPrograms() {
  std::vector<Program> out;
  std::set<std::string> seen;
  for (const KernelSpec &spec : WarmSpecsFor(WarmMode::kCommon, true)) {
    const Model *model = FindModel(spec.model);
    if (!model) continue;
    EvalPlan plan;  // one light of each kind the spec has; area_method defaults to LTC
    plan.spec = spec;
    plan.n_directional = spec.has_directional, plan.n_point = spec.has_point;
    plan.n_polygon = spec.has_polygon;
    for (const ModelPass &pass : model->passes) {
      if (pass.needed && !pass.needed(plan)) continue;
      Program p{spec.Describe() + " " + pass.entry, pass.kernel_file, PassBuildOptions(pass, spec)};
      if (seen.insert(p.kernel_file + '\n' + p.options).second) out.push_back(p);
    }
  }
  return out;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Arms {
  std::vector<double> build;  // two cold builds per round
  std::vector<double> binaries, rebuild, load;
};

int Main(int argc, char **argv) {
  int rounds = 2;
  std::string match, json;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--rounds")
      rounds = std::max(1, std::atoi(v.c_str()));
    else if (a == "--match")
      match = v;
    else if (a == "--json")
      json = v;
    else {
      std::fprintf(stderr,
                   "usage: bench_program_cache [--rounds R] [--match TEXT] [--json PATH]\n");
      return 2;
    }
  }
  if (argc % 2 == 0) {
    std::fprintf(stderr, "bench_program_cache: %s needs a value\n", argv[argc - 1]);
    return 2;
  }
  // A private PoCL cache, set before the first OpenCL call (PoCL reads it once per process).
  char dir[] = "/tmp/bench_program_cache.XXXXXX";
  if (!mkdtemp(dir)) {
    std::perror("mkdtemp");
    return 1;
  }
  setenv("POCL_CACHE_DIR", dir, 1);
  std::unique_ptr<ClRuntime> rt;
  if (Status s = ClRuntime::Create("", "", &rt); !s.ok()) {
    std::fprintf(stderr, "bench_program_cache: %s\n", s.message().c_str());
    return 1;
  }
  std::vector<Program> programs;
  for (const Program &p : WarmPrograms()) {
    const bool pick = !match.empty() ? p.name.find(match) != std::string::npos
                                     : (p.name.rfind("smooth/ggx/schlick/probe/fp32", 0) == 0 ||
                                        p.name.rfind("smooth/ggx/schlick/polygon/", 0) == 0 ||
                                        p.name.rfind("binomial", 0) == 0);
    if (!pick) continue;
    // The default takes the first program of each of the three kinds.
    if (match.empty() && std::any_of(programs.begin(), programs.end(), [&](const Program &q) {
          return q.name.substr(0, q.name.find('/', q.name.find('/') + 1)) ==
                     p.name.substr(0, p.name.find('/', p.name.find('/') + 1)) &&
                 (q.name.find("/probe") != std::string::npos) ==
                     (p.name.find("/probe") != std::string::npos) &&
                 (q.name.find("/polygon") != std::string::npos) ==
                     (p.name.find("/polygon") != std::string::npos);
        }))
      continue;
    programs.push_back(p);
  }
  if (programs.empty()) {
    std::fprintf(stderr, "bench_program_cache: no program matches '%s'\n", match.c_str());
    return 2;
  }
  const cl_device_id device = rt->device();
  const cl_context context = rt->context();
  auto create = [&](const std::string &source, cl_program *out) {
    const char *text = source.c_str();
    const size_t len = source.size();
    cl_int err = CL_SUCCESS;
    *out = clCreateProgramWithSource(context, 1, &text, &len, &err);
    return err == CL_SUCCESS;
  };
  auto build = [&](cl_program p, const std::string &options) {
    return clBuildProgram(p, 1, &device, options.c_str(), nullptr, nullptr) == CL_SUCCESS;
  };
  int salt = 0;
  const std::string run_salt = std::to_string(getpid()) + std::to_string(time(nullptr));
  std::vector<Arms> arms(programs.size());
  std::printf("device %s (%s %s); PoCL cache %s; %d rounds\n", rt->info().name.c_str(),
              rt->info().platform_name.c_str(), rt->info().driver_version.c_str(), dir, rounds);
  for (int round = 0; round < rounds; ++round)
    for (size_t i = 0; i < programs.size(); ++i) {
      const Program &prog = programs[i];
      const std::string source = ExpandKernelSource(prog.kernel_file);
      // Two cold programs: one built only, one built and asked for its binaries; in alternating
      // order so neither always goes first.
      const std::string opt_a =
          prog.options + " -DGLINT_BENCH_SALT=" + run_salt + "_" + std::to_string(++salt);
      const std::string opt_b =
          prog.options + " -DGLINT_BENCH_SALT=" + run_salt + "_" + std::to_string(++salt);
      std::vector<unsigned char> bytes;
      for (int arm = 0; arm < 2; ++arm) {
        const bool with_binaries = (arm + round) % 2 == 1;
        const std::string &options = with_binaries ? opt_b : opt_a;
        cl_program p = nullptr;
        auto t0 = Clock::now();
        if (!create(source, &p) || !build(p, options)) {
          std::fprintf(stderr, "bench_program_cache: %s does not build\n", prog.name.c_str());
          return 1;
        }
        arms[i].build.push_back(Since(t0));  // both arms' builds are cold builds
        if (with_binaries) {
          t0 = Clock::now();
          size_t size = 0;
          clGetProgramInfo(p, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, nullptr);
          bytes.resize(size);
          unsigned char *ptr = bytes.data();
          clGetProgramInfo(p, CL_PROGRAM_BINARIES, sizeof ptr, &ptr, nullptr);
          arms[i].binaries.push_back(Since(t0));
        }
        clReleaseProgram(p);
      }
      // The warm paths, again alternating: a rebuild from source (PoCL's cache holds opt_a's
      // build) and a load of opt_b's binaries.
      for (int arm = 0; arm < 2; ++arm) {
        const bool load = (arm + round) % 2 == 1;
        cl_program p = nullptr;
        const auto t0 = Clock::now();
        if (load) {
          const unsigned char *data = bytes.data();
          const size_t size = bytes.size();
          cl_int status = CL_SUCCESS, err = CL_SUCCESS;
          p = clCreateProgramWithBinary(context, 1, &device, &size, &data, &status, &err);
          if (err != CL_SUCCESS || !build(p, opt_b)) {
            std::fprintf(stderr, "bench_program_cache: %s: binary does not load\n",
                         prog.name.c_str());
            return 1;
          }
          arms[i].load.push_back(Since(t0));
        } else {
          if (!create(source, &p) || !build(p, opt_a)) return 1;
          arms[i].rebuild.push_back(Since(t0));
        }
        clReleaseProgram(p);
      }
      std::fprintf(stderr,
                   "round %d %s: build %.2f s, binaries %.2f s, rebuild %.3f s, load %.3f s\n",
                   round, prog.name.c_str(), arms[i].build.back(), arms[i].binaries.back(),
                   arms[i].rebuild.back(), arms[i].load.back());
    }
  double load_avg[3] = {0, 0, 0};
  getloadavg(load_avg, 3);
  std::printf("load average %.1f %.1f %.1f at the end (loaded: ratios, not absolute times)\n\n",
              load_avg[0], load_avg[1], load_avg[2]);
  std::printf(
      "| program | cold build s | + binaries query s | binaries / build | rebuild (PoCL cache) s "
      "| load binary s |\n|---|---|---|---|---|---|\n");
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (size_t i = 0; i < programs.size(); ++i) {
    const Arms &a = arms[i];
    const double b = Median(a.build), q = Median(a.binaries), r = Median(a.rebuild),
                 l = Median(a.load);
    std::printf("| %s | %.2f | %.2f | %.2f | %.3f | %.3f |\n", programs[i].name.c_str(), b, q,
                q / b, r, l);
    rows.push_back({{"program", programs[i].name},
                    {"build_s", a.build},
                    {"binaries_s", a.binaries},
                    {"rebuild_s", a.rebuild},
                    {"load_s", a.load}});
  }
  if (!json.empty())
    std::ofstream(json) << nlohmann::ordered_json{{"device", rt->info().name},
                                                  {"driver", rt->info().driver_version},
                                                  {"load_average_end", load_avg[0]},
                                                  {"rows", rows}}
                               .dump(1)
                        << "\n";
  rt.reset();
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return 0;
}

}  // namespace
}  // namespace glint

int main(int argc, char **argv) {
  return glint::Main(argc, argv);
}
