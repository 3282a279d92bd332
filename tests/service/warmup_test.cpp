// Kernel warm-up before SERVING (server/warmup.h, issue 13 "first-request latency"): after
// WarmKernels the first request of a warmed variant builds and loads no program (the runtime's
// program-cache counters, which /metrics exports as glint_program_cache_lookups_total), while a
// variant outside the warm set does (so the counters do see requests); the --warm modes list the
// variants they promise; concurrent builds of the program cache build each program once; glintd
// refuses a bad --warm value.
#include "server/warmup.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/launch_grid.h"
#include "server/model_table.h"
#include "server/query_view.h"
#include "server/validation.h"
#include "test_queries.h"

namespace glint {
namespace {

using glint::v1::EvaluateRequest;

// The test's kernel cache: the suite's shared one when set (fast), else a fresh directory.
std::string CacheDir() {
  if (const char *d = std::getenv("GLINT_CACHE_DIR")) return d;
  return ::testing::TempDir() + "glint_warmup_cache_" + std::to_string(::getpid());
}

// A SMOOTH request written here, not through the warm-up's own example requests: GGX, the given
// Fresnel kind, `n` random queries (probes, or a directional + point light on framed queries, or
// one polygon light).
enum class Shape { kProbe, kLitFramed, kPolygon };
EvaluateRequest SmoothRequest(Shape shape, v1::Ndf ndf, bool dielectric, uint32_t n) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::SMOOTH);
  m->set_ndf(ndf);
  m->set_alpha_x(0.25f);
  m->set_alpha_y(0.4f);
  if (dielectric) {
    m->mutable_dielectric()->set_ior(1.5f);
  } else {
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  }
  *r.mutable_queries() =
      test::RandomQueries(n, shape == Shape::kProbe, shape == Shape::kLitFramed, 11);
  auto add3 = [](auto *field, float x, float y, float z) {
    field->Add(x);
    field->Add(y);
    field->Add(z);
  };
  if (shape == Shape::kLitFramed) {
    auto *d = r.add_lights()->mutable_directional();
    add3(d->mutable_direction(), 0.0f, 0.6f, 0.8f);
    add3(d->mutable_irradiance(), 2, 2, 2);
    auto *p = r.add_lights()->mutable_point();
    add3(p->mutable_position(), -1, 0.5f, 3);
    add3(p->mutable_intensity(), 5, 5, 5);
  } else if (shape == Shape::kPolygon) {
    auto *p = r.add_lights()->mutable_polygon();
    for (float v : {-1.0f, -1.0f, 3.0f, 1.0f, -1.0f, 3.0f, 1.0f, 1.0f, 3.0f, -1.0f, 1.0f, 3.0f})
      p->add_vertices(v);
    add3(p->mutable_radiance(), 1, 1, 1);
  }
  r.set_precision(v1::FP32);
  return r;
}

TEST(WarmUp, FirstRequestOfAWarmedVariantBuildsNothing) {
  DeviceEngineOptions o;
  o.cache_dir = CacheDir();
  o.workers = 2;
  std::unique_ptr<DeviceEngine> engine;
  ASSERT_TRUE(DeviceEngine::Create(o, &engine).ok());
  const std::vector<KernelSpec> specs = WarmSpecsFor(WarmMode::kCommon, engine->info().fp64);
  Status s = WarmKernels(engine.get(), specs, 2);
  ASSERT_TRUE(s.ok()) << s.message();
  ClRuntime &rt = engine->runtime();
  const int built = rt.programs_compiled() + rt.programs_loaded_from_disk();
  EXPECT_GE(built, int(specs.size())) << "every warmed variant needs at least one program";

  // The smooth model's declared variants (models/smooth/smooth_model.cpp): probes and lit framed
  // queries for GGX and Beckmann, polygon lights; on both queues.
  for (Shape shape : {Shape::kProbe, Shape::kLitFramed, Shape::kPolygon})
    for (v1::Ndf ndf : {v1::GGX, v1::BECKMANN}) {
      if (shape == Shape::kPolygon && ndf == v1::BECKMANN) continue;  // not declared
      const EvaluateRequest r = SmoothRequest(shape, ndf, false, 100);
      const Status valid = ValidateSettings(r, {});
      ASSERT_TRUE(valid.ok()) << valid.message();
      const EvalPlan plan = MakeEvalPlan(r, r.queries());
      ASSERT_NE(std::find(specs.begin(), specs.end(), plan.spec), specs.end())
          << plan.spec.Describe() << " is not in the warm set";
      std::vector<float> out(3 * 100);
      for (int w = 0; w < engine->workers(); ++w) {
        ASSERT_TRUE(engine->Evaluate(w, plan, r.queries(), out.data()).ok());
        EXPECT_EQ(rt.programs_compiled() + rt.programs_loaded_from_disk(), built)
            << plan.spec.Describe() << " on queue " << w << " built a program after warm-up";
      }
    }

  // A variant outside the warm set (a dielectric) does build one: the counters see requests.
  const EvaluateRequest cold = SmoothRequest(Shape::kProbe, v1::GGX, true, 100);
  const EvalPlan plan = MakeEvalPlan(cold, cold.queries());
  ASSERT_EQ(std::find(specs.begin(), specs.end(), plan.spec), specs.end());
  std::vector<float> out(3 * 100);
  ASSERT_TRUE(engine->Evaluate(0, plan, cold.queries(), out.data()).ok());
  EXPECT_EQ(rt.programs_compiled() + rt.programs_loaded_from_disk(), built + 1);
}

