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
//   evals_per_s      queries / median seconds of --repeat runs (--quick: or the mean of two
//                    runs within 5%, Driver::Time); the batch (the shared queries
//                    tiled) grows until one run takes >= the minimum time or reaches 2^20 queries,
//                    after an untimed run that compiles and warms the kernel (--quick: on 16
//                    queries, and a first run of the starting batch at >= 2x the minimum time
//                    is the first repeat: Driver::Time says why);
//   timing_shared_with  --quick (and --tiny) only: the variant whose evals_per_s and batch the
//                    row reports, not timed again: the case declares their work the same
//                    (ModelBenchCase::same_work: KEMPPINEN's k under polygon lights) and the
//                    same program and passes gave bit-identical radiance on every query of the
//                    timed batch (Driver::SharedTiming); null = timed itself;
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
//                    1 for the others; --error-seeds S for all; 2 with --tiny)
//                    on the shared queries (--quick: a case may use fewer, KEMPPINEN's four
//                    quads 4096; the row's error_queries says how many), error_mean
//                    its absolute value, error_signed with the sign, error_se its standard
//                    error (the larger of the delta method over seeds x queries and the spread
//                    of the per-seed means; Driver::Errors says why one seed is not enough).
// Printed as a markdown table; --json PATH writes {"command", "machine", "rows": [...],
// "skipped": [...]} (scripts/bench_tables.py turns it into the README's performance section).
//
// Before the first row every kernel variant the run needs is built (Driver::WarmUp), in
// --compile-jobs processes (default: one per core) sharing the kernel cache, so no row's first
// run compiles; stderr and the JSON's machine.time_breakdown say where the time went. --quick
// and --tiny build an LTC polygon row's programs for LTC alone (--area-programs ltc-only,
// DeviceEngineOptions::ltc_only_programs: the glint models' *_area programs without the
// per-query integrators their LTC rows never run, about half the compile; radiance
// bit-identical, bench_area_programs); the full run builds glintd's (--area-programs shared).
// --warm-up-only stops after the warm-up.
//
//   build/bench/bench_models --quick --json bench/results/quick.json   # < 3 min, even cold
//   build/bench/bench_models --json results.json                       # every variant, longer
// Flags: --quick | --tiny (seconds; the ctest smoke run), --models A,B, --lights a,b,
// --precisions fp32,fp64, --paths device,host,end_to_end,shared_memory, --repeat R, --min-time S,
// --shm-direct-output, --error-seeds S,
// --note TEXT (stored in the JSON's machine note), --cache-dir DIR (default: glintd's,
// $GLINT_CACHE_DIR; PoCL's own cache goes to DIR/pocl), --compile-jobs N,
// --area-programs ltc-only|shared, --warm-up-only.
#include <fcntl.h>
#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
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
  // Processes compiling the run's kernels up front (--compile-jobs; see Driver::WarmUp).
  int compile_jobs = int(std::max(1u, std::thread::hardware_concurrency()));
  std::string compile_worker;               // --compile-worker DIR: a child of WarmUp
  std::vector<std::string> selection_args;  // the flags that choose what runs, for the children
  // --area-programs ltc-only|shared: DeviceEngineOptions::ltc_only_programs (an LTC polygon
  // row's programs built for LTC alone) or glintd's programs; default ltc-only with
  // --quick and --tiny, shared in the full run (bench/README.md says why).
  std::string area_programs;
  bool warm_up_only = false;  // --warm-up-only: the warm-up and its time breakdown, no rows
};

bool Selected(const std::set<std::string> &filter, const std::string &name) {
  return filter.empty() || filter.count(name);
}

struct Row {
  std::string model, variant, lights, precision, path;
  double evals_per_s = NAN;
  std::optional<double> ratio_to_smooth, error_mean, error_p95, error_max, error_se;
  std::optional<double> error_signed;  // glint models: mean / smooth mean - 1 (error_mean = |.|)
  int error_seeds = 0;                 // glint models: the request seeds behind it
  // Timed itself: the slowest of its runs over the fastest, minus 1 (stderr only: what a
  // shorter or fewer runs would risk on this machine).
  double spread = NAN;
  int runs = 0;                 // the timed runs behind evals_per_s (stderr only)
  std::string error_reference;  // "" = none
  uint32_t batch = 0;           // queries per timed run
  uint32_t error_queries = 0;
  uint32_t nonfinite = 0;
  std::string transport;  // end_to_end: unary or stream; shared_memory: shm or shm-direct
  // end_to_end and shared_memory: device seconds / this path's seconds (medians), the device
  // timed on the same batch right before each of this path's runs (the device rate of this VM
  // changes 2x between moments: the PoCL threads stacked on one core or spread over two).
  std::optional<double> ratio_to_device;
  // The radiance bits of the row's own request (its seed) on its first error queries, from
  // Errors: FNV-1a over the floats, and the query count (0 = not recorded).
  uint64_t output_hash = 0;
  uint32_t output_queries = 0;
  std::string kernel;  // the program and passes the row runs (Driver::KernelKey)
  std::string work;    // ModelBenchCase::same_work of its variant and light set ("" = none)
  // --quick: the variant whose timing this row reports (evals_per_s, batch), when both run the
  // same program and passes and gave bit-identical radiance on every query of this row's timed
  // batch (see Driver::SharedTiming); "" = timed itself.
  std::string timing_shared_with;
};

// FNV-1a over the bits of the first n RGB results.
uint64_t OutputHash(const std::vector<float> &rgb, uint32_t n) {
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < 3 * size_t(n) && i < rgb.size(); ++i) {
    uint32_t bits = 0;
    std::memcpy(&bits, &rgb[i], sizeof bits);
    for (int b = 0; b < 4; ++b) h = (h ^ ((bits >> (8 * b)) & 0xffu)) * 1099511628211ull;
  }
  return h;
}

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

// Time()'s batch growth: the next batch after one of n queries took t seconds, aiming at
// 1.3 x min_time, at least doubling and at most x64.
uint32_t NextBatch(uint32_t n, double t, double min_time, uint32_t max_batch) {
  const double grow = std::clamp(1.3 * min_time / std::max(t, 1e-6), 2.0, 64.0);
  return uint32_t(std::min(double(max_batch), std::ceil(n * grow)));
}

