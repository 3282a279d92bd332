// One benchmark for every model (issue 13): every model of the model table (server/model_table.h)
// with its registered quality-knob variants (bench/cases/<model>.cpp; the smooth model's variants
// are its Fresnel kinds and the polygon-light area methods), over the same query sets and light
// sets (bench/lib/bench_case.h Lights), on the paths
//   device      the OpenCL device in process (DeviceEngine, one command queue; buffer set-up and
//               the result copy included, like the service),
//   host        the host C++ path on one thread (HostEvaluate),
//   end_to_end  glintd's service in this process on loopback through the client library
//               (protobuf + gRPC both ways; fp32, each model's first variant per light set),
//               on the batch the device row of the same run timed,
//   shared_memory  the same service through same-host shared memory, zero-copy (client/lib/
//               shm_transport.h ShmSession::PrepareInPlace: a region registered once, the
//               queries written into it before the clock starts; each timed call sends the small
//               request, glintd validates and evaluates the queries in place and its kernels
//               write the radiance into the region; same rows and batch as end_to_end;
//               bench_shm_steps times the copying ShmSession::Evaluate),
// in fp32 and fp64. One row per measurement:
//   evals_per_s      queries / median seconds of --repeat runs; the batch (the shared queries
//                    tiled) grows until one run takes >= the minimum time or reaches 2^20 queries,
//                    after an untimed run that compiles and warms the kernel;
//   ratio_to_smooth  evals_per_s / that of SMOOTH `schlick` `directional_point` on the same path
//                    and precision (the issue's "smooth kernel with the same queries and a
//                    directional light");
//   ratio_to_device  end_to_end and shared_memory: this path's rate / the device's, the device
//                    timed on the same batch before each of this path's runs (interleaved);
//   error_*          against the case's reference (bench_case.h ErrorReference): mean, p95 and
//                    max of the per-query relative error for the smooth model (fp64 host for
//                    probes and point-like lights, fp64 REFERENCE quadrature for polygons), the
//                    relative bias of the batch mean against the smooth model for glint models:
//                    the mean over request seeds (the case's error_seeds: 16 for BINOMIAL,
//                    1 for the others; --error-seeds S for all; 2 with --tiny), error_mean
//                    its absolute value, error_signed with the sign, error_se its standard
//                    error (the larger of the delta method over seeds x queries and the spread
//                    of the per-seed means; Driver::Errors says why one seed is not enough).
// Printed as a markdown table; --json PATH writes {"command", "machine", "rows": [...],
// "skipped": [...]} (scripts/bench_tables.py turns it into the README's performance section).
//
//   build/bench/bench_models --quick --json bench/results/quick.json   # < 3 min, warm cache
//   build/bench/bench_models --json results.json                       # every variant, longer
// Flags: --quick | --tiny (seconds; the ctest smoke run), --models A,B, --lights a,b,
// --precisions fp32,fp64, --paths device,host,end_to_end,shared_memory, --repeat R, --min-time S,
// --shm-direct-output, --error-seeds S,
// --note TEXT (stored in the JSON's machine note), --cache-dir DIR.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <sys/utsname.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "bench/lib/bench_case.h"
#include "bench/lib/bench_lib.h"
#include "bench/lib/loopback_service.h"
#include "client/lib/glint_client.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/model_table.h"