TEST(WarmUp, ModesListTheDeclaredVariants) {
  EXPECT_TRUE(WarmSpecsFor(WarmMode::kNone, true).empty());
  const std::vector<KernelSpec> common = WarmSpecsFor(WarmMode::kCommon, true);
  const std::vector<KernelSpec> all = WarmSpecsFor(WarmMode::kAll, true);
  const std::vector<KernelSpec> all32 = WarmSpecsFor(WarmMode::kAll, false);
  size_t declared = 0;
  for (const Model *model : Models()) {
    if (!model->warm_specs) continue;
    for (KernelSpec spec : model->warm_specs()) {
      ++declared;
      spec.model = model->id;
      EXPECT_NE(std::find(common.begin(), common.end(), spec), common.end()) << spec.Describe();
      for (int fresnel = 1; fresnel <= 3; ++fresnel)
        for (bool fp64 : {false, true}) {
          KernelSpec v = spec;
          v.fresnel = fresnel;
          v.fp64 = fp64;
          EXPECT_NE(std::find(all.begin(), all.end(), v), all.end()) << v.Describe();
          EXPECT_EQ(std::find(all32.begin(), all32.end(), v) != all32.end(), !fp64)
              << v.Describe() << ": fp64 variants only where the device has fp64";
        }
    }
  }
  EXPECT_GT(declared, 0u);
  EXPECT_LE(common.size(), declared);  // duplicates removed
  for (size_t i = 0; i < all.size(); ++i)
    for (size_t j = i + 1; j < all.size(); ++j)
      EXPECT_FALSE(all[i] == all[j]) << "duplicate " << all[i].Describe();
  WarmMode m;
  EXPECT_TRUE(ParseWarmMode("all", &m) && m == WarmMode::kAll);
  EXPECT_FALSE(ParseWarmMode("everything", &m));
}

