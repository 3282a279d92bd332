// The Sample RPC's cost and efficiency (server/sample.h, in process): samples per second of each
// model's sample pass on the OpenCL device (DeviceEngine, fp32, one worker, one sample per
// work-item) or the host path (--host: one thread), and the variance of the weight f cos_i / pdf
// (red channel), averaged over queries, against the "simple alternative" K25 Sec. 3.3.5 compares
// with: sampling the smooth lobe (the SMOOTH sampler of the same alpha and Fresnel) and weighting
// with the glint model's own f cos_i (its probe path). A ratio < 1 means the glint-aware sampler
// needs fewer samples for the same noise. Median of --repeat timed runs after one warm run.
//
//   cmake --build build --target bench_sample
//   build/bench/bench_sample [--queries N] [--samples K] [--repeat R] [--json] [--host]
//   (defaults 2000 queries x 256 samples, 3 repeats)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/sample.h"

namespace {

using Clock = std::chrono::steady_clock;
using glint::v1::Material;

struct Config {
  std::string name;
  Material material;
};

Material Base(glint::v1::Model model, glint::v1::Ndf ndf, float alpha) {
  Material m;
  m.set_model(model);
  m.set_ndf(ndf);
  m.set_alpha_x(alpha);
  m.set_alpha_y(alpha);
  for (float f : {0.9f, 0.6f, 0.3f}) m.mutable_schlick()->add_f0(f);
  return m;
}

// Random views (cos theta_o uniform in [0.1, 1]) and uv; footprint 1e-3 uv per pixel.
glint::v1::QueryBatch Queries(uint32_t n) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  glint::v1::QueryBatch q;
  q.set_count(n);
  for (uint32_t i = 0; i < n; ++i) {
    const float c = 0.1f + 0.9f * u01(rng), s = std::sqrt(1.0f - c * c);
    const float phi = 6.2831853f * u01(rng);
    for (float v : {s * std::cos(phi), s * std::sin(phi), c}) q.add_wo(v);
    for (int k = 0; k < 2; ++k) q.add_uv(u01(rng));
    for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) q.add_footprint(v);
  }
  return q;
}

// Mean over queries of the variance of the red weight over each query's K samples.
double MeanVariance(const std::vector<float> &weight_r, uint32_t n, uint32_t k) {
  double total = 0;
  for (uint32_t i = 0; i < n; ++i) {
    double s = 0, s2 = 0;
    for (uint32_t j = 0; j < k; ++j) {
      const double w = weight_r[size_t(i) * k + j];
      s += w;
      s2 += w * w;
    }
    const double mean = s / k;
    total += std::max(0.0, s2 / k - mean * mean) * k / (k - 1);
  }
  return total / n;
}

}  // namespace