namespace glint::bench {
namespace {

struct Options {
  std::string mode = "full";  // full, quick, tiny
  uint32_t base_queries = 65536;
  uint32_t area_ref_queries = 256;  // queries with a REFERENCE truth (polygon-light errors)
  uint32_t max_batch = 1u << 20;
  double min_time = 0.2;
  int repeat = 5;
  bool area_truth_tiny = false;    // --tiny: REFERENCE at 16 nodes, a smoke value, not a truth
  bool shm_direct_output = false;  // --shm-direct-output (glintd's flag) on shared_memory rows
  int error_seeds = 0;             // --error-seeds: seeds behind a glint bias; 0 = the case's
  std::set<std::string> models, lights, precisions, paths;
  std::string json, note, cache_dir = DefaultCacheDir();
  std::string command;
};

bool Selected(const std::set<std::string> &filter, const std::string &name) {
  return filter.empty() || filter.count(name);
}

std::set<std::string> SplitList(const std::string &s) {
  std::set<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.insert(item);
  return out;
}

struct Row {
  std::string model, variant, lights, precision, path;
  double evals_per_s = NAN;
  std::optional<double> ratio_to_smooth, error_mean, error_p95, error_max, error_se;
  std::optional<double> error_signed;  // glint models: mean / smooth mean - 1 (error_mean = |.|)
  int error_seeds = 0;                 // glint models: the request seeds behind it
  std::string error_reference;         // "" = none
  uint32_t batch = 0;                  // queries per timed run
  uint32_t error_queries = 0;
  uint32_t nonfinite = 0;
  std::string transport;  // end_to_end: unary or stream; shared_memory: shm or shm-direct
  // end_to_end and shared_memory: device seconds / this path's seconds (medians), the device
  // timed on the same batch right before each of this path's runs (the device rate of this VM
  // changes 2x between moments: the PoCL threads stacked on one core or spread over two).
  std::optional<double> ratio_to_device;
};

struct Skipped {
  std::string model, variant, lights, precision, reason;
};

const char *PrecisionName(bool fp64) {
  return fp64 ? "fp64" : "fp32";
}

// The material of `request` as the smooth model: the model's own params field cleared (through
// reflection, so it works for any model's field).
glint::v1::EvaluateRequest AsSmooth(const glint::v1::EvaluateRequest &request, const Model &model) {
  glint::v1::EvaluateRequest s = request;
  auto *m = s.mutable_material();
  if (model.params_field) {
    const auto *f = m->GetDescriptor()->FindFieldByName(model.params_field);
    if (f) m->GetReflection()->ClearField(m, f);
  }
  m->set_model(glint::v1::SMOOTH);
  return s;
}

// The plan of `request` with the data its model takes from the request (Model::request_table:
// NORMAL_MAP's uploaded map), as the service makes it.
EvalPlan ResolvedPlan(const glint::v1::EvaluateRequest &request, const glint::v1::QueryBatch &q) {
  EvalPlan plan = MakeEvalPlan(request, q);
  if (Status s = ResolveRequestTable(request.material(), &plan); !s.ok())
    throw std::runtime_error("request table: " + s.message());
  return plan;
}

// Host evaluation of `request` on its first `n` queries, split over two threads (chunks of 64).
std::vector<float> HostParallel(const glint::v1::EvaluateRequest &request, uint32_t n) {
  const glint::v1::QueryBatch q = Tile(request.queries(), n);
  const EvalPlan plan = ResolvedPlan(request, q);
  std::vector<float> out(3 * size_t(n));
  std::atomic<uint32_t> next{0};
  auto work = [&] {
    for (uint32_t b; (b = next.fetch_add(64)) < n;) {
      const uint32_t e = std::min(n, b + 64);
      const glint::v1::QueryBatch part = glint::client::SliceQueries(q, b, e);
      HostEvaluate(plan, part, out.data() + 3 * size_t(b));
    }
  };
  std::thread t(work);
  work();
  t.join();
  return out;
}

// REFERENCE nodes per dimension for the truth: README "Area lights" finds 128 / 256 / 512 / 1024
// nodes within 1e-3 of an independent adaptive integration at alpha 0.1 / 0.05 / 0.03 / 0.01;
// this takes one step finer down to alpha 0.03 (capped at the 1024 the server allows).
uint32_t ReferenceNodes(double alpha) {
  return alpha < 0.05 ? 1024 : alpha < 0.1 ? 512 : 256;
}

class Driver {
 public:
  Driver(Options o, DeviceEngine *engine) : o_(std::move(o)), engine_(engine) {
    probe_ = SharedQueries(o_.base_queries, true);
    lit_ = SharedQueries(o_.base_queries, false);
  }

  void Run();
  const std::vector<Row> &rows() const { return rows_; }
  const std::vector<Skipped> &skipped() const { return skipped_; }

 private:
  // Times `request` on `path`; false (and *why) when the path fails.
  bool Time(const std::string &path, const glint::v1::EvaluateRequest &request, Row *row,
            std::string *why);
  // Evaluates the first n queries of `request` on `path` (untimed).
  bool Eval(const std::string &path, const glint::v1::EvaluateRequest &request, uint32_t n,
            std::vector<float> *out, std::string *why);
  void Errors(const Model &model, const ModelBenchCase &c, Lights lights,
              const glint::v1::EvaluateRequest &request, const std::string &path, Row *row);
  const std::vector<double> &ExactReference(const std::string &key,
                                            const glint::v1::EvaluateRequest &request);
  const std::vector<double> &AreaTruth(const std::string &key,
                                       const glint::v1::EvaluateRequest &request, double *floor);
  const std::vector<double> &SmoothReference(const std::string &key,
                                             const glint::v1::EvaluateRequest &request);

