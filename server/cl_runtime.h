// OpenCL runtime: device choice, context, and a program cache (memory, then
// disk binaries, then compiling). One ClRuntime per process; thread-safe.
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

class ClRuntime {
 public:
  // `device_selector`: "" picks PoCL's CPU device if present, else the first
  // device; a number picks that index of ListDevices(); anything else picks
  // the first device whose device or platform name contains it.
  // `cache_dir`: where program binaries are kept ("" disables the disk cache).
  static Status Create(const std::string &device_selector, const std::string &cache_dir,
                       std::unique_ptr<ClRuntime> *out);
  ~ClRuntime();
  ClRuntime(const ClRuntime &) = delete;
  ClRuntime &operator=(const ClRuntime &) = delete;

  const DeviceInfo &info() const { return info_; }
  cl_context context() const { return context_.get(); }
  cl_device_id device() const { return device_; }

  // The built program for (source, options): from memory, else from a disk
  // binary, else compiled. A build failure returns Internal with the build log.
  // The runtime keeps ownership of the program. Different programs build
  // concurrently (parallel warm-up, server/warmup.h); callers asking for the
  // same one while it builds wait for that build.
  Status GetProgram(const std::string &source, const std::string &options, cl_program *out);

  // Counters for capabilities/logs: programs compiled from source and loaded from disk.
  int programs_compiled() const;
  int programs_loaded_from_disk() const;
  // Lookups answered from the in-memory cache (for /metrics).
  int programs_memory_hits() const;

 private:
  ClRuntime() = default;
  Status BuildFromSource(const std::string &source, const std::string &options, ClProgram *out);
  bool LoadBinary(const std::string &path, const std::string &options, ClProgram *out);
  void SaveBinary(const std::string &path, cl_program program);

  DeviceInfo info_;
  cl_platform_id platform_ = nullptr;
  cl_device_id device_ = nullptr;
  ClContext context_;
  std::string cache_dir_;

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