int main(int argc, char **argv) {
  uint32_t n = 2000, k = 256;
  int repeat = 3;
  bool json = false, host = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--queries" && i + 1 < argc)
      n = uint32_t(std::atoi(argv[++i]));
    else if (a == "--samples" && i + 1 < argc)
      k = uint32_t(std::atoi(argv[++i]));
    else if (a == "--repeat" && i + 1 < argc)
      repeat = std::max(1, std::atoi(argv[++i]));
    else if (a == "--json")
      json = true;
    else if (a == "--host")
      host = true;
    else {
      std::fprintf(stderr,
                   "usage: bench_sample [--queries N] [--samples K] [--repeat R] [--json] "
                   "[--host]\n");
      return 2;
    }
  }
  if (n == 0 || k < 2 || uint64_t(n) * k > (1u << 20)) {
    std::fprintf(stderr, "bench_sample: need n >= 1, K >= 2 and n * K <= 2^20\n");
    return 2;
  }

  std::unique_ptr<glint::DeviceEngine> engine;
  if (!host) {
    glint::DeviceEngineOptions o;
    const char *cache = std::getenv("GLINT_CACHE_DIR");
    o.cache_dir = cache ? cache : "";
    o.workers = 1;
    glint::Status s = glint::DeviceEngine::Create(o, &engine);
    if (!s.ok()) {
      std::fprintf(stderr, "bench_sample: %s\n", s.message().c_str());
      return 1;
    }
  }

  std::vector<Config> configs;
  configs.push_back({"SMOOTH GGX 0.3", Base(glint::v1::SMOOTH, glint::v1::GGX, 0.3f)});
  configs.push_back({"SMOOTH BECKMANN 0.3", Base(glint::v1::SMOOTH, glint::v1::BECKMANN, 0.3f)});
  for (double density : {1e5, 1e7, 1e9}) {
    Material m = Base(glint::v1::KEMPPINEN, glint::v1::GGX, 0.3f);
    m.mutable_kemppinen()->set_density(density);
    m.mutable_kemppinen()->set_microroughness(0.02f);
    char name[64];
    std::snprintf(name, sizeof name, "KEMPPINEN GGX 0.3 density %.0e", density);
    configs.push_back({name, m});
  }
  {
    Material m = Base(glint::v1::CHERMAIN, glint::v1::BECKMANN, 0.5f);
    m.mutable_chermain()->set_log_density(20.0f);
    configs.push_back({"CHERMAIN BECKMANN 0.5 ln rho 20", m});
  }

  const glint::v1::QueryBatch queries = Queries(n);
  glint::ValidationLimits limits;
  if (!json) {
    std::printf("Sample pass, %u queries x %u samples, %s fp32, median of %d (loaded machine)\n\n",
                n, k, host ? "host path (1 thread)" : "device", repeat);
    std::printf(
        "| material | samples/s | weight variance | smooth-lobe sampling variance | "
        "ratio |\n| --- | --- | --- | --- | --- |\n");
  }
  for (const Config &c : configs) {
    glint::v1::SampleRequest r;
    *r.mutable_material() = c.material;
    *r.mutable_queries() = queries;
    r.set_samples_per_query(k);
    r.set_seed(1);
    r.set_precision(glint::v1::FP32);
    glint::v1::SampleResponse resp;
    std::vector<double> times;
    for (int t = 0; t <= repeat; ++t) {
      resp.Clear();
      const auto start = Clock::now();
      glint::Status s = glint::RunSample(engine.get(), 0, r, limits, &resp);
      const double sec = std::chrono::duration<double>(Clock::now() - start).count();
      if (!s.ok()) {
        std::fprintf(stderr, "bench_sample: %s: %s\n", c.name.c_str(), s.message().c_str());
        return 1;
      }
      if (t > 0) times.push_back(sec);  // the first run compiles and warms
    }
    std::sort(times.begin(), times.end());
    const double rate = double(n) * k / times[times.size() / 2];
    std::vector<float> red(size_t(n) * k);
    for (size_t j = 0; j < red.size(); ++j) red[j] = resp.weight(int(3 * j));
    const double var = MeanVariance(red, n, k);

    // The alternative: the smooth lobe's samples, weighted by this model's own f cos_i.
    double var_smooth = var;
    if (c.material.model() != glint::v1::SMOOTH) {
      glint::v1::SampleRequest sr = r;
      sr.mutable_material()->set_model(glint::v1::SMOOTH);
      sr.mutable_material()->clear_kemppinen();
      sr.mutable_material()->clear_chermain();
      sr.mutable_queries()->clear_uv();
      sr.mutable_queries()->clear_footprint();
      glint::v1::SampleResponse smooth;
      glint::Status s = glint::RunSample(engine.get(), 0, sr, limits, &smooth);
      if (!s.ok()) return 1;
      glint::v1::EvaluateRequest probe;
      *probe.mutable_material() = c.material;
      probe.set_seed(1);
      glint::v1::QueryBatch &pq = *probe.mutable_queries();
      pq.set_count(n * k);
      for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = 0; j < k; ++j) {
          const int g = int(i * k + j);
          for (int ch = 0; ch < 3; ++ch) pq.add_wo(queries.wo(int(3 * i) + ch));
          for (int ch = 0; ch < 2; ++ch) pq.add_uv(queries.uv(int(2 * i) + ch));
          for (int ch = 0; ch < 4; ++ch) pq.add_footprint(queries.footprint(int(4 * i) + ch));
          // A null sample probes straight up and is weighted 0 below.
          const bool none = smooth.pdf(g) == 0.0f;
          for (int ch = 0; ch < 3; ++ch)
            pq.add_wi(none ? (ch == 2 ? 1.0f : 0.0f) : smooth.wi(3 * g + ch));
        }
      const glint::EvalPlan plan = glint::MakeEvalPlan(probe, pq);
      std::vector<float> fcos(3 * size_t(n) * k);
      if (engine) {
        if (!engine->Evaluate(0, plan, pq, fcos.data()).ok()) return 1;
      } else {
        glint::HostEvaluate(plan, pq, fcos.data());
      }
      for (size_t j = 0; j < red.size(); ++j) {
        const float p = smooth.pdf(int(j));
        red[j] = p > 0.0f && smooth.wi(int(3 * j + 2)) > 0.0f ? fcos[3 * j] / p : 0.0f;
      }
      var_smooth = MeanVariance(red, n, k);
    }
    if (json) {
      std::printf(
          "{\"material\": \"%s\", \"device\": \"%s\", \"queries\": %u, \"samples\": %u, "
          "\"samples_per_s\": %.4g, \"weight_variance\": %.4g, \"smooth_lobe_variance\": %.4g}\n",
          c.name.c_str(), host ? "host" : "device", n, k, rate, var, var_smooth);
    } else {
      std::printf("| %s | %.3g M | %.4g | %.4g | %.3g |\n", c.name.c_str(), rate * 1e-6, var,
                  var_smooth, var / var_smooth);
    }
  }
  return 0;
}
