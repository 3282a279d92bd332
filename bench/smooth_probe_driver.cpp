// The glint side of bench/mitsuba_compare.py: SMOOTH BRDF probes of one material over direction
// pairs read from raw float32 files, on the in-process device path (DeviceEngine::Evaluate: the
// input buffers wrap the request's arrays, the kernel, the read-back into the caller's array,
// exactly as the service runs a request) or on the host path (HostEvaluate, one thread).
// Driven over stdin so that the Python script can interleave its rounds with Mitsuba's in one
// process pair:
//   round K   -> runs K evaluations, prints one line "seconds w1,c1 ... wK,cK": wall and CPU
//                seconds (all threads) of each
//   write     -> writes the last output (n x RGB float32) to --out, prints "ok"
//   quit
// The inputs are built once (the "inputs in memory" of the comparison); the output array is
// allocated and touched once, before the first round (the device writes into it in place).
//
//   smooth_probe_driver --wo WO.f32 --wi WI.f32 --out OUT.f32 --material conductor
//                       [--path device|host] [--precision fp32|fp64] [--cache-dir DIR]
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "server/eval_plan.h"
#include "server/host_path.h"

namespace {

bool ReadFloats(const std::string &path, std::vector<float> *out) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) return false;
  const std::streamsize bytes = f.tellg();
  if (bytes <= 0 || bytes % (3 * sizeof(float)) != 0) return false;
  out->resize(size_t(bytes) / sizeof(float));
  f.seekg(0);
  return bool(f.read(reinterpret_cast<char *>(out->data()), bytes));
}

// CPU seconds of every thread of the process (PoCL's workers included): with other work on the
// machine, CPU time per evaluation is the load-independent cost, wall time is not.
double CpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

int Fail(const std::string &why) {
  std::fprintf(stderr, "smooth_probe_driver: %s\n", why.c_str());
  return 1;
}

}  // namespace

int main(int argc, char **argv) {
  std::string wo_path, wi_path, out_path, material = "conductor", path = "device";
  std::string precision = "fp32";
  std::string cache_dir = glint::bench::DefaultCacheDir();
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--wo")
      wo_path = v;
    else if (a == "--wi")
      wi_path = v;
    else if (a == "--out")
      out_path = v;
    else if (a == "--material")
      material = v;
    else if (a == "--path")
      path = v;
    else if (a == "--precision")
      precision = v;
    else if (a == "--cache-dir")
      cache_dir = v;
    else
      return Fail("unknown option " + a);
  }
  if (material != "conductor" && material != "schlick")
    return Fail("--material: expected conductor or schlick, got " + material);
  if (path != "device" && path != "host") return Fail("--path: expected device or host");
  if (precision != "fp32" && precision != "fp64") return Fail("--precision: expected fp32 or fp64");
  std::vector<float> wo, wi;
  if (!ReadFloats(wo_path, &wo)) return Fail("--wo " + wo_path + ": expected n x 3 float32");
  if (!ReadFloats(wi_path, &wi) || wi.size() != wo.size())
    return Fail("--wi " + wi_path + ": expected as many n x 3 float32 as --wo");
  const uint32_t n = uint32_t(wo.size() / 3);

  // The material of the issue 13 comparison (bench/cases/smooth.cpp, "conductor").
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  if (material == "conductor") {
    for (float v : {0.2f, 0.4f, 1.4f}) m->mutable_conductor()->add_eta(v);
    for (float v : {3.9f, 2.4f, 1.8f}) m->mutable_conductor()->add_k(v);
  } else {
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  }
  r.set_precision(precision == "fp64" ? glint::v1::FP64 : glint::v1::FP32);
  auto *q = r.mutable_queries();
  q->set_count(n);
  q->mutable_wo()->Add(wo.begin(), wo.end());
  q->mutable_wi()->Add(wi.begin(), wi.end());
  if (glint::Status s = glint::bench::Validate(r, true); !s.ok()) return Fail(s.message());
  const glint::EvalPlan plan = glint::MakeEvalPlan(r, *q);

  std::unique_ptr<glint::DeviceEngine> engine;
  if (path == "device") {
    if (glint::Status s = glint::bench::CreateEngine(cache_dir, &engine); !s.ok())
      return Fail(s.message());
  }
  std::vector<float> out(3 * size_t(n), 0.0f);
  auto run = [&]() -> bool {
    if (!engine) {
      glint::HostEvaluate(plan, *q, out.data());
      return true;
    }
    glint::Status s = engine->Evaluate(0, plan, *q, out.data());
    if (!s.ok()) std::fprintf(stderr, "smooth_probe_driver: %s\n", s.message().c_str());
    return s.ok();
  };
  if (!run()) return 1;  // compile (or load) and warm
  std::printf("ready %u\n", n);
  std::fflush(stdout);
  for (std::string cmd; std::cin >> cmd;) {
    if (cmd == "round") {
      int k = 0;
      std::cin >> k;
      std::printf("seconds");
      for (int j = 0; j < k; ++j) {
        const auto t0 = glint::bench::Clock::now();
        const double c0 = CpuSeconds();
        if (!run()) return 1;
        std::printf(" %.9f,%.9f",
                    std::chrono::duration<double>(glint::bench::Clock::now() - t0).count(),
                    CpuSeconds() - c0);
      }
      std::printf("\n");
    } else if (cmd == "write") {
      std::ofstream f(out_path, std::ios::binary);
      f.write(reinterpret_cast<const char *>(out.data()), std::streamsize(out.size() * 4));
      std::printf(f ? "ok\n" : "error\n");
    } else if (cmd == "quit") {
      break;
    }
    std::fflush(stdout);
  }
  return 0;
}
