// Test support: one OpenCL DeviceEngine per test suite, on the suite's kernel cache.
//
// The engine reads GLINT_CACHE_DIR (scripts/test.sh points it at the build's private cache,
// shared by every test process of the suite): a kernel variant that another test process has
// already built is loaded from disk instead of compiled again, which is most of the suite's
// time on PoCL (seconds to tens of seconds per variant, one build at a time per process).
// Without the variable the engine keeps programs in memory only (and PoCL its kernels in its
// default cache, ~/.cache/pocl). A test that must see a build from source (EngineTest) asks for it
// (CreateEngine's from_source).
//
// Suites derive from DeviceEngineTest and use the static `engine_`. Workers default to 1 (one
// command queue); a suite that needs concurrent Evaluate calls, or source builds, defines its own
// SetUpTestSuite() { CreateEngine(2); }.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "server/device_engine.h"

namespace glint::test {

class DeviceEngineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { CreateEngine(1); }
  // Prints how the suite's programs were obtained, to see where a cold run's time goes: with a
  // cold cache "compiled" are the variants this process was the first to need (with a warm one
  // everything loads from disk); from_source counts every program as compiled, and PoCL's cache
  // decides what the build costs.
  static void TearDownTestSuite() {
    if (engine_) {
      std::printf("kernel programs: %d compiled, %d loaded from the disk cache, %d memory hits\n",
                  engine_->runtime().programs_compiled(),
                  engine_->runtime().programs_loaded_from_disk(),
                  engine_->runtime().programs_memory_hits());
    }
    engine_.reset();
  }

  // from_source: no program binary cache, so every process builds its programs from source
  // (clBuildProgram on the source text: EngineTest wants to see real build results). PoCL's own
  // kernel cache still applies, as it always did (PoCL keys a source build by the source and
  // options and skips the compile on a hit; measured: a test building two programs, 2.4 s of CPU
  // cold, 0.13 s with PoCL's cache warm): it is pointed at the suite's cache directory
  // (GLINT_CACHE_DIR/pocl, where ClRuntime puts it for the other tests) instead of
  // ~/.cache/pocl, so a variant another test process built is not compiled again and the run
  // does not depend on a cache outside the build tree.
  static void CreateEngine(int workers, bool from_source = false) {
    DeviceEngineOptions o;
    const char *cache = std::getenv("GLINT_CACHE_DIR");
    o.cache_dir = cache && !from_source ? cache : "";
    if (cache && from_source && std::getenv("POCL_CACHE_DIR") == nullptr) {
      const std::string pocl = std::string(cache) + "/pocl";
      std::filesystem::create_directories(pocl);
      setenv("POCL_CACHE_DIR", pocl.c_str(), 0);
    }
    o.workers = workers;
    Status s = DeviceEngine::Create(o, &engine_);
    ASSERT_TRUE(s.ok()) << s.message();
  }

  static inline std::unique_ptr<DeviceEngine> engine_;
};

}  // namespace glint::test