  Options o_;
  DeviceEngine *engine_;
  std::unique_ptr<LoopbackService> service_;
  glint::v1::QueryBatch probe_, lit_;
  std::vector<Row> rows_;
  std::vector<Skipped> skipped_;
  std::map<std::string, std::vector<double>> refs_;
  std::map<std::string, double> floors_;
};

bool Driver::Eval(const std::string &path, const glint::v1::EvaluateRequest &request, uint32_t n,
                  std::vector<float> *out, std::string *why) {
  glint::v1::EvaluateRequest r = request;
  *r.mutable_queries() = Tile(request.queries(), n);
  out->assign(3 * size_t(n), 0.0f);
  if (path == "end_to_end" || path == "shared_memory") {
    if (!service_)
      service_ = std::make_unique<LoopbackService>(engine_, glint::client::ClientOptions{},
                                                   o_.shm_direct_output);
    if (!service_->ok()) {
      *why = "could not start the loopback service";
      return false;
    }
    glint::client::EvaluateInfo info;
    grpc::Status s = path == "end_to_end" ? service_->Evaluate(r, out, &info)
                                          : service_->EvaluateShared(r, out, &info);
    if (!s.ok()) *why = path + ": " + s.error_message();
    return s.ok();
  }
  const EvalPlan plan = ResolvedPlan(r, r.queries());
  if (path == "host") {
    HostEvaluate(plan, r.queries(), out->data());
    return true;
  }
  Status s = engine_->Evaluate(0, plan, r.queries(), out->data());
  if (!s.ok()) *why = "device: " + s.message();
  return s.ok();
}

bool Driver::Time(const std::string &path, const glint::v1::EvaluateRequest &request, Row *row,
                  std::string *why) {
  std::vector<float> out;
  uint32_t n = std::min(o_.base_queries, 256u);
  if (!Eval(path, request, n, &out, why)) return false;  // compile + warm
  auto once = [&](uint32_t count, double *seconds) {
    glint::v1::EvaluateRequest r = request;
    *r.mutable_queries() = Tile(request.queries(), count);
    std::vector<float> o(3 * size_t(count));
    bool ok = true;
    if (path == "end_to_end") {
      glint::client::EvaluateInfo info;
      const auto t0 = Clock::now();
      grpc::Status s = service_->Evaluate(r, &o, &info);
      *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
      row->transport = info.streamed ? "stream" : "unary";
      if (!s.ok()) *why = "end_to_end: " + s.error_message(), ok = false;
      return ok;
    }
    if (path == "shared_memory") {
      // Zero-copy: the queries written into the registered region before the clock starts (as
      // the application producing them there would, and as Triton's perf_analyzer prepares its
      // shared-memory inputs), the radiance read where the kernels wrote it. The client
      // library's copying ShmSession::Evaluate is timed by bench/bench_shm_steps.cpp.
      grpc::Status s = service_->PrepareSharedInPlace(r);
      if (!s.ok()) {
        *why = "shared_memory: " + s.error_message();
        return false;
      }
      glint::client::EvaluateInfo info;
      const auto t0 = Clock::now();
      s = service_->EvaluateSharedInPlace(r, &info);
      *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
      row->transport = "shm-in-place";
      if (!s.ok()) *why = "shared_memory: " + s.error_message(), ok = false;
      return ok;
    }
    const EvalPlan plan = ResolvedPlan(r, r.queries());
    const auto t0 = Clock::now();
    if (path == "host") {
      HostEvaluate(plan, r.queries(), o.data());
    } else {
      Status s = engine_->Evaluate(0, plan, r.queries(), o.data());
      if (!s.ok()) *why = "device: " + s.message(), ok = false;
    }
    *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return ok;
  };
  double t = 0;
  // end_to_end and shared_memory time the batch their device row timed in this run (issue 12:
  // the rates side by side on the same batch, 1M queries for the probes).
  uint32_t same_as_device = 0;
  if (path == "end_to_end" || path == "shared_memory")
    for (const Row &d : rows_)
      if (d.path == "device" && d.model == row->model && d.variant == row->variant &&
          d.lights == row->lights && d.precision == row->precision)
        same_as_device = d.batch;
  if (same_as_device) n = same_as_device;
  if (!once(n, &t)) return false;
  while (!same_as_device && t < o_.min_time && n < o_.max_batch) {
    const double grow = std::clamp(1.3 * o_.min_time / std::max(t, 1e-6), 2.0, 64.0);
    n = uint32_t(std::min(double(o_.max_batch), std::ceil(n * grow)));
    if (!once(n, &t)) return false;
  }
  // The device on the same batch, for the interleaved ratio of a transport row.
  auto device_once = [&](uint32_t count, double *seconds) {
    glint::v1::EvaluateRequest r = request;
    *r.mutable_queries() = Tile(request.queries(), count);
    std::vector<float> o(3 * size_t(count));
    const EvalPlan plan = ResolvedPlan(r, r.queries());
    const auto t0 = Clock::now();
    Status s = engine_->Evaluate(0, plan, r.queries(), o.data());
    *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    if (!s.ok()) *why = "device: " + s.message();
    return s.ok();
  };
  std::vector<double> times, device_times;
  for (int k = 0; k < o_.repeat; ++k) {
    if (same_as_device) {
      double d = 0;
      if (!device_once(n, &d)) return false;
      device_times.push_back(d);
    }
    if (!once(n, &t)) return false;
    times.push_back(t);
  }
  std::sort(times.begin(), times.end());
  std::sort(device_times.begin(), device_times.end());
  row->evals_per_s = n / times[times.size() / 2];
  if (!device_times.empty())
    row->ratio_to_device = device_times[device_times.size() / 2] / times[times.size() / 2];
  row->batch = n;
  return true;
}

const std::vector<double> &Driver::ExactReference(const std::string &key,
                                                  const glint::v1::EvaluateRequest &request) {
  auto it = refs_.find(key);
  if (it != refs_.end()) return it->second;
  glint::v1::EvaluateRequest r = request;
  r.set_precision(glint::v1::FP64);
  const std::vector<float> out = HostParallel(r, r.queries().count());
  return refs_[key] = RgbSums(out.data(), r.queries().count());
}

const std::vector<double> &Driver::AreaTruth(const std::string &key,
                                             const glint::v1::EvaluateRequest &request,
                                             double *floor) {
  auto it = refs_.find(key);
  if (it == refs_.end()) {
    glint::v1::EvaluateRequest r = request;
    r.set_precision(glint::v1::FP64);
    r.set_area_method(glint::v1::REFERENCE);
    const double alpha = std::min(r.material().alpha_x(), r.material().alpha_y());
    r.set_area_samples(o_.area_truth_tiny ? 16 : ReferenceNodes(alpha));
    const auto t0 = Clock::now();
    const uint32_t n = std::min(o_.area_ref_queries, r.queries().count());
    const std::vector<float> out = HostParallel(r, n);
    std::fprintf(stderr, "  truth %s: REFERENCE:%u fp64 host, %u queries, %.1f s\n", key.c_str(),
                 r.area_samples(), n, std::chrono::duration<double>(Clock::now() - t0).count());
    it = refs_.emplace(key, RgbSums(out.data(), n)).first;
    double top = 0;
    for (double v : it->second) top = std::max(top, v);
    floors_[key] = 1e-3 * top;
  }
  *floor = floors_[key];
  return it->second;
}

const std::vector<double> &Driver::SmoothReference(const std::string &key,
                                                   const glint::v1::EvaluateRequest &request) {
  auto it = refs_.find(key);
  if (it != refs_.end()) return it->second;
  glint::v1::EvaluateRequest r = request;
  r.set_precision(glint::v1::FP64);
  const std::vector<float> out = HostParallel(r, r.queries().count());
  return refs_[key] = RgbSums(out.data(), r.queries().count());
}

void Driver::Errors(const Model &model, const ModelBenchCase &c, Lights lights,
                    const glint::v1::EvaluateRequest &request, const std::string &path, Row *row) {
  if (path == "end_to_end" || path == "shared_memory") return;  // the device path's numbers
  std::string why;
  std::vector<float> out;
  const std::string light_key = std::string(model.name) + "|" + LightsName(lights);
  if (c.error == ErrorReference::kExact && !HasPolygons(lights)) {
    if (path == "host" && row->precision == "fp64") return;  // the reference itself
    const auto &ref = ExactReference(light_key + "|" + row->variant, request);
    if (!Eval(path, request, uint32_t(ref.size()), &out, &why)) return;
    double top = 0;
    for (double v : ref) top = std::max(top, v);
    const ErrorStats s = Summarise(RelativeErrors(out.data(), ref, 1e-3 * top, &row->nonfinite));
    row->error_mean = s.mean, row->error_p95 = s.p95, row->error_max = s.max;
    row->error_reference = "fp64 host";
    row->error_queries = uint32_t(ref.size());
  } else if (c.error == ErrorReference::kExact) {
    double floor = 0;
    const auto &truth = AreaTruth(light_key, request, &floor);
    if (!Eval(path, request, uint32_t(truth.size()), &out, &why)) return;
    const ErrorStats s = Summarise(RelativeErrors(out.data(), truth, floor, &row->nonfinite));
    row->error_mean = s.mean, row->error_p95 = s.p95, row->error_max = s.max;
    row->error_reference = "REFERENCE fp64 host";
    row->error_queries = uint32_t(truth.size());
  } else if (c.error == ErrorReference::kSmoothMean) {
    // The glint model's mean over the case's error_seeds request seeds (16 for BINOMIAL; or
    // --error-seeds) (the first the request's own; the
    // others differ in both halves, seed_lo and seed_hi, and the models hash every glint from
    // the seed, so each is an independent realisation) against the smooth model's. One seed is
    // not enough: where a footprint holds few facets that reflect the light (BINOMIAL at N_P p
    // << 1, e.g. the random footprints of near-zero area) a query's radiance is 0 or, rarely,
    // the smooth value / (N_P p), so the per-seed batch mean is skewed (kurtosis ~60 for the
    // quad at N_P 1e2) and its sample standard error mostly misses those rare values: over
    // 10000 seeds its spread was 1.28x the mean and 1.49x the median per-seed standard error,
    // and issue 13's quad row ("3.9 standard errors" from one seed) was a rare low draw, not a
    // bias (bench/binomial_bias.cpp; models/binomial/README.md "Bias at N_P = 1e2?"). Over 16
    // seeds the spread of the mean is 1.23x its median standard error there (|t| > 3 in 0.6% of
    // groups): still a little small where N_P p << 1.
    const auto &sv = SmoothReference(light_key, AsSmooth(request, model));
    const uint32_t n = uint32_t(sv.size());
    const int seeds = std::max(1, o_.error_seeds ? o_.error_seeds : c.error_seeds);
    std::vector<std::vector<double>> gv;
    for (int k = 0; k < seeds; ++k) {
      glint::v1::EvaluateRequest r = request;
      r.set_seed(request.seed() + uint64_t(k) * 0x100000001ull);
      if (!Eval(path, r, n, &out, &why)) return;
      gv.push_back(RgbSums(out.data(), n));
    }
    double mean_s = 0;
    for (uint32_t i = 0; i < n; ++i) mean_s += sv[i];
    mean_s /= n;
    std::vector<double> seed_ratio(seeds, 0.0);
    std::vector<bool> nonfinite(n, false);
    for (int k = 0; k < seeds; ++k) {
      for (uint32_t i = 0; i < n; ++i) {
        if (!std::isfinite(gv[k][i])) nonfinite[i] = true;
        seed_ratio[k] += gv[k][i];
      }
      seed_ratio[k] /= n * mean_s;
    }
    row->nonfinite += uint32_t(std::count(nonfinite.begin(), nonfinite.end(), true));
    double ratio = 0;
    for (double r : seed_ratio) ratio += r / seeds;
    // Two estimates of var(ratio): the delta method over all seeds x queries (var(mean_g /
    // mean_s) ~ var(g - ratio s) / (N mean_s^2), N = seeds n; it assumes independent queries,
    // which holds for BINOMIAL: the spread over 2000 seeds matched it within 1%) and the spread
    // of the per-seed ratios (valid whatever the queries share, noisier). The larger is
    // reported (one seed: the delta method alone).
    double pooled = 0;
    for (int k = 0; k < seeds; ++k)
      for (uint32_t i = 0; i < n; ++i) {
        const double d = gv[k][i] - ratio * sv[i];
        pooled += d * d;
      }
    const double total = double(seeds) * n;
    pooled /= (total - 1) * total * mean_s * mean_s;
    double spread = 0;
    for (double r : seed_ratio) spread += (r - ratio) * (r - ratio);
    spread = seeds > 1 ? spread / ((seeds - 1) * double(seeds)) : 0.0;
    if (std::isfinite(ratio)) {
      row->error_mean = std::fabs(ratio - 1.0);
      row->error_signed = ratio - 1.0;
      row->error_se = std::sqrt(std::max(pooled, spread));
      row->error_seeds = seeds;
      char ref[64];
      std::snprintf(ref, sizeof ref, "mean of %d seeds vs SMOOTH fp64 host", seeds);
      row->error_reference = ref;
      row->error_queries = n;
    }
  }
}

void Driver::Run() {
  std::map<int, ModelBenchCase> cases;
  for (ModelBenchCase &c : BenchCases()) cases[int(c.model)] = std::move(c);
  const bool fp64_ok = engine_->info().fp64;
  for (const Model *model : Models()) {
    if (!Selected(o_.models, model->name)) continue;
    ModelBenchCase c;
    if (auto it = cases.find(int(model->id)); it != cases.end()) {
      c = it->second;
    } else {  // no registered case: the model's own example material, no error reference
      c.model = model->id;
      c.base = [model](glint::v1::Material *m) {
        m->set_ndf(glint::v1::GGX);
        m->set_alpha_x(0.3f);
        m->set_alpha_y(0.1f);
        for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
        glint::v1::QueryBatch unused;
        if (model->example) model->example(m, &unused);
      };
      c.variants.push_back({"example", {}, true, nullptr});
    }
    glint::v1::QueryBatch probe = probe_, lit = lit_;
    if (c.footprints) c.footprints(&probe), c.footprints(&lit);
    const QueryStats stats = StatsOf(lit);
    for (Lights lights : kAllLights) {
      if (!Selected(o_.lights, LightsName(lights))) continue;
      bool first_variant = true;
      for (const BenchVariant &v : c.variants) {
        if (!v.lights.empty() &&
            std::find(v.lights.begin(), v.lights.end(), lights) == v.lights.end())
          continue;
        if (o_.mode != "full" && !v.quick) continue;
        bool measured = false;
        for (bool fp64 : {false, true}) {
          if (!Selected(o_.precisions, PrecisionName(fp64))) continue;
          glint::v1::EvaluateRequest r;
          auto *m = r.mutable_material();
          m->set_model(model->id);
          c.base(m);
          r.set_precision(fp64 ? glint::v1::FP64 : glint::v1::FP32);
          r.set_seed(0x9e3779b97f4aull);
          *r.mutable_queries() = lights == Lights::kProbe ? probe : lit;
          AddLights(lights, &r);
          if (v.apply) v.apply(&r, stats);
          Status s = Validate(r, fp64_ok);
          if (!s.ok()) {
            skipped_.push_back(
                {model->name, v.name, LightsName(lights), PrecisionName(fp64), s.message()});
            continue;
          }
          for (const char *path : {"device", "host", "end_to_end", "shared_memory"}) {
            if (!Selected(o_.paths, path)) continue;
            const bool service =
                std::string(path) == "end_to_end" || std::string(path) == "shared_memory";
            if (service && (fp64 || !first_variant)) continue;
            Row row;
            row.model = model->name;
            row.variant = v.name;
            row.lights = LightsName(lights);
            row.precision = PrecisionName(fp64);
            row.path = path;
            std::string why;
            if (!Time(path, r, &row, &why)) {
              skipped_.push_back({row.model, row.variant, row.lights, row.precision,
                                  std::string(path) + ": " + why});
              continue;
            }
            Errors(*model, c, lights, r, path, &row);
            char vs_device[64] = "";
            if (row.ratio_to_device)
              std::snprintf(vs_device, sizeof vs_device, ", %.2f of the device (interleaved)",
                            *row.ratio_to_device);
            std::fprintf(stderr, "%s %s %s %s %s: %.4g evals/s (batch %u)%s\n", row.model.c_str(),
                         row.variant.c_str(), row.lights.c_str(), row.precision.c_str(), path,
                         row.evals_per_s, row.batch, vs_device);
            rows_.push_back(row);
            measured = true;
          }
        }
        if (measured) first_variant = false;
      }
    }
  }
  // ratio_to_smooth against SMOOTH schlick directional_point on the same path and precision.
  for (Row &row : rows_)
    for (const Row &base : rows_)
      if (base.model == "SMOOTH" && base.variant == "schlick" &&
          base.lights == "directional_point" && base.path == row.path &&
          base.precision == row.precision)
        row.ratio_to_smooth = row.evals_per_s / base.evals_per_s;
}

std::string Fmt(const std::optional<double> &v, const char *f) {
  if (!v || !std::isfinite(*v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, *v);
  return b;
}

// 4 significant digits: the timings do not carry more, and the JSON stays readable.
nlohmann::ordered_json Num(const std::optional<double> &v) {
  if (!v || !std::isfinite(*v)) return nullptr;
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", *v);
  return std::strtod(b, nullptr);
}

std::string LoadAverage() {
  double l[3] = {NAN, NAN, NAN};
  if (getloadavg(l, 3) < 1) return "unknown";
  char b[64];
  std::snprintf(b, sizeof b, "%.2f %.2f %.2f", l[0], l[1], l[2]);
  return b;
}

std::string UtcNow() {
  std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
  return b;
}

int Main(int argc, char **argv) {
  Options o;
  o.command = "build/bench/bench_models";
  auto usage = [] {
    std::fprintf(stderr,
                 "usage: bench_models [--quick | --tiny] [--json PATH] [--models A,B] "
                 "[--lights probe,directional_point,quad,four_quads] [--precisions fp32,fp64] "
                 "[--paths device,host,end_to_end,shared_memory] [--repeat R] [--min-time S] "
                 "[--error-seeds S] [--note TEXT] [--cache-dir DIR] [--shm-direct-output]\n");
    return 2;
  };
  int repeat = 0, error_seeds = 0;
  double min_time = -1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    std::string shown = a;
    if (a == "--quick") {
      o.mode = "quick";
    } else if (a == "--tiny") {
      o.mode = "tiny";
    } else if (a == "--shm-direct-output") {
      o.shm_direct_output = true;
    } else if (has_value && a == "--json") {
      o.json = argv[++i];
      shown += " " + o.json;
    } else if (has_value &&
               (a == "--models" || a == "--lights" || a == "--precisions" || a == "--paths")) {
      const std::set<std::string> v = SplitList(argv[++i]);
      (a == "--models"       ? o.models
       : a == "--lights"     ? o.lights
       : a == "--precisions" ? o.precisions
                             : o.paths) = v;
      shown += " " + std::string(argv[i]);
    } else if (has_value && a == "--repeat") {
      repeat = std::max(1, std::atoi(argv[++i]));
      shown += " " + std::string(argv[i]);
    } else if (has_value && a == "--min-time") {
      min_time = std::atof(argv[++i]);
      shown += " " + std::string(argv[i]);
    } else if (has_value && a == "--error-seeds") {
      error_seeds = std::max(1, std::atoi(argv[++i]));
      shown += " " + std::string(argv[i]);
    } else if (has_value && a == "--note") {
      o.note = argv[++i];
      shown += " '" + o.note + "'";
    } else if (has_value && a == "--cache-dir") {
      o.cache_dir = argv[++i];
      shown.clear();  // machine-specific: not part of the command shown
    } else {
      return usage();
    }
    if (!shown.empty()) o.command += " " + shown;
  }
  // Refuse unknown names in the filters instead of silently measuring nothing.
  std::set<std::string> known_models, known_lights;
  for (const Model *m : Models()) known_models.insert(m->name);
  for (Lights l : kAllLights) known_lights.insert(LightsName(l));
  const std::pair<const std::set<std::string> *, std::set<std::string>> filters[] = {
      {&o.models, known_models},
      {&o.lights, known_lights},
      {&o.precisions, {"fp32", "fp64"}},
      {&o.paths, {"device", "host", "end_to_end", "shared_memory"}}};
  for (const auto &[given, known] : filters)
    for (const std::string &name : *given)
      if (!known.count(name)) {
        std::string list;
        for (const std::string &k : known) list += (list.empty() ? "" : ", ") + k;
        std::fprintf(stderr, "bench_models: unknown name %s; expected one of %s\n", name.c_str(),
                     list.c_str());
        return 2;
      }
  if (o.mode == "quick") {
    o.base_queries = 16384, o.area_ref_queries = 64, o.min_time = 0.03, o.repeat = 3;
  } else if (o.mode == "tiny") {
    o.base_queries = 64, o.area_ref_queries = 8, o.max_batch = 64, o.min_time = 0, o.repeat = 1;
    o.area_truth_tiny = true;
    o.error_seeds = 2;
  }
  if (repeat) o.repeat = repeat;
  if (error_seeds) o.error_seeds = error_seeds;
  if (min_time >= 0) o.min_time = min_time;

  std::unique_ptr<DeviceEngine> engine;
  Status s = CreateEngine(o.cache_dir, &engine);
  if (!s.ok()) {
    std::fprintf(stderr, "bench_models: %s\n", s.message().c_str());
    return 1;
  }
  const std::string load_start = LoadAverage(), started = UtcNow();
  const auto t0 = Clock::now();
  Driver driver(o, engine.get());
  driver.Run();
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const std::string load_end = LoadAverage();

  std::printf(
      "bench_models (%s): device %s, %u cores, load average %s at start, %s at end, "
      "%.0f s\n\n",
      o.mode.c_str(), engine->info().name.c_str(), std::thread::hardware_concurrency(),
      load_start.c_str(), load_end.c_str(), wall);
  std::printf(
      "| model | variant | lights | precision | path | evals/s | ratio to smooth | "
      "error mean | p95 | max |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row &r : driver.rows())
    std::printf("| %s | %s | %s | %s | %s | %.4g | %s | %s | %s | %s |\n", r.model.c_str(),
                r.variant.c_str(), r.lights.c_str(), r.precision.c_str(), r.path.c_str(),
                r.evals_per_s, Fmt(r.ratio_to_smooth, "%.3g").c_str(),
                r.error_signed
                    ? (Fmt(r.error_signed, "%+.3g") + " +- " + Fmt(r.error_se, "%.2g")).c_str()
                    : Fmt(r.error_mean, "%.3g").c_str(),
                Fmt(r.error_p95, "%.3g").c_str(), Fmt(r.error_max, "%.3g").c_str());
  if (!driver.skipped().empty()) std::printf("\nnot measured:\n");
  for (const Skipped &k : driver.skipped())
    std::printf("- %s %s %s %s: %s\n", k.model.c_str(), k.variant.c_str(), k.lights.c_str(),
                k.precision.c_str(), k.reason.c_str());

  if (!o.json.empty()) {
    nlohmann::ordered_json j;
    j["command"] = o.command;
    utsname u{};
    uname(&u);
    j["machine"] = {
        {"device", engine->info().name},
        {"platform", engine->info().platform_name},
        {"cores", std::thread::hardware_concurrency()},
        {"kernel", std::string(u.sysname) + " " + u.release},
        {"load_average_start", load_start},
        {"load_average_end", load_end},
        {"started", started},
        {"wall_seconds", Num(wall)},
        {"kernels_compiled", engine->runtime().programs_compiled()},
        {"kernels_from_cache", engine->runtime().programs_loaded_from_disk()},
        {"note", o.note},
    };
    j["settings"] = {{"mode", o.mode},
                     {"base_queries", o.base_queries},
                     {"area_reference_queries", o.area_ref_queries},
                     {"max_batch", o.max_batch},
                     {"min_time_s", o.min_time},
                     {"repeat", o.repeat},
                     {"error_seeds", o.error_seeds}};
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (const Row &r : driver.rows()) {
      rows.push_back({{"model", r.model},
                      {"variant", r.variant},
                      {"lights", r.lights},
                      {"precision", r.precision},
                      {"path", r.path},
                      {"evals_per_s", Num(r.evals_per_s)},
                      {"ratio_to_smooth", Num(r.ratio_to_smooth)},
                      {"error_mean", Num(r.error_mean)},
                      {"error_p95", Num(r.error_p95)},
                      {"error_max", Num(r.error_max)},
                      {"error_se", Num(r.error_se)},
                      {"error_signed", Num(r.error_signed)},
                      {"error_seeds", r.error_seeds},
                      {"error_reference", r.error_reference.empty()
                                              ? nlohmann::ordered_json(nullptr)
                                              : nlohmann::ordered_json(r.error_reference)},
                      {"error_queries", r.error_queries},
                      {"nonfinite", r.nonfinite},
                      {"batch", r.batch},
                      {"transport", r.transport.empty() ? nlohmann::ordered_json(nullptr)
                                                        : nlohmann::ordered_json(r.transport)},
                      {"ratio_to_device", Num(r.ratio_to_device)}});
    }
    j["rows"] = rows;
    nlohmann::ordered_json skipped = nlohmann::ordered_json::array();
    for (const Skipped &k : driver.skipped())
      skipped.push_back({{"model", k.model},
                         {"variant", k.variant},
                         {"lights", k.lights},
                         {"precision", k.precision},
                         {"reason", k.reason}});
    j["skipped"] = skipped;
    std::ofstream f(o.json);
    f << j.dump(1) << "\n";
    if (!f) {
      std::fprintf(stderr, "bench_models: cannot write %s\n", o.json.c_str());
      return 1;
    }
    std::fprintf(stderr, "wrote %s (%zu rows)\n", o.json.c_str(), driver.rows().size());
  }
  // A model of the table with no row over every light set means the driver no longer covers it
  // (its case registers nothing that validates, or every run failed): fail so the smoke test
  // notices. With --lights a model may rightly have none (BINOMIAL refuses probes).
  int missing = 0;
  for (const Model *model : Models()) {
    if (!Selected(o.models, model->name)) continue;
    const bool any = std::any_of(driver.rows().begin(), driver.rows().end(),
                                 [&](const Row &r) { return r.model == model->name; });
    if (!any) {
      std::fprintf(stderr, "bench_models: no row for model %s\n", model->name);
      missing += o.lights.empty() ? 1 : 0;
    }
  }
  return driver.rows().empty() || missing ? 1 : 0;
}

}  // namespace
}  // namespace glint::bench

int main(int argc, char **argv) {
  return glint::bench::Main(argc, argv);
}