// One combination the run measures: a model's variant under a light set at a precision, as the
// request every path times (valid: the server's validation of it).
struct Combination {
  const Model *model = nullptr;
  const ModelBenchCase *bench_case = nullptr;
  Lights lights = Lights::kProbe;
  const BenchVariant *variant = nullptr;
  bool fp64 = false;
  glint::v1::EvaluateRequest request;
  Status valid;
};

// What DeviceEngine compiles and runs for a plan: the model, the spec, the passes it needs and
// the build options ("SMOOTH smooth/ggx/schlick/probe/fp32 glint_smooth [-DGLINT_NDF=1 ...]");
// the spec as the engine builds it (DeviceEngine::ProgramSpec: with --quick a polygon plan's
// area method is part of it).
std::string KernelKey(const DeviceEngine &engine, const Model &model, const EvalPlan &plan) {
  const KernelSpec spec = engine.ProgramSpec(plan);
  std::string key = std::string(model.name) + " " + spec.Describe();
  for (const ModelPass &pass : model.passes)
    if (!pass.needed || pass.needed(plan)) key += std::string(" ") + pass.entry;
  return key + " [" + spec.BuildOptions() + "]";
}

// CPU seconds (user + system) of this process, all its threads (RUSAGE_SELF: the PoCL workers
// included), or of its ended and waited-for children (RUSAGE_CHILDREN: the compile processes).
// On a shared machine the wall time of a phase depends on the other jobs; its CPU time much
// less (issue 13's 3-minute bound is measured quiet; a loaded run reports where the CPU went).
double CpuSeconds(int who = RUSAGE_SELF) {
  rusage u{};
  getrusage(who, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// Where the time of a run goes, per model (stderr and the JSON's machine block): wall seconds,
// and the CPU seconds of this process (all threads) in the same phases.
struct Phases {
  double first_run = 0;   // each row's untimed first run (compile or load, when not warmed)
  double timed = 0;       // batch growth and the timed runs
  double clocked = 0;     // of `timed`: inside the clock of the timed and growth runs (the rest
                          // tiles the batch, copies requests, allocates the output)
  double errors = 0;      // the rows' own evaluations for their errors
  double references = 0;  // fp64 host references and REFERENCE truths (shared between rows)
  double first_run_cpu = 0, timed_cpu = 0, errors_cpu = 0, references_cpu = 0;
};

class Driver {
 public:
  Driver(Options o, DeviceEngine *engine);

  // Builds every kernel variant the run needs before any row is timed (see the definition).
  void WarmUp();
  // --compile-worker: builds the variants this process claims; false if one failed.
  bool CompileWorker(const std::string &claim_dir);
  void Run();
  const std::vector<Row> &rows() const { return rows_; }
  const std::vector<Skipped> &skipped() const { return skipped_; }
  const std::map<std::string, Phases> &phases() const { return phases_; }
  double warm_up_seconds() const { return warm_up_seconds_; }
  // CPU seconds of the warm-up: this process's, and its compile children's.
  double warm_up_cpu() const { return warm_up_cpu_; }
  double warm_up_children_cpu() const { return warm_up_children_cpu_; }
  int warm_up_variants() const { return warm_up_variants_; }
  int warm_up_processes() const { return warm_up_processes_; }
  int warm_up_child_failures() const { return warm_up_child_failures_; }

 private:
  struct ModelRun {
    const Model *model;
    ModelBenchCase bench_case;
    glint::v1::QueryBatch probe, lit;  // the shared queries, footprints as the case wants
    QueryStats stats;
  };
  // A kernel variant the run needs: its key (model, build options, the passes it runs) and a
  // one-query request of it.
  struct WarmItem {
    std::string key;
    glint::v1::EvaluateRequest request;  // a combination's request of the variant
    int lanes_min = 1, lanes_max = 1;    // queries per work-item of its passes
    double cost = 1;                     // expected compile time, relative (WarmItems)
  };
  // Calls fn for every combination the options select, in the order of the rows.
  void ForEach(const std::function<void(Combination &)> &fn) const;
  std::vector<WarmItem> WarmItems() const;
  // Runs the item's kernels once on worker 0 (building or loading them; see the definition).
  // Prints what it did (compile or load; `child`: in a compile child) and the seconds.
  // *compiled: whether it compiled. False (and a message) on failure.
  bool WarmOne(const WarmItem &item, bool child, bool *compiled = nullptr);
  // Claims `item` for this process: true for exactly one process of the run.
  static bool Claim(const std::string &claim_dir, const WarmItem &item);
  static std::string ClaimPath(const std::string &claim_dir, const WarmItem &item);
  // A compile child marks each variant it built (in the shared cache) so that this process can
  // load it while the children still compile (Built), instead of after them all.
  static void MarkBuilt(const std::string &claim_dir, const WarmItem &item);
  static bool Built(const std::string &claim_dir, const WarmItem &item);
  // Times `request` on `path`; false (and *why) when the path fails.
  bool Time(const std::string &path, const glint::v1::EvaluateRequest &request, Row *row,
            std::string *why);
  // Evaluates the first n queries of `request` on `path` (untimed).
  bool Eval(const std::string &path, const glint::v1::EvaluateRequest &request, uint32_t n,
            std::vector<float> *out, std::string *why);
  // Eval for a row's error: the host path split over two threads (HostParallel), untimed; the
  // same bits as one thread (the host path's result does not depend on how the queries are
  // split: DESIGN.md, Determinism).
  bool EvalForErrors(const std::string &path, const glint::v1::EvaluateRequest &request, uint32_t n,
                     std::vector<float> *out, std::string *why);
  void Errors(const Model &model, const ModelBenchCase &c, Lights lights,
              const glint::v1::EvaluateRequest &request, const std::string &path, Row *row);
  // --quick: an earlier row whose timing `row` may report instead of timing itself: the same
  // model, light set, precision, path, declared work (ModelBenchCase::same_work, non-empty),
  // program and passes (Row::kernel), timed itself, and the same radiance bits on `row`'s first
  // error queries (Row::output_hash, the request's own seed), which hold every query of that
  // row's timed batch (its batch tiles the first `batch` shared queries: no more than were
  // compared). The case says why the knob does not change the work; the same program giving
  // the same bits on every query of the batch checks that it changed nothing the kernel
  // computes there. KEMPPINEN's polygon pass is the case: it widens the explicit angular block
  // to cover the light's image up to 4 x 4 cells whatever k (models/kemppinen/README.md, Polygon
  // lights), so on the 6 x 6 quad k = 1, 4, 9, 16 run the same block, on the four small quads
  // k = 1 and 4 (k = 9 and 16 differ there on some queries and are timed themselves). nullptr:
  // time it.
  const Row *SharedTiming(const Row &row) const;
  const std::vector<double> &ExactReference(const std::string &key,
                                            const glint::v1::EvaluateRequest &request);
  const std::vector<double> &AreaTruth(const std::string &key,
                                       const glint::v1::EvaluateRequest &request, double *floor);
  const std::vector<double> &SmoothReference(const std::string &key,
                                             const glint::v1::EvaluateRequest &request);

  Options o_;
  DeviceEngine *engine_;
  std::unique_ptr<LoopbackService> service_;
  std::vector<ModelRun> runs_;
  std::vector<Row> rows_;
  std::vector<Skipped> skipped_;
  std::map<std::string, std::vector<double>> refs_;
  std::map<std::string, double> floors_;
  std::map<std::string, Phases> phases_;  // by model name
  double reference_seconds_ = 0;          // running total of the reference computations
  double reference_cpu_ = 0;              // the same in CPU seconds of this process
  double warm_up_seconds_ = 0, warm_up_cpu_ = 0, warm_up_children_cpu_ = 0;
  int warm_up_variants_ = 0, warm_up_processes_ = 1;
  int warm_up_child_failures_ = 0;  // compile children not started, or not ending with 0
};

Driver::Driver(Options o, DeviceEngine *engine) : o_(std::move(o)), engine_(engine) {
  const glint::v1::QueryBatch probe = SharedQueries(o_.base_queries, true);
  const glint::v1::QueryBatch lit = SharedQueries(o_.base_queries, false);
  std::map<int, ModelBenchCase> cases;
  for (ModelBenchCase &c : BenchCases()) cases[int(c.model)] = std::move(c);
  for (const Model *model : Models()) {
    if (!Selected(o_.models, model->name)) continue;
    ModelRun run{model, {}, probe, lit, {}};
    ModelBenchCase &c = run.bench_case;
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
    if (c.footprints) c.footprints(&run.probe), c.footprints(&run.lit);
    run.stats = StatsOf(run.lit);
    runs_.push_back(std::move(run));
  }
}

void Driver::ForEach(const std::function<void(Combination &)> &fn) const {
  const bool fp64_ok = engine_->info().fp64;
  for (const ModelRun &run : runs_) {
    const ModelBenchCase &c = run.bench_case;
    for (Lights lights : kAllLights) {
      if (!Selected(o_.lights, LightsName(lights))) continue;
      for (const BenchVariant &v : c.variants) {
        if (!v.lights.empty() &&
            std::find(v.lights.begin(), v.lights.end(), lights) == v.lights.end())
          continue;
        if (o_.mode != "full" && !v.quick) continue;
        for (bool fp64 : {false, true}) {
          if (!Selected(o_.precisions, PrecisionName(fp64))) continue;
          Combination k;
          k.model = run.model, k.bench_case = &c, k.lights = lights, k.variant = &v;
          k.fp64 = fp64;
          glint::v1::EvaluateRequest &r = k.request;
          auto *m = r.mutable_material();
          m->set_model(run.model->id);
          c.base(m);
          r.set_precision(fp64 ? glint::v1::FP64 : glint::v1::FP32);
          r.set_seed(0x9e3779b97f4aull);
          *r.mutable_queries() = lights == Lights::kProbe ? run.probe : run.lit;
          AddLights(lights, &r);
          if (v.apply) v.apply(&r, run.stats);
          k.valid = Validate(r, fp64_ok);
          fn(k);
        }
      }
    }
  }
}

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

bool Driver::EvalForErrors(const std::string &path, const glint::v1::EvaluateRequest &request,
                           uint32_t n, std::vector<float> *out, std::string *why) {
  if (path != "host") return Eval(path, request, n, out, why);
  *out = HostParallel(request, n);
  return true;
}

bool Driver::Time(const std::string &path, const glint::v1::EvaluateRequest &request, Row *row,
                  std::string *why) {
  std::vector<float> out;
  uint32_t n = std::min(o_.base_queries, 256u);
  Phases &phases = phases_[row->model];
  const auto start = Clock::now();
  const double start_cpu = CpuSeconds();
  // The untimed first run: compile or load, if not warmed. --quick runs it on a few queries:
  // WarmUp ran every variant once already (programs built, PoCL's work-group function compiled
  // for the engine's local size, which a batch of any size shares), the device engine makes its
  // buffers per call (nothing sized by this run carries over), and the service paths start the
  // loopback service on any request; on the slowest rows (NORMAL_MAP quad, ~500 evals/s) 256
  // queries took 0.5 s each.
  const uint32_t first_n = o_.mode == "quick" ? std::min(n, 16u) : n;
  const bool first_ok = Eval(path, request, first_n, &out, why);
  const auto timed_start = Clock::now();
  const double timed_start_cpu = CpuSeconds();
  phases.first_run += std::chrono::duration<double>(timed_start - start).count();
  phases.first_run_cpu += timed_start_cpu - start_cpu;
  if (!first_ok) return false;
  // Everything after the first run counts as timing, however the function returns.
  struct AddOnExit {
    double *to, *to_cpu;
    Clock::time_point since;
    double since_cpu;
    ~AddOnExit() {
      *to += std::chrono::duration<double>(Clock::now() - since).count();
      *to_cpu += CpuSeconds() - since_cpu;
    }
  } add_timed{&phases.timed, &phases.timed_cpu, timed_start, timed_start_cpu};
  // The request of `count` queries, tiled once per batch size: the repeats and the interleaved
  // device runs reuse it (tiling 2^20 queries costs more than a fast row's timed run; none of it
  // is inside the clock).
  glint::v1::EvaluateRequest tiled;
  uint32_t tiled_count = 0;
  std::vector<float> o;
  auto batch_of = [&](uint32_t count) -> const glint::v1::EvaluateRequest & {
    if (tiled_count != count || !tiled.has_queries()) {
      tiled = request;
      *tiled.mutable_queries() = Tile(request.queries(), count);
      tiled_count = count;
    }
    o.resize(3 * size_t(count));
    return tiled;
  };
  auto once = [&](uint32_t count, double *seconds) {
    const glint::v1::EvaluateRequest &r = batch_of(count);
    bool ok = true;
    if (path == "end_to_end") {
      glint::client::EvaluateInfo info;
      const auto t0 = Clock::now();
      grpc::Status s = service_->Evaluate(r, &o, &info);
      *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
      phases.clocked += *seconds;
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
      phases.clocked += *seconds;
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
    phases.clocked += *seconds;
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
  const uint32_t start_n = n;
  if (!once(n, &t)) return false;
  while (!same_as_device && t < o_.min_time && n < o_.max_batch) {
    n = NextBatch(n, t, o_.min_time, o_.max_batch);
    if (!once(n, &t)) return false;
  }
  // The device on the same batch, for the interleaved ratio of a transport row.
  auto device_once = [&](uint32_t count, double *seconds) {
    const glint::v1::EvaluateRequest &r = batch_of(count);
    const EvalPlan plan = ResolvedPlan(r, r.queries());
    const auto t0 = Clock::now();
    Status s = engine_->Evaluate(0, plan, r.queries(), o.data());
    *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    phases.clocked += *seconds;
    if (!s.ok()) *why = "device: " + s.message();
    return s.ok();
  };
  std::vector<double> times, device_times;
  // --quick: the last run of the growth is the first of the repeats: a run of the final batch,
  // whose size was fixed before it ran (from the run before it, aiming at 1.3 x the minimum
  // time, or the cap), on the same tiled request and output as the repeats (built before the
  // clock; the device engine makes its buffers per call, so a first run at a size sets up
  // nothing that a repeat does not), so it measures that batch as the repeats do. It saves one
  // of the final batch's four runs (session 13's quiet --quick: ~8 of the 57 s in the clock).
  // One condition comes with it: it ended the growth by taking at least the minimum time, so
  // had it come out faster it would have grown the batch instead. Where the batch was aimed at
  // 1.3 x that is a run ~23% faster than its batch's typical run, in the tail of a quiet run's
  // spread, and where the cap ended the growth there is no condition at all; rows whose runs sit
  // just above the minimum (1.05 x in session 13's JSON) can lose a fast first run that way,
  // which moves their median of three by at most the spread between runs. A first run of the
  // starting batch counts only at twice the minimum time or more (session 13): nothing aimed
  // its size, so "at least the minimum" would select its slow outcomes. Not for end_to_end and
  // shared_memory, whose runs pair with interleaved device runs.
  if (o_.mode == "quick" && !same_as_device && (n != start_n || t >= 2 * o_.min_time))
    times.push_back(t);
  // --quick (median of 3): two runs within kAgree of each other end the repeats, and the row
  // reports their mean time. The median of three runs always lies between the first two (a
  // third run below both makes the faster of them the median, above both the slower), so the
  // mean of two within 5% is within 2.5% of the median the third run would have given,
  // whatever it came out; quick rows move more than that between quiet runs (README: up to 30%
  // for the same SMOOTH row). The third run is skipped on a quiet machine for most rows; a
  // loaded one spreads them more and runs it. end_to_end and shared_memory: both series, the
  // path's and the interleaved device's, within 5% (their ratio then within ~5% of the one a
  // third pair would have given).
  constexpr double kAgree = 0.05;
  auto agree = [&](const std::vector<double> &v) {
    return v.size() == 2 && std::max(v[0], v[1]) <= (1 + kAgree) * std::min(v[0], v[1]);
  };
  const bool stop_at_two = o_.mode == "quick" && o_.repeat == 3;
  for (int k = int(times.size()); k < o_.repeat; ++k) {
    if (stop_at_two && agree(times) && (!same_as_device || agree(device_times))) break;
    if (same_as_device) {
      double d = 0;
      if (!device_once(n, &d)) return false;
      device_times.push_back(d);
    }
    if (!once(n, &t)) return false;
    times.push_back(t);
  }
  // The median, or with two runs that ended the repeats (stop_at_two) their mean.
  auto middle = [&](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return stop_at_two && v.size() == 2 ? 0.5 * (v[0] + v[1]) : v[v.size() / 2];
  };
  row->evals_per_s = n / middle(times);
  row->spread = *std::max_element(times.begin(), times.end()) /
                    *std::min_element(times.begin(), times.end()) -
                1;
  row->runs = int(times.size());
  if (!device_times.empty()) row->ratio_to_device = middle(device_times) / middle(times);
  row->batch = n;
  return true;
}

const Row *Driver::SharedTiming(const Row &row) const {
  if (row.work.empty() || row.kernel.empty() || row.output_queries == 0) return nullptr;
  for (const Row &r : rows_)
    if (r.model == row.model && r.lights == row.lights && r.precision == row.precision &&
        r.path == row.path && r.work == row.work && r.kernel == row.kernel &&
        r.timing_shared_with.empty() && r.output_queries == row.output_queries &&
        r.output_hash == row.output_hash && r.batch <= row.output_queries)
      return &r;
  return nullptr;
}

const std::vector<double> &Driver::ExactReference(const std::string &key,
                                                  const glint::v1::EvaluateRequest &request) {
  auto it = refs_.find(key);
  if (it != refs_.end()) return it->second;
  const auto t0 = Clock::now();
  const double cpu0 = CpuSeconds();
  glint::v1::EvaluateRequest r = request;
  r.set_precision(glint::v1::FP64);
  const std::vector<float> out = HostParallel(r, r.queries().count());
  reference_seconds_ += std::chrono::duration<double>(Clock::now() - t0).count();
  reference_cpu_ += CpuSeconds() - cpu0;
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
    const double cpu0 = CpuSeconds();
    const uint32_t n = std::min(o_.area_ref_queries, r.queries().count());
    const std::vector<float> out = HostParallel(r, n);
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    reference_seconds_ += seconds;
    reference_cpu_ += CpuSeconds() - cpu0;
    std::fprintf(stderr, "  truth %s: REFERENCE:%u fp64 host, %u queries, %.1f s\n", key.c_str(),
                 r.area_samples(), n, seconds);
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
  const auto t0 = Clock::now();
  const double cpu0 = CpuSeconds();
  glint::v1::EvaluateRequest r = request;
  r.set_precision(glint::v1::FP64);
  const std::vector<float> out = HostParallel(r, r.queries().count());
  reference_seconds_ += std::chrono::duration<double>(Clock::now() - t0).count();
  reference_cpu_ += CpuSeconds() - cpu0;
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
    if (!EvalForErrors(path, request, uint32_t(ref.size()), &out, &why)) return;
    row->output_hash = OutputHash(out, uint32_t(ref.size()));
    row->output_queries = uint32_t(ref.size());
    double top = 0;
    for (double v : ref) top = std::max(top, v);
    const ErrorStats s = Summarise(RelativeErrors(out.data(), ref, 1e-3 * top, &row->nonfinite));
    row->error_mean = s.mean, row->error_p95 = s.p95, row->error_max = s.max;
    row->error_reference = "fp64 host";
    row->error_queries = uint32_t(ref.size());
  } else if (c.error == ErrorReference::kExact) {
    double floor = 0;
    const auto &truth = AreaTruth(light_key, request, &floor);
    if (!EvalForErrors(path, request, uint32_t(truth.size()), &out, &why)) return;
    row->output_hash = OutputHash(out, uint32_t(truth.size()));
    row->output_queries = uint32_t(truth.size());
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
    // --quick: the case's smaller sample where it names one (ModelBenchCase::quick_error_*).
    const bool quick = o_.mode == "quick";
    uint32_t n = request.queries().count();
    if (quick && c.quick_error_queries && c.quick_error_queries(lights) > 0)
      n = std::min(n, c.quick_error_queries(lights));
    glint::v1::EvaluateRequest sample = request;
    *sample.mutable_queries() = Tile(request.queries(), n);
    const auto &sv = SmoothReference(light_key + "|" + std::to_string(n), AsSmooth(sample, model));
    const int case_seeds = quick && c.quick_error_seeds > 0 ? c.quick_error_seeds : c.error_seeds;
    const int seeds = std::max(1, o_.error_seeds ? o_.error_seeds : case_seeds);
    std::vector<std::vector<double>> gv;
    for (int k = 0; k < seeds; ++k) {
      glint::v1::EvaluateRequest r = sample;
      r.set_seed(request.seed() + uint64_t(k) * 0x100000001ull);
      if (!EvalForErrors(path, r, n, &out, &why)) return;
      if (k == 0) row->output_hash = OutputHash(out, n), row->output_queries = n;
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

// The kernel variants of the run: one per model, build options and set of passes (what
// DeviceEngine compiles), each with a one-query request of it. The service paths use the device
// rows' kernels; when only they are selected every fp32 variant is listed (a superset).
std::vector<Driver::WarmItem> Driver::WarmItems() const {
  std::vector<WarmItem> items;
  std::set<std::string> seen;
  const bool device = Selected(o_.paths, "device");
  const bool service = Selected(o_.paths, "end_to_end") || Selected(o_.paths, "shared_memory");
  ForEach([&](Combination &k) {
    if (!k.valid.ok() || !(device || (service && !k.fp64))) return;
    WarmItem item;
    item.request = k.request;
    EvalPlan plan;
    try {
      plan = ResolvedPlan(item.request, Tile(k.request.queries(), 1));
    } catch (const std::exception &) {
      return;  // the row reports it
    }
    item.key = KernelKey(*engine_, *k.model, plan);
    item.lanes_min = 1 << 30, item.lanes_max = 1;
    for (const ModelPass &pass : k.model->passes)
      if (!pass.needed || pass.needed(plan)) {
        item.lanes_min = std::min(item.lanes_min, pass.Width(plan.spec.fp64));
        item.lanes_max = std::max(item.lanes_max, pass.Width(plan.spec.fp64));
      }
    item.lanes_min = std::min(item.lanes_min, item.lanes_max);
    // Expected compile cost, for the order: seen cold on this machine (loaded), a SMOOTH
    // probe or punctual variant ~12 s, SMOOTH polygons with the 8-lane LTC pass ~50 s, with the
    // one-query-per-item area pass ~150 s, BINOMIAL ~170 s; other glint models taken as heavy.
    item.cost = k.model->id == glint::v1::SMOOTH ? 1 : 12;
    if (plan.spec.has_polygon) item.cost *= item.lanes_min == 1 ? 12 : 4;
    if (seen.insert(item.key).second) items.push_back(std::move(item));
  });
  // The costliest first: the processes claim in this order, so the last claims are short and
  // the processes finish together (longest-processing-time-first scheduling).
  std::stable_sort(items.begin(), items.end(),
                   [](const WarmItem &a, const WarmItem &b) { return a.cost > b.cost; });
  return items;
}

// One run of the variant's kernels on one query builds (or loads) everything its rows use: its
// programs and, at the first enqueue, PoCL's work-group function for the local size. PoCL 3.1
// compiles another work-group function for grids with a dimension of 65535 work-items or more
// ("smallgrid" specialisation, pocl_cache.c); the device engine's launches never reach that
// (a 2D grid, server/launch_grid.h), so the rows' large batches run the one compiled here.
bool Driver::WarmOne(const WarmItem &item, bool child, bool *compiled) {
  const auto t0 = Clock::now();
  const double cpu0 = CpuSeconds();
  std::vector<float> out;
  std::string why;
  const int compiled_before = engine_->runtime().programs_compiled();
  const bool ok = Eval("device", item.request, 1, &out, &why);
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  const double cpu = CpuSeconds() - cpu0;
  // A variant loaded from the disk cache was compiled by an earlier run or a compile child.
  const bool built = engine_->runtime().programs_compiled() != compiled_before;
  if (compiled) *compiled = built;
  std::fprintf(stderr, "  %s%s %.1f s (%.1f s CPU): %s%s\n", built ? "compile" : "load",
               child ? " (child)" : "", seconds, cpu, item.key.c_str(),
               ok ? "" : (" failed: " + why).c_str());
  return ok;
}

std::string Driver::ClaimPath(const std::string &claim_dir, const WarmItem &item) {
  uint64_t h = 1469598103934665603ull;  // FNV-1a: the same name in every process
  for (unsigned char ch : item.key) h = (h ^ ch) * 1099511628211ull;
  char name[32];
  std::snprintf(name, sizeof name, "/%016llx", static_cast<unsigned long long>(h));
  return claim_dir + name;
}

bool Driver::Claim(const std::string &claim_dir, const WarmItem &item) {
  const int fd = open(ClaimPath(claim_dir, item).c_str(), O_CREAT | O_EXCL | O_WRONLY, 0600);
  if (fd < 0) return false;
  close(fd);
  return true;
}

void Driver::MarkBuilt(const std::string &claim_dir, const WarmItem &item) {
  const int fd = open((ClaimPath(claim_dir, item) + ".built").c_str(), O_CREAT | O_WRONLY, 0600);
  if (fd >= 0) close(fd);
}

bool Driver::Built(const std::string &claim_dir, const WarmItem &item) {
  return access((ClaimPath(claim_dir, item) + ".built").c_str(), F_OK) == 0;
}

// Compiles every kernel variant the run needs before the first row, in --compile-jobs processes.
// Why processes: PoCL 3.1 serialises kernel compilation inside a process. clBuildProgram holds
// its context's LLVM lock, and the work-group function it compiles at a kernel's first enqueue
// (most of the time) holds the process-wide dlhandle-cache lock (pocl common_driver.c,
// pocl_check_kernel_dlhandle_cache), so threads, even with one cl_context each, take turns.
// The children (this binary with --compile-worker and the same selection) and this process
// claim variants one by one (an O_EXCL file per variant in a fresh directory); each compiles its
// claims into the shared kernel cache (--cache-dir; on PoCL its own cache under pocl/, which
// holds the compiled programs and work-group functions, server/cl_runtime.h ProgramStore). Then
// this process runs every variant once, loading the children's from the disk cache. Without a
// disk cache, or with --compile-jobs 1, it compiles them all itself, still before any row, so no
// row's first run compiles. A child that cannot be started, or ends with a failure or a signal,
// is reported on stderr (and counted in the JSON's time breakdown); the variants it did not leave
// in the cache are then compiled here like the others.
void Driver::WarmUp() {
  const auto t0 = Clock::now();
  const double cpu0 = CpuSeconds(), children_cpu0 = CpuSeconds(RUSAGE_CHILDREN);
  const std::vector<WarmItem> items = WarmItems();
  warm_up_variants_ = int(items.size());
  const int jobs = std::min(o_.compile_jobs, int(items.size()));
  std::string claim_dir;
  if (jobs > 1 && !o_.cache_dir.empty()) {
    char dir[] = "/tmp/bench_models_claims.XXXXXX";
    if (mkdtemp(dir)) claim_dir = dir;
  }
  std::set<std::string> built_here;  // compiled by this process (its claims)
  std::set<std::string> ready_here;  // run once on this engine: its claims and loads so far
  std::map<pid_t, int> ended;        // children reaped while loading, and their status
  int fallback = 0;                  // variants this process compiled that a child had claimed
  warm_up_child_failures_ = 0;
  if (!claim_dir.empty()) {
    std::vector<pid_t> children;
    for (int j = 1; j < jobs; ++j) {
      std::vector<std::string> args = {"bench_models"};
      args.insert(args.end(), o_.selection_args.begin(), o_.selection_args.end());
      for (const char *a :
           {"--cache-dir", o_.cache_dir.c_str(), "--compile-worker", claim_dir.c_str()})
        args.push_back(a);
      std::vector<char *> argv;
      for (std::string &a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      pid_t pid = 0;
      if (const int err =
              posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv.data(), environ);
          err == 0) {
        children.push_back(pid);
      } else {
        ++warm_up_child_failures_;
        std::fprintf(stderr, "bench_models: could not start compile process %d: %s\n", j,
                     std::strerror(err));
      }
    }
    // Loads the variants the children have built so far (one PoCL cache lookup and work-group
    // function load each, ~0.1-0.5 s on the quiet machine): between this process's own
    // compiles and while it waits for the children, not all after them with the second core
    // idle (session 13: 16 loads after the children had ended).
    auto load_built = [&] {
      int loaded = 0;
      for (const WarmItem &item : items)
        if (!ready_here.count(item.key) && Built(claim_dir, item)) {
          bool compiled = false;
          WarmOne(item, false, &compiled);
          fallback += compiled;  // not in the cache after all: compiled here
          ready_here.insert(item.key);
          ++loaded;
        }
      return loaded;
    };
    for (const WarmItem &item : items) {
      load_built();
      if (Claim(claim_dir, item)) {
        WarmOne(item, false);
        ready_here.insert(item.key);
        built_here.insert(item.key);
      }
    }
    // Until every child has ended: load what they built, else poll (20 ms) for their end.
    for (std::vector<pid_t> running = children; !running.empty();) {
      if (load_built()) continue;
      bool any_ended = false;
      for (size_t c = 0; c < running.size(); ++c) {
        int status = 0;
        const pid_t got = waitpid(running[c], &status, WNOHANG);
        if (got == 0) continue;
        if (got == running[c]) ended[got] = status;  // else a waitpid failure, reported below
        running.erase(running.begin() + std::ptrdiff_t(c));
        any_ended = true;
        break;
      }
      if (!any_ended) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    for (pid_t pid : children) {
      int status = 0;
      const auto it = ended.find(pid);
      if (it != ended.end()) status = it->second;
      if (it == ended.end() && waitpid(pid, &status, 0) != pid) {
        ++warm_up_child_failures_;
        std::fprintf(stderr, "bench_models: compile process %d: waitpid: %s\n", int(pid),
                     std::strerror(errno));
      } else if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        ++warm_up_child_failures_;
        if (WIFSIGNALED(status))
          std::fprintf(stderr, "bench_models: compile process %d ended by signal %d (%s)\n",
                       int(pid), WTERMSIG(status), strsignal(WTERMSIG(status)));
        else
          std::fprintf(stderr, "bench_models: compile process %d exited with status %d\n", int(pid),
                       WEXITSTATUS(status));
      }
    }
    warm_up_processes_ = 1 + int(children.size());
    std::error_code ec;
    std::filesystem::remove_all(claim_dir, ec);
  }
  // Every variant on this engine: built or loaded here already, loaded from the disk cache (a
  // child's), or compiled now (no children, or a child failed).
  for (const WarmItem &item : items) {
    if (ready_here.count(item.key)) continue;
    bool compiled = false;
    WarmOne(item, false, &compiled);
    fallback += compiled && !claim_dir.empty();
  }
  if (fallback)
    std::fprintf(stderr,
                 "bench_models: %d variants were not in the cache after the compile processes "
                 "(%d failed to start or finish): compiled in this process\n",
                 fallback, warm_up_child_failures_);
  warm_up_seconds_ = std::chrono::duration<double>(Clock::now() - t0).count();
  warm_up_cpu_ = CpuSeconds() - cpu0;
  warm_up_children_cpu_ = CpuSeconds(RUSAGE_CHILDREN) - children_cpu0;
}

bool Driver::CompileWorker(const std::string &claim_dir) {
  bool failed = false;
  for (const WarmItem &item : WarmItems())
    if (Claim(claim_dir, item)) {
      if (WarmOne(item, true))
        MarkBuilt(claim_dir, item);
      else
        failed = true;
    }
  return !failed;
}

void Driver::Run() {
  // The service paths run each model's first variant per light set that gave a row.
  std::map<std::string, std::string> first_variant;  // model|lights -> variant
  ForEach([&](Combination &k) {
    const std::string model = k.model->name, variant = k.variant->name;
    if (!k.valid.ok()) {
      skipped_.push_back(
          {model, variant, LightsName(k.lights), PrecisionName(k.fp64), k.valid.message()});
      return;
    }
    std::string &first = first_variant[model + "|" + LightsName(k.lights)];
    Phases &phases = phases_[model];
    for (const char *path : {"device", "host", "end_to_end", "shared_memory"}) {
      if (!Selected(o_.paths, path)) continue;
      const bool service =
          std::string(path) == "end_to_end" || std::string(path) == "shared_memory";
      if (service && (k.fp64 || !(first.empty() || first == variant))) continue;
      Row row;
      row.model = model;
      row.variant = variant;
      row.lights = LightsName(k.lights);
      row.precision = PrecisionName(k.fp64);
      row.path = path;
      std::string why;
      const auto row_start = Clock::now();
      auto errors = [&] {
        const auto t0 = Clock::now();
        const double cpu0 = CpuSeconds();
        const double refs0 = reference_seconds_, refs_cpu0 = reference_cpu_;
        Errors(*k.model, *k.bench_case, k.lights, k.request, path, &row);
        const double refs = reference_seconds_ - refs0, refs_cpu = reference_cpu_ - refs_cpu0;
        phases.references += refs;
        phases.references_cpu += refs_cpu;
        phases.errors += std::chrono::duration<double>(Clock::now() - t0).count() - refs;
        phases.errors_cpu += CpuSeconds() - cpu0 - refs_cpu;
      };
      // --quick (and --tiny, so that the smoke tests run it), device and host: the errors
      // first, so that a row of the same work (ModelBenchCase::same_work) whose radiance is
      // bit-identical to an earlier variant's can report that variant's timing
      // (SharedTiming). The full run times every row itself.
      const bool share = o_.mode != "full" && !service;
      const Row *same = nullptr;
      if (share) {
        if (k.bench_case->same_work) row.work = k.bench_case->same_work(*k.variant, k.lights);
        try {
          row.kernel =
              KernelKey(*engine_, *k.model, ResolvedPlan(k.request, Tile(k.request.queries(), 1)));
        } catch (const std::exception &) {
          // Time reports it.
        }
        errors();
        same = SharedTiming(row);
      }
      if (same) {
        row.evals_per_s = same->evals_per_s;
        row.batch = same->batch;
        row.timing_shared_with = same->variant;
      } else if (!Time(path, k.request, &row, &why)) {
        skipped_.push_back(
            {row.model, row.variant, row.lights, row.precision, std::string(path) + ": " + why});
        continue;
      }
      if (!share) errors();
      char vs_device[64] = "";
      if (row.ratio_to_device)
        std::snprintf(vs_device, sizeof vs_device, ", %.2f of the device (interleaved)",
                      *row.ratio_to_device);
      const std::string shared =
          same ? "; timing shared with " + same->variant + " (bit-identical radiance)" : "";
      char spread[48] = "";
      if (std::isfinite(row.spread))
        std::snprintf(spread, sizeof spread, ", %d runs, spread %.1f%%", row.runs,
                      100 * row.spread);
      std::fprintf(stderr, "%s %s %s %s %s: %.4g evals/s (batch %u%s)%s%s; row %.2f s\n",
                   row.model.c_str(), row.variant.c_str(), row.lights.c_str(),
                   row.precision.c_str(), path, row.evals_per_s, row.batch, spread, vs_device,
                   shared.c_str(), std::chrono::duration<double>(Clock::now() - row_start).count());
      rows_.push_back(row);
      if (first.empty()) first = variant;
    }
  });
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
                 "[--error-seeds S] [--note TEXT] [--cache-dir DIR] [--compile-jobs N] "
                 "[--shm-direct-output] [--area-programs ltc-only|shared] "
                 "[--warm-up-only]\n");
    return 2;
  };
  int repeat = 0, error_seeds = 0;
  double min_time = -1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    const int first_arg = i;
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
    } else if (has_value && a == "--compile-jobs") {
      o.compile_jobs = std::max(1, std::atoi(argv[++i]));
      shown.clear();  // changes the wall time only
    } else if (has_value && a == "--compile-worker") {
      o.compile_worker = argv[++i];
      shown.clear();
    } else if (has_value && a == "--area-programs" &&
               (std::string(argv[i + 1]) == "ltc-only" || std::string(argv[i + 1]) == "shared")) {
      o.area_programs = argv[++i];
      shown += " " + o.area_programs;
    } else if (a == "--warm-up-only") {
      o.warm_up_only = true;
    } else {
      return usage();
    }
    if (!shown.empty()) o.command += " " + shown;
    // What selects the variants (and so the kernels), forwarded to the compile children.
    if (a == "--quick" || a == "--tiny" || a == "--models" || a == "--lights" ||
        a == "--precisions" || a == "--paths" || a == "--area-programs")
      for (int k = first_arg; k <= i; ++k) o.selection_args.push_back(argv[k]);
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
    // Runs of >= 20 ms (30 ms until session 13): the growth and the three repeats are most of a
    // --quick row's time (issue 13: under 3 minutes, cold), and the median of three absorbs one
    // preempted run; rows that want tighter numbers are the full run's (0.2 s, median of 5) or
    // the interleaved benchmarks'.
    o.base_queries = 16384, o.area_ref_queries = 64, o.min_time = 0.02, o.repeat = 3;
  } else if (o.mode == "tiny") {
    o.base_queries = 64, o.area_ref_queries = 8, o.max_batch = 64, o.min_time = 0, o.repeat = 1;
    o.area_truth_tiny = true;
    o.error_seeds = 2;
  }
  if (repeat) o.repeat = repeat;
  if (error_seeds) o.error_seeds = error_seeds;
  if (min_time >= 0) o.min_time = min_time;

  if (o.area_programs.empty()) o.area_programs = o.mode == "full" ? "shared" : "ltc-only";
  std::unique_ptr<DeviceEngine> engine;
  Status s = CreateEngine(o.cache_dir, &engine, o.area_programs == "ltc-only");
  if (!s.ok()) {
    std::fprintf(stderr, "bench_models: %s\n", s.message().c_str());
    return 1;
  }
  if (!o.compile_worker.empty()) {
    // A compile child ends with the run that started it (killed or not).
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() == 1) return 1;
    return Driver(o, engine.get()).CompileWorker(o.compile_worker) ? 0 : 1;
  }
  const std::string load_start = LoadAverage(), started = UtcNow();
  const auto t0 = Clock::now();
  const double cpu0 = CpuSeconds(), children_cpu0 = CpuSeconds(RUSAGE_CHILDREN);
  Driver driver(o, engine.get());
  driver.WarmUp();
  if (o.warm_up_only) {
    std::fprintf(stderr,
                 "warm-up: %.1f s, %d variants in %d processes, CPU %.1f s here + %.1f s "
                 "in the compile processes\n",
                 driver.warm_up_seconds(), driver.warm_up_variants(), driver.warm_up_processes(),
                 driver.warm_up_cpu(), driver.warm_up_children_cpu());
    return 0;
  }
  driver.Run();
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  // This process and its compile children (process start and the engine's creation excluded,
  // like the wall time).
  const double cpu = CpuSeconds() - cpu0 + CpuSeconds(RUSAGE_CHILDREN) - children_cpu0;
  const std::string load_end = LoadAverage();
  // Where the time went (issue 13: --quick from a cold cache in under 3 minutes).
  nlohmann::ordered_json breakdown = {
      {"kernel_warm_up_s", Num(driver.warm_up_seconds())},
      {"kernel_warm_up_variants", driver.warm_up_variants()},
      {"kernel_warm_up_processes", driver.warm_up_processes()},
      {"kernel_warm_up_child_failures", driver.warm_up_child_failures()},
      {"kernel_warm_up_cpu_s", Num(driver.warm_up_cpu())},
      {"kernel_warm_up_children_cpu_s", Num(driver.warm_up_children_cpu())},
      {"cpu_s", Num(cpu)}};
  std::fprintf(stderr,
               "\ntime: %.1f s wall, %.1f s CPU; kernel warm-up %.1f s wall (%d variants, %d "
               "processes), %.1f s CPU in this process + %.1f s in the compile processes\n",
               wall, cpu, driver.warm_up_seconds(), driver.warm_up_variants(),
               driver.warm_up_processes(), driver.warm_up_cpu(), driver.warm_up_children_cpu());
  for (const auto &[model, p] : driver.phases()) {
    std::fprintf(stderr,
                 "  %-10s first runs %5.1f/%5.1f s, timing %5.1f/%5.1f s (%5.1f s in the clock), "
                 "errors %5.1f/%5.1f s, references %5.1f/%5.1f s (wall/CPU)\n",
                 model.c_str(), p.first_run, p.first_run_cpu, p.timed, p.timed_cpu, p.clocked,
                 p.errors, p.errors_cpu, p.references, p.references_cpu);
    breakdown["per_model_s"][model] = {
        {"first_runs", Num(p.first_run)},         {"timing", Num(p.timed)},
        {"timing_clocked", Num(p.clocked)},       {"errors", Num(p.errors)},
        {"references", Num(p.references)},        {"first_runs_cpu", Num(p.first_run_cpu)},
        {"timing_cpu", Num(p.timed_cpu)},         {"errors_cpu", Num(p.errors_cpu)},
        {"references_cpu", Num(p.references_cpu)}};
  }

  std::printf(
      "bench_models (%s): device %s, %u cores, load average %s at start, %s at end, "
      "%.0f s\n\n",
      o.mode.c_str(), engine->info().name.c_str(), std::thread::hardware_concurrency(),
      load_start.c_str(), load_end.c_str(), wall);
  std::printf(
      "| model | variant | lights | precision | path | evals/s | ratio to smooth | "
      "error mean | p95 | max |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row &r : driver.rows())
    std::printf("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", r.model.c_str(),
                r.variant.c_str(), r.lights.c_str(), r.precision.c_str(), r.path.c_str(),
                (Fmt(r.evals_per_s, "%.4g") +
                 (r.timing_shared_with.empty()
                      ? ""
                      : " (timing of " + r.timing_shared_with + ": bit-identical radiance)"))
                    .c_str(),
                Fmt(r.ratio_to_smooth, "%.3g").c_str(),
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
        {"time_breakdown", breakdown},
    };
    j["settings"] = {{"mode", o.mode},
                     {"base_queries", o.base_queries},
                     {"area_reference_queries", o.area_ref_queries},
                     {"max_batch", o.max_batch},
                     {"min_time_s", o.min_time},
                     {"repeat", o.repeat},
                     {"error_seeds", o.error_seeds},
                     {"area_programs", o.area_programs}};
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
                      {"ratio_to_device", Num(r.ratio_to_device)},
                      {"timing_shared_with", r.timing_shared_with.empty()
                                                 ? nlohmann::ordered_json(nullptr)
                                                 : nlohmann::ordered_json(r.timing_shared_with)}});
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
