// The BINOMIAL model against the smooth model in interleaved rounds (issue 13: binomial >= 1/10
// of the smooth directional rate), for measuring on a shared machine: every round evaluates
// every request once on the device (DeviceEngine::Evaluate, as bench_models' `device` path), and
// each request's rate is reported as the median over rounds of its ratio to SMOOTH
// directional_point in the same round, by wall time and by the process's CPU time (PoCL's
// worker threads included; less sensitive to other processes' load). The queries, lights and
// materials are bench_models' (bench/lib, bench/cases/binomial.cpp: GGX alpha (0.3, 0.1), the
// density giving N_P facets in the mean footprint, normal threshold 9). A hash of each output's
// bits compares results across builds.
//
//   binomial_breakdown [--n 262144] [--rounds 7] [--lights directional_point,quad]
//                      [--np 1e2,1e4,1e6] [--threshold 9]
//                      [--interpolation trilinear,tetrahedral,stochastic] [--precision fp32]
// --precision fp64 evaluates the BINOMIAL requests in fp64 (SMOOTH directional_point, the
// reference of every ratio, and SMOOTH LTC stay fp32).
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "server/eval_plan.h"

namespace {

using namespace glint;
using namespace glint::bench;

std::vector<std::string> Split(const std::string &s) {
  std::vector<std::string> v;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) v.push_back(item);
  return v;
}

struct Case {
  std::string name;
  glint::v1::EvaluateRequest request;
  std::vector<double> wall, cpu;
  uint64_t hash = 0;  // FNV-1a of the output's bits: results compared across builds
};

}  // namespace

int main(int argc, char **argv) {
  uint32_t n = 1u << 18;
  int rounds = 7;
  float threshold = 9.0f;
  std::vector<std::string> lights = {"directional_point", "quad"}, nps = {"1e2", "1e4", "1e6"};
  std::vector<std::string> interpolations = {"trilinear"};  // footprint_interpolation
  bool fp64 = false;                                        // the BINOMIAL requests' precision
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--n") {
      n = uint32_t(std::stoul(v));
    } else if (a == "--rounds") {
      rounds = std::max(1, std::stoi(v));
    } else if (a == "--lights") {
      lights = Split(v);
    } else if (a == "--np") {
      nps = Split(v);
    } else if (a == "--threshold") {
      threshold = std::stof(v);
    } else if (a == "--interpolation") {
      interpolations = Split(v);
    } else if (a == "--precision") {
      if (v != "fp32" && v != "fp64") {
        std::fprintf(stderr, "binomial_breakdown: --precision %s; expected fp32 or fp64\n",
                     v.c_str());
        return 2;
      }
      fp64 = v == "fp64";
    } else {
      std::fprintf(stderr, "binomial_breakdown: unknown flag %s\n", a.c_str());
      return 2;
    }
  }
  std::unique_ptr<DeviceEngine> engine;
  if (Status s = CreateEngine(DefaultCacheDir(), &engine); !s.ok()) {
    std::fprintf(stderr, "binomial_breakdown: %s\n", s.message().c_str());
    return 1;
  }
  const glint::v1::QueryBatch base = SharedQueries(16384, false);
  const glint::v1::QueryBatch queries = Tile(base, n);
  const QueryStats stats = StatsOf(base);
  auto request = [&](glint::v1::Model model, Lights l) {
    glint::v1::EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(model);
    m->set_ndf(glint::v1::GGX);
    m->set_alpha_x(0.3f);
    m->set_alpha_y(0.1f);
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
    r.set_precision(glint::v1::FP32);
    r.set_seed(0x9e3779b97f4aull);
    *r.mutable_queries() = queries;
    AddLights(l, &r);
    return r;
  };
  std::vector<Case> cases;
  cases.push_back(
      {"SMOOTH directional_point", request(glint::v1::SMOOTH, Lights::kDirectionalPoint), {}, {}});
  for (const std::string &ln : lights) {
    const Lights l = ln == "quad"         ? Lights::kQuad
                     : ln == "four_quads" ? Lights::kFourQuads
                                          : Lights::kDirectionalPoint;
    if (l != Lights::kDirectionalPoint)
      cases.push_back({"SMOOTH LTC " + ln, request(glint::v1::SMOOTH, l), {}, {}});
    for (const std::string &np : nps)
      for (const std::string &interp : interpolations) {
        Case c{"BINOMIAL N_P=" + np + " " + ln + (interpolations.size() > 1 ? " " + interp : ""),
               request(glint::v1::BINOMIAL, l),
               {},
               {}};
        auto *b = c.request.mutable_material()->mutable_binomial();
        b->set_density(std::stod(np) / stats.mean_footprint_area);
        b->set_normal_threshold(threshold);
        if (interp == "tetrahedral") b->set_footprint_interpolation(glint::v1::TETRAHEDRAL);
        if (interp == "stochastic") b->set_footprint_interpolation(glint::v1::STOCHASTIC);
        if (fp64) c.request.set_precision(glint::v1::FP64);
        cases.push_back(c);
      }
  }
  std::vector<float> out(3 * size_t(n));
  for (int round = -1; round < rounds; ++round)  // round -1 compiles and warms
    for (Case &c : cases) {
      if (Status s = Validate(c.request, true); !s.ok()) {
        std::fprintf(stderr, "binomial_breakdown: %s: %s\n", c.name.c_str(), s.message().c_str());
        return 1;
      }
      const EvalPlan plan = MakeEvalPlan(c.request, c.request.queries());
      const double c0 = glint::bench::ProcessCpuSeconds();
      const auto t0 = Clock::now();
      if (Status s = engine->Evaluate(0, plan, c.request.queries(), out.data()); !s.ok()) {
        std::fprintf(stderr, "binomial_breakdown: %s: %s\n", c.name.c_str(), s.message().c_str());
        return 1;
      }
      const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
      const double cpu = glint::bench::ProcessCpuSeconds() - c0;
      if (round >= 0) c.wall.push_back(wall), c.cpu.push_back(cpu);
      if (round == -1) {
        uint64_t h = 1469598103934665603ull;
        for (float x : out) {
          uint32_t bits;
          std::memcpy(&bits, &x, sizeof bits);
          h = (h ^ bits) * 1099511628211ull;
        }
        c.hash = h;
      }
    }
  std::printf(
      "%u queries, %d interleaved rounds, device, BINOMIAL %s, SMOOTH fp32; ratios: median over "
      "rounds of the rate / SMOOTH directional_point's in the same round\n\n",
      n, rounds, fp64 ? "fp64" : "fp32");
  std::printf("mean footprint area %.4g uv units (N_P = density x area)\n\n",
              stats.mean_footprint_area);
  std::printf(
      "| request | M evals/s (wall) | ratio (wall) | M evals/CPU-s | ratio (CPU) | output hash |\n"
      "|---|---|---|---|---|---|\n");
  for (const Case &c : cases) {
    std::vector<double> rw, rc;
    for (int k = 0; k < rounds; ++k) {
      rw.push_back(cases[0].wall[k] / c.wall[k]);
      rc.push_back(cases[0].cpu[k] / c.cpu[k]);
    }
    std::printf("| %s | %.3g | %.4f | %.3g | %.4f | %016llx |\n", c.name.c_str(),
                1e-6 * n / glint::bench::Median(c.wall), glint::bench::Median(rw),
                1e-6 * n / glint::bench::Median(c.cpu), glint::bench::Median(rc),
                (unsigned long long)c.hash);
  }
  return 0;
}
