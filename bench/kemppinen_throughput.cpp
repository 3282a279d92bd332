// KEMPPINEN against SMOOTH on the same queries and lights, interleaved in one process (issue 9:
// "at least a quarter of the smooth model's throughput on the same lights"). Each round
// evaluates every configuration in turn (SMOOTH, then KEMPPINEN at each k) on the device path
// until it has used --min-time CPU-seconds; a configuration's rate is evaluations per
// CPU-second of the whole process (PoCL's threads included) and per wall second, and its ratio
// to SMOOTH is taken within each round (so both saw the same load), then the median over
// rounds. The material, queries, lights and seed are bench_models' KEMPPINEN case
// (bench/cases/kemppinen.cpp: GGX alpha 0.3, Schlick f0 (0.9, 0.6, 0.3), density 1e5).
//
//   kemppinen_throughput [--lights directional_point|probe|quad|four_quads] [--ks 1,4,9,16]
//                        [--density D] [--queries N] [--rounds R] [--min-time S]
//                        [--neighborhoods paper,one_level,one_cell]
//                        [--cache-dir DIR] [--json PATH] [--out PREFIX] [--path device|host]
// --path host runs the host scalar path (HostEvaluate, one thread) instead of the device: the
// driver for callgrind instruction counts of the same math (repeatable under load).
// --neighborhoods: glint.v1.KemppinenNeighborhood settings to run at each k (default paper).
// --out writes each configuration's output (RGB float32 per query) to PREFIX.<k or smooth>.f32,
// to check that a change of the kernels keeps the output (cmp, or a tolerance).
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/lib/bench_lib.h"
#include "server/eval_plan.h"
#include "server/host_path.h"

namespace {

using glint::bench::Clock;

int Fail(const std::string &why) {
  std::fprintf(stderr, "kemppinen_throughput: %s\n", why.c_str());
  return 1;
}

struct Config {
  std::string name;
  glint::v1::EvaluateRequest request;
  std::vector<double> cpu_rate, wall_rate, cpu_ratio, wall_ratio;
};

}  // namespace