// Builds of one program from several threads compile it once; different programs build side by
// side (each slot has its own lock, server/cl_runtime.cpp) and all come out usable.
TEST(WarmUp, ConcurrentProgramBuildsCompileEachProgramOnce) {
  std::unique_ptr<ClRuntime> rt;
  ASSERT_TRUE(ClRuntime::Create("", "", &rt).ok());  // memory only: every program compiles
  const std::string source =
      "__kernel void scale(__global float *x) { x[get_global_id(0)] *= (float)(K); }";
  std::vector<cl_program> got(6, nullptr);
  std::vector<Status> status(6);
  std::vector<std::thread> threads;
  for (int t = 0; t < 6; ++t)
    threads.emplace_back([&, t] {
      status[t] = rt->GetProgram(source, "-DK=" + std::to_string(t % 2 + 2), &got[t]);
    });
  for (std::thread &t : threads) t.join();
  for (int t = 0; t < 6; ++t) {
    ASSERT_TRUE(status[t].ok()) << status[t].message();
    EXPECT_EQ(got[t], got[t % 2]) << "thread " << t << " got another program for the same key";
  }
  EXPECT_NE(got[0], got[1]);
  EXPECT_EQ(rt->programs_compiled(), 2);
  EXPECT_EQ(rt->programs_memory_hits(), 4);
  // The programs work: K = 2 and K = 3 scale a buffer.
  for (int k = 0; k < 2; ++k) {
    cl_int err = CL_SUCCESS;
    ClKernel kernel(clCreateKernel(got[k], "scale", &err));
    ASSERT_EQ(err, CL_SUCCESS);
    float x[4] = {1, 2, 3, 4};
    ClBuffer buf(
        clCreateBuffer(rt->context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof x, x, &err));
    ASSERT_EQ(err, CL_SUCCESS);
    cl_mem m = buf.get();
    ASSERT_EQ(clSetKernelArg(kernel.get(), 0, sizeof m, &m), CL_SUCCESS);
    ClQueue queue(clCreateCommandQueue(rt->context(), rt->device(), 0, &err));
    ASSERT_EQ(err, CL_SUCCESS);
    const size_t global = 4;
    ASSERT_EQ(clEnqueueNDRangeKernel(queue.get(), kernel.get(), 1, nullptr, &global, nullptr, 0,
                                     nullptr, nullptr),
              CL_SUCCESS);
    ASSERT_EQ(
        clEnqueueReadBuffer(queue.get(), buf.get(), CL_TRUE, 0, sizeof x, x, 0, nullptr, nullptr),
        CL_SUCCESS);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(x[i], float((i + 1) * (k + 2)));
  }
}

// PoCL's work-group functions in its kernel cache: one directory per compiled specialisation,
// named <local size>[-goffs0][-smallgrid] under <program>/<kernel>/ (pocl_cache.c,
// pocl_cache_kernel_cachedir_path, PoCL 3.1). The set of their paths.
std::set<std::string> WorkGroupFunctions(const std::string &pocl_cache) {
  std::set<std::string> out;
  const std::regex name(R"(\d+-\d+-\d+(-goffs0)?(-smallgrid)?)");
  std::error_code ec;
  for (auto it = std::filesystem::recursive_directory_iterator(pocl_cache, ec);
       !ec && it != std::filesystem::recursive_directory_iterator(); it.increment(ec))
    if (it->is_directory() && std::regex_match(it->path().filename().string(), name))
      out.insert(it->path().lexically_relative(pocl_cache).string());
  return out;
}

// PoCL 3.1 compiles a kernel's work-group function again for a launch with a grid dimension of
// 65535 work-items or more (its "smallgrid" specialisation: pocl_cache.c, pocl_llvm_wg.cc,
// grid_width_specialization_limit = USHRT_MAX). The device engine launches 2D grids whose
// dimensions stay below that (server/launch_grid.h), so the one-query warm-up compiles the work-
// group function every request of the variant uses: a request of 65536 work-items of the smooth
// probe kernel (2 grid rows: 65408 + 128; 2^21 queries at 16 lanes x 2 blocks) compiles nothing
// more. Its result is bit-identical to the same queries evaluated in chunks of one grid row or less
// (the work-item index kernels/work_item.h computes from the 2D id).
TEST(WarmUp, LargeRequestAfterWarmUpCompilesNoWorkGroupFunction) {
  // A fresh cache, so every work-group function this test needs is compiled here and seen.
  const std::string dir =
      ::testing::TempDir() + "glint_large_grid_cache_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  DeviceEngineOptions o;
  o.cache_dir = dir;
  o.workers = 1;
  std::unique_ptr<DeviceEngine> engine;
  ASSERT_TRUE(DeviceEngine::Create(o, &engine).ok());
  const std::string pocl = engine->runtime().platform_cache_dir();
  if (pocl != dir + "/pocl") {
    engine.reset();
    std::filesystem::remove_all(dir);
    GTEST_SKIP() << "PoCL's kernel cache is not this test's fresh one (\"" << pocl
                 << "\": POCL_CACHE_DIR set, its cache off, or another OpenCL platform)";
  }

  // As many queries as 65536 work-items of the pass hold, so the launch takes two grid rows
  // (checked, so that the test keeps its purpose if the pass's width or blocks change).
  const ModelPass &pass = FindModel(v1::SMOOTH)->passes[0];
  const uint32_t kQueries = uint32_t(65536 * pass.Width(false) * pass.Blocks(false, true));
  ASSERT_GT(GridFor(65536, o.local_size).global[1], 1u);
  const EvaluateRequest r = SmoothRequest(Shape::kProbe, v1::GGX, false, kQueries);
  const EvalPlan plan = MakeEvalPlan(r, r.queries());
  ASSERT_TRUE(WarmKernels(engine.get(), {plan.spec}, 1).ok());
  const std::set<std::string> warmed = WorkGroupFunctions(pocl);
  ASSERT_FALSE(warmed.empty()) << "the warm-up compiled no work-group function into " << pocl;
  const int programs = engine->runtime().programs_compiled();

  std::vector<float> whole(size_t(3) * kQueries);
  ASSERT_TRUE(engine->Evaluate(0, plan, r.queries(), whole.data()).ok());
  const std::set<std::string> after = WorkGroupFunctions(pocl);
  for (const std::string &f : after)
    EXPECT_TRUE(warmed.count(f)) << "the two-row request compiled work-group function " << f;
  EXPECT_EQ(engine->runtime().programs_compiled(), programs);

  // Chunks of 4096 queries: at most 256 work-items, one grid row.
  const QueryView all = QueryView::Of(r.queries());
  std::vector<float> chunk(size_t(3) * 4096);
  for (uint32_t begin = 0; begin < kQueries; begin += 4096) {
    ASSERT_TRUE(engine->Evaluate(0, plan, all.Slice(begin, 4096), chunk.data()).ok());
    ASSERT_EQ(std::memcmp(chunk.data(), whole.data() + size_t(3) * begin, sizeof(float) * 3 * 4096),
              0)
        << "queries " << begin << "..+4096 differ from the same queries in one launch";
  }
  engine.reset();
  std::filesystem::remove_all(dir);
}

