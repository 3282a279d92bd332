// The smooth model's LTC polygon pass against its directional+point pass, measured in CPU time:
// the same 16384 shared queries and material as bench_models' SMOOTH rows (GGX alpha (0.3, 0.1),
// Schlick f0 (0.9, 0.6, 0.3)), device fp32 in process, the three light sets `directional_point`,
// `quad`, `four_quads` timed in interleaved rounds. Each evaluation is timed by wall clock and by
// the CPU seconds of every thread of the process (PoCL's workers included): on a machine shared
// with other work the CPU time per evaluation is the load-independent cost, the wall time is not.
// Prints, per light set, the median wall and CPU rates and their ratio to directional_point.
//
// `--precision fp64` times all three in fp64 (default fp32). `--framed 1` gives the queries
// random world frames and positions (lights partly below some shading horizons: the clip paths);
// `--dump PREFIX` writes each light set's radiance once more after the rounds, raw float32 RGB,
// to PREFIX.<lights>.f32 (to check that a change of the kernel is bit-identical: `cmp` two
// dumps).
//
//   bench_ltc_cost [--rounds R] [--queries N] [--cache-dir DIR]
//                  [--precision fp32|fp64] [--framed 0|1] [--dump PREFIX]
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "server/eval_plan.h"
#include "test_queries.h"

namespace {

struct Case {
  glint::bench::Lights lights;
  glint::v1::EvaluateRequest request;
  std::vector<double> wall, cpu;
};

}  // namespace

int main(int argc, char **argv) {
  int rounds = 15;
  uint32_t queries = 16384;
  std::string cache_dir = glint::bench::DefaultCacheDir(), dump;
  bool framed = false, fp64 = false;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--rounds")
      rounds = std::max(1, std::stoi(v));
    else if (a == "--queries")
      queries = uint32_t(std::max(8, std::stoi(v)));
    else if (a == "--cache-dir")
      cache_dir = v;
    else if (a == "--framed")
      framed = v != "0";
    else if (a == "--precision")
      fp64 = v == "fp64";
    else if (a == "--dump")
      dump = v;
    else {
      std::fprintf(stderr, "bench_ltc_cost: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  std::unique_ptr<glint::DeviceEngine> engine;
  if (glint::Status s = glint::bench::CreateEngine(cache_dir, &engine); !s.ok()) {
    std::fprintf(stderr, "bench_ltc_cost: %s\n", s.message().c_str());
    return 1;
  }
  std::vector<Case> cases;
  for (glint::bench::Lights l : {glint::bench::Lights::kDirectionalPoint,
                                 glint::bench::Lights::kQuad, glint::bench::Lights::kFourQuads}) {
    Case c{l, {}, {}, {}};
    auto *m = c.request.mutable_material();
    m->set_model(glint::v1::SMOOTH);
    m->set_ndf(glint::v1::GGX);
    m->set_alpha_x(0.3f);
    m->set_alpha_y(0.1f);
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
    c.request.set_precision(fp64 ? glint::v1::FP64 : glint::v1::FP32);
    *c.request.mutable_queries() = framed ? glint::test::RandomQueries(queries, false, true, 42)
                                          : glint::bench::SharedQueries(queries, false);
    glint::bench::AddLights(l, &c.request);
    if (glint::Status s = glint::bench::Validate(c.request, true); !s.ok()) {
      std::fprintf(stderr, "bench_ltc_cost: %s\n", s.message().c_str());
      return 1;
    }
    cases.push_back(std::move(c));
  }
  std::vector<float> out(3 * size_t(queries));
  // Each evaluation repeated until it takes >= 20 ms of wall time (batch fixed in the warm-up).
  std::vector<int> reps(cases.size(), 1);
  for (size_t k = 0; k < cases.size(); ++k) {
    const glint::EvalPlan plan = glint::MakeEvalPlan(cases[k].request, cases[k].request.queries());
    for (;;) {
      const auto t0 = glint::bench::Clock::now();
      for (int r = 0; r < reps[k]; ++r) {
        if (glint::Status s = engine->Evaluate(0, plan, cases[k].request.queries(), out.data());
            !s.ok()) {
          std::fprintf(stderr, "bench_ltc_cost: %s\n", s.message().c_str());
          return 1;
        }
      }
      if (std::chrono::duration<double>(glint::bench::Clock::now() - t0).count() >= 0.02) break;
      reps[k] *= 2;
    }
  }
  for (int round = 0; round < rounds; ++round) {
    for (size_t k = 0; k < cases.size(); ++k) {
      const glint::EvalPlan plan =
          glint::MakeEvalPlan(cases[k].request, cases[k].request.queries());
      const auto t0 = glint::bench::Clock::now();
      const double c0 = glint::bench::ProcessCpuSeconds();
      for (int r = 0; r < reps[k]; ++r)
        (void)engine->Evaluate(0, plan, cases[k].request.queries(), out.data());
      const double evals = double(queries) * reps[k];
      cases[k].cpu.push_back(evals / (glint::bench::ProcessCpuSeconds() - c0));
      cases[k].wall.push_back(
          evals / std::chrono::duration<double>(glint::bench::Clock::now() - t0).count());
    }
  }
  const double wall0 = glint::bench::Median(cases[0].wall),
               cpu0 = glint::bench::Median(cases[0].cpu);
  std::printf(
      "| lights | wall evals/s | ratio | CPU evals/CPU-s | ratio |\n|---|---|---|---|---|\n");
  for (const Case &c : cases) {
    std::printf("| %s | %.4g | %.3f | %.4g | %.3f |\n", glint::bench::LightsName(c.lights),
                glint::bench::Median(c.wall), glint::bench::Median(c.wall) / wall0,
                glint::bench::Median(c.cpu), glint::bench::Median(c.cpu) / cpu0);
  }
  for (const Case &c : cases) {
    if (dump.empty()) break;
    const glint::EvalPlan plan = glint::MakeEvalPlan(c.request, c.request.queries());
    if (glint::Status s = engine->Evaluate(0, plan, c.request.queries(), out.data()); !s.ok()) {
      std::fprintf(stderr, "bench_ltc_cost: %s\n", s.message().c_str());
      return 1;
    }
    const std::string path = dump + "." + glint::bench::LightsName(c.lights) + ".f32";
    FILE *f = std::fopen(path.c_str(), "wb");
    if (!f || std::fwrite(out.data(), sizeof(float), out.size(), f) != out.size()) {
      std::fprintf(stderr, "bench_ltc_cost: cannot write %s\n", path.c_str());
      if (f) std::fclose(f);
      return 1;
    }
    std::fclose(f);
  }
  return 0;
}