static int Run(int argc, char **argv) {
  std::string lights_name = "directional_point", ks = "1,4,9,16", json, out_prefix;
  std::string hoods = "paper", path = "device";
  std::string cache_dir = glint::bench::DefaultCacheDir();
  double density = 1e5, min_time = 0.3;
  uint32_t queries = 65536;
  int rounds = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    try {
      if (a == "--lights")
        lights_name = v;
      else if (a == "--ks")
        ks = v;
      else if (a == "--neighborhoods")
        hoods = v;
      else if (a == "--density")
        density = std::stod(v);
      else if (a == "--queries")
        queries = uint32_t(std::stoul(v));
      else if (a == "--rounds")
        rounds = std::stoi(v);
      else if (a == "--min-time")
        min_time = std::stod(v);
      else if (a == "--cache-dir")
        cache_dir = v;
      else if (a == "--json")
        json = v;
      else if (a == "--out")
        out_prefix = v;
      else if (a == "--path")
        path = v;
      else
        return Fail("unknown option " + a);
    } catch (const std::exception &) {  // std::stod / stoul / stoi
      return Fail(a + ": expected a number, got '" + v + "'");
    }
  }
  glint::bench::Lights lights{};
  bool found = false;
  for (glint::bench::Lights l : glint::bench::kAllLights)
    if (lights_name == glint::bench::LightsName(l)) lights = l, found = true;
  if (!found) return Fail("--lights: expected probe, directional_point, quad or four_quads");
  if (queries == 0 || rounds < 1) return Fail("--queries and --rounds must be positive");
  if (path != "device" && path != "host") return Fail("--path: expected device or host");
  const bool host = path == "host";

  std::unique_ptr<glint::DeviceEngine> engine;
  if (glint::Status s = glint::bench::CreateEngine(cache_dir, &engine); !s.ok())
    return Fail("device: " + s.message());

  const bool probe = lights == glint::bench::Lights::kProbe;
  glint::v1::EvaluateRequest base;
  auto *m = base.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.3f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  base.set_precision(glint::v1::FP32);
  base.set_seed(0x9e3779b97f4aull);
  *base.mutable_queries() = glint::bench::SharedQueries(queries, probe);
  glint::bench::AddLights(lights, &base);

  std::vector<Config> configs;
  configs.push_back({"SMOOTH", base, {}, {}, {}, {}});
  std::vector<std::pair<std::string, glint::v1::KemppinenNeighborhood>> hood_list;
  std::stringstream hood_names(hoods);
  for (std::string h; std::getline(hood_names, h, ',');) {
    if (h == "paper")
      hood_list.push_back({"", glint::v1::KEMPPINEN_NEIGHBORHOOD_UNSPECIFIED});
    else if (h == "one_level")
      hood_list.push_back({" one_level", glint::v1::KEMPPINEN_ONE_LEVEL});
    else if (h == "one_cell")
      hood_list.push_back({" one_cell", glint::v1::KEMPPINEN_ONE_CELL});
    else
      return Fail("--neighborhoods: expected paper, one_level or one_cell, got '" + h + "'");
  }
  std::stringstream list(ks);
  for (std::string k; std::getline(list, k, ',');)
    for (const auto &[hood_name, hood] : hood_list) {
      Config c{"KEMPPINEN k=" + k + hood_name, base, {}, {}, {}, {}};
      auto *km = c.request.mutable_material();
      km->set_model(glint::v1::KEMPPINEN);
      km->mutable_kemppinen()->set_density(float(density));
      uint32_t neighbors = 0;
      try {
        neighbors = uint32_t(std::stoul(k));
      } catch (const std::exception &) {
        return Fail("--ks: expected numbers separated by commas, got '" + ks + "'");
      }
      km->mutable_kemppinen()->set_neighbors(neighbors);
      km->mutable_kemppinen()->set_neighborhood(hood);
      configs.push_back(std::move(c));
    }
  for (Config &c : configs)
    if (glint::Status s = glint::bench::Validate(c.request, engine->info().fp64); !s.ok())
      return Fail(c.name + ": " + s.message());

  std::vector<float> out(3 * size_t(queries));
  auto run = [&](const Config &c) {
    const glint::EvalPlan plan = glint::MakeEvalPlan(c.request, c.request.queries());
    if (host) {
      glint::HostEvaluate(plan, c.request.queries(), out.data());
      return;
    }
    glint::Status s = engine->Evaluate(0, plan, c.request.queries(), out.data());
    if (!s.ok()) throw std::runtime_error(c.name + ": " + s.message());
  };
  for (const Config &c : configs) {  // compile and warm
    run(c);
    if (out_prefix.empty()) continue;
    std::string tag = c.name == "SMOOTH" ? "smooth" : c.name.substr(c.name.find("k="));
    std::replace(tag.begin(), tag.end(), ' ', '.');
    std::ofstream f(out_prefix + "." + tag + ".f32", std::ios::binary);
    f.write(reinterpret_cast<const char *>(out.data()),
            std::streamsize(out.size() * sizeof(float)));
  }
  for (int r = 0; r < rounds; ++r) {
    for (Config &c : configs) {
      const double cpu0 = glint::bench::ProcessCpuSeconds();
      const auto t0 = Clock::now();
      uint64_t evals = 0;
      do {
        run(c);
        evals += queries;
      } while (glint::bench::ProcessCpuSeconds() - cpu0 < min_time);
      const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
      c.cpu_rate.push_back(double(evals) / (glint::bench::ProcessCpuSeconds() - cpu0));
      c.wall_rate.push_back(double(evals) / wall);
    }
    for (Config &c : configs) {
      c.cpu_ratio.push_back(c.cpu_rate.back() / configs[0].cpu_rate.back());
      c.wall_ratio.push_back(c.wall_rate.back() / configs[0].wall_rate.back());
    }
  }
  double load[3] = {0, 0, 0};
  if (std::ifstream f("/proc/loadavg"); f) f >> load[0] >> load[1] >> load[2];
  std::printf(
      "lights %s, %s path, %u queries, %d rounds, load average %.2f %.2f %.2f at end (loaded "
      "machine: compare ratios)\n",
      lights_name.c_str(), path.c_str(), queries, rounds, load[0], load[1], load[2]);
  std::printf(
      "| model | M evals / CPU-s | ratio to SMOOTH (CPU) | M evals / s (wall) | ratio (wall) |\n"
      "|---|---|---|---|---|\n");
  std::string rows;
  for (const Config &c : configs) {
    const double cr = glint::bench::Median(c.cpu_rate), wr = glint::bench::Median(c.wall_rate);
    const double cq = glint::bench::Median(c.cpu_ratio), wq = glint::bench::Median(c.wall_ratio);
    std::printf("| %s | %.4g | %.4f | %.4g | %.4f |\n", c.name.c_str(), cr / 1e6, cq, wr / 1e6, wq);
    char row[256];
    std::snprintf(row, sizeof row,
                  "%s{\"model\": \"%s\", \"evals_per_cpu_s\": %.6g, \"ratio_cpu\": %.6g, "
                  "\"evals_per_s\": %.6g, \"ratio_wall\": %.6g}",
                  rows.empty() ? "" : ",\n  ", c.name.c_str(), cr, cq, wr, wq);
    rows += row;
  }
  if (!json.empty()) {
    std::ofstream f(json);
    f << "{\"lights\": \"" << lights_name << "\", \"queries\": " << queries
      << ", \"rounds\": " << rounds << ", \"load\": [" << load[0] << ", " << load[1] << ", "
      << load[2] << "],\n \"rows\": [\n  " << rows << "]}\n";
  }
  return 0;
}

int main(int argc, char **argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception &e) {  // a request the engine refuses
    return Fail(e.what());
  }
}
