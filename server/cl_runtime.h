// OpenCL runtime: device choice, context, and a program cache (memory, then
// the disk, then compiling). One ClRuntime per process; thread-safe.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "server/cl_handle.h"
#include "server/status.h"

namespace glint {

struct DeviceInfo {
  std::string name, vendor, opencl_version, driver_version, platform_name;
  uint32_t compute_units = 0;
  bool fp64 = false;
};

// Every OpenCL device visible through the ICD loader, in (platform, device)
// order; the index is what `glintd --device N` selects.
std::vector<DeviceInfo> ListDevices();

// How compiled programs outlive the process (with a cache directory).
enum class ProgramStore {
  // kPlatformCache on PoCL with its kernel cache on (POCL_KERNEL_CACHE not 0), else kBinaries.
  kAuto,
  // Program binaries in `cache_dir` (<hash>.clbin): clGetProgramInfo(CL_PROGRAM_BINARIES) after a
  // compile, clCreateProgramWithBinary at the next process's first use. For drivers without a
  // cache of their own.
  kBinaries,
  // The platform's own compiled-kernel cache (PoCL's, keyed by source, options and device; in
  // `cache_dir`/pocl unless POCL_CACHE_DIR says otherwise): a program is built from source every
  // time and the platform finds its earlier compile. No binaries are asked for: on PoCL 3.1
  // CL_PROGRAM_BINARIES compiles one more (generic) work-group function of every kernel of the
  // program for the binary, as long as the first build again, and the specialised one compiled at
  // the first enqueue is what runs anyway (bench/bench_program_cache.cpp measures both).
  kPlatformCache,
};

class ClRuntime {
 public:
  // `device_selector`: "" picks PoCL's CPU device if present, else the first
  // device; a number picks that index of ListDevices(); anything else picks
  // the first device whose device or platform name contains it.
  // `cache_dir`: the disk cache ("" disables it: every process compiles its programs, though
  // PoCL still keeps its own cache in its default place). `store`: how programs are kept there.
  static Status Create(const std::string &device_selector, const std::string &cache_dir,
                       std::unique_ptr<ClRuntime> *out, ProgramStore store = ProgramStore::kAuto);
  ~ClRuntime();
  ClRuntime(const ClRuntime &) = delete;
  ClRuntime &operator=(const ClRuntime &) = delete;

  const DeviceInfo &info() const { return info_; }
  cl_context context() const { return context_.get(); }
  cl_device_id device() const { return device_; }

  // The built program for (source, options): from memory, else from the disk
  // cache, else compiled. A build failure returns Internal with the build log.
  // The runtime keeps ownership of the program. Callers asking for the same
  // program while it builds wait for that build; callers of different programs
  // do not wait for each other here, but PoCL 3.1 itself compiles one program
  // at a time per process (bench/bench_models.cpp, Driver::WarmUp).
  Status GetProgram(const std::string &source, const std::string &options, cl_program *out);

  // Counters for capabilities/logs: programs compiled from source and loaded from disk. With
  // kPlatformCache a program counts as loaded when this cache directory saw it built before
  // (a stamp file next to the platform's cache, so deleting that cache resets it).
  int programs_compiled() const;
  int programs_loaded_from_disk() const;
  // kBinaries or kPlatformCache (never kAuto); with no cache directory, what it would be.
  ProgramStore program_store() const { return store_; }
  // kPlatformCache: the directory of PoCL's cache this process uses ("" otherwise).
  const std::string &platform_cache_dir() const { return platform_cache_dir_; }
  // Lookups answered from the in-memory cache (for /metrics).
  int programs_memory_hits() const;

 private:
  ClRuntime() = default;
  Status BuildFromSource(const std::string &source, const std::string &options, ClProgram *out);
  bool LoadBinary(const std::string &path, const std::string &options, ClProgram *out);
  void SaveBinary(const std::string &path, cl_program program);
  // kPlatformCache: the stamp saying this program was built with the platform's cache before.
  std::string StampPath(const std::string &name) const;

  DeviceInfo info_;
  cl_platform_id platform_ = nullptr;
  cl_device_id device_ = nullptr;
  ClContext context_;
  std::string cache_dir_;
  ProgramStore store_ = ProgramStore::kBinaries;
  std::string platform_cache_dir_;
  std::string build_environment_;  // platform/device versions, PoCL settings: part of every key

  // One slot per program, its own lock held while it is built, so that only
  // callers of the same program wait for a build.
  struct ProgramSlot {
    std::mutex build;
    ClProgram program;  // empty until built (a failed build leaves it empty: retried next time)
  };
  mutable std::mutex mutex_;                                      // the map and the counters
  std::map<std::string, std::shared_ptr<ProgramSlot>> programs_;  // key: options + '\n' + source
  int compiled_ = 0, loaded_ = 0, memory_hits_ = 0;
};

// "CL_INVALID_VALUE" style names for error messages.
std::string ClErrorName(cl_int err);

// Returns Internal naming the call and the error from the enclosing function.
#define GLINT_CL_CHECK(call)                                                            \
  do {                                                                                  \
    cl_int glint_err_ = (call);                                                         \
    if (glint_err_ != CL_SUCCESS)                                                       \
      return ::glint::Status::Internal(std::string(#call) +                             \
                                       " failed: " + ::glint::ClErrorName(glint_err_)); \
  } while (0)

}  // namespace glint