// A variant whose warm-up fails stops glintd with a message naming the variant and, when glintd
// says who needs it (the --model presets, KServeServiceImpl::PresetsUsing), those too: a preset's
// failure used to name only the variant, not which --model file asked for it. The failing
// variant here is a model id no model has (Warm refuses it before any build); the variant before
// it warms normally and names nobody.
TEST(WarmUp, AFailureNamesWhoNeedsTheVariant) {
  DeviceEngineOptions o;
  o.cache_dir = CacheDir();
  o.workers = 1;
  std::unique_ptr<DeviceEngine> engine;
  ASSERT_TRUE(DeviceEngine::Create(o, &engine).ok());
  const EvaluateRequest good = SmoothRequest(Shape::kProbe, v1::GGX, false, 1);
  KernelSpec bad = MakeEvalPlan(good, good.queries()).spec;
  bad.model = 999;
  const std::vector<KernelSpec> specs = {MakeEvalPlan(good, good.queries()).spec, bad};
  const std::string who = "--model preset 'paint' (dir/paint.json,dir/studio.json)";
  const std::vector<std::string> users = {"", who};
  const Status named = WarmKernels(engine.get(), specs, 1, nullptr, &users);
  ASSERT_FALSE(named.ok());
  EXPECT_EQ(named.message().rfind("warm-up of " + bad.Describe() + " (for " + who + "): ", 0), 0u)
      << named.message();
  EXPECT_NE(named.message().find("no model with id 999"), std::string::npos) << named.message();
  // Without users (or an empty entry) the message is the variant's alone, as before.
  const std::vector<std::string> nobody = {""};
  for (const std::vector<std::string> *none :
       {&nobody, (const std::vector<std::string> *)nullptr}) {
    const Status s = WarmKernels(engine.get(), {bad}, 1, nullptr, none);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.message().rfind("warm-up of " + bad.Describe() + ": ", 0), 0u) << s.message();
  }
}

// glintd refuses a --warm value it does not know, naming the flag and the choices.
TEST(WarmUp, GlintdRefusesAnUnknownWarmMode) {
  const std::string err = ::testing::TempDir() + "glint_warm_flag_" + std::to_string(::getpid());
  const std::string cmd =
      std::string("\"") + GLINTD_PATH + "\" --warm sometimes --listen 127.0.0.1:0 2> " + err;
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 2);
  std::stringstream text;
  text << std::ifstream(err).rdbuf();
  EXPECT_NE(text.str().find("--warm sometimes: expected none, common or all"), std::string::npos)
      << text.str();
  std::filesystem::remove(err);
}

}  // namespace
}  // namespace glint
