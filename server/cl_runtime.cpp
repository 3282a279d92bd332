#include "server/cl_runtime.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "server/pocl_affinity.h"

namespace glint {
namespace {

std::string DeviceString(cl_device_id d, cl_device_info what) {
  size_t size = 0;
  if (clGetDeviceInfo(d, what, 0, nullptr, &size) != CL_SUCCESS || size == 0) return "";
  std::string s(size, '\0');
  clGetDeviceInfo(d, what, size, s.data(), nullptr);
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

std::string PlatformString(cl_platform_id p, cl_platform_info what) {
  size_t size = 0;
  if (clGetPlatformInfo(p, what, 0, nullptr, &size) != CL_SUCCESS || size == 0) return "";
  std::string s(size, '\0');
  clGetPlatformInfo(p, what, size, s.data(), nullptr);
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

struct DeviceHandle {
  cl_platform_id platform;
  cl_device_id device;
  DeviceInfo info;
};

// POCL_CACHE_DIR as PoCL reads it: once, at its initialisation inside this process's first
// clGetPlatformIDs (every OpenCL call of glint comes after one here). "" when unset.
std::string &PoclCacheDirAtInit() {
  static std::string dir;
  return dir;
}

std::vector<DeviceHandle> EnumerateDevices() {
  static std::once_flag first;
  std::call_once(first, [] {
    DefaultPoclAffinity();
    const char *dir = std::getenv("POCL_CACHE_DIR");
    PoclCacheDirAtInit() = dir ? dir : "";
  });
  std::vector<DeviceHandle> out;
  cl_uint np = 0;
  if (clGetPlatformIDs(0, nullptr, &np) != CL_SUCCESS || np == 0) return out;
  std::vector<cl_platform_id> platforms(np);
  clGetPlatformIDs(np, platforms.data(), nullptr);
  for (cl_platform_id p : platforms) {
    cl_uint nd = 0;
    if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &nd) != CL_SUCCESS || nd == 0) continue;
    std::vector<cl_device_id> devices(nd);
    clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, nd, devices.data(), nullptr);
    for (cl_device_id d : devices) {
      DeviceHandle h{p, d, {}};
      h.info.name = DeviceString(d, CL_DEVICE_NAME);
      h.info.vendor = DeviceString(d, CL_DEVICE_VENDOR);
      h.info.opencl_version = DeviceString(d, CL_DEVICE_VERSION);
      h.info.driver_version = DeviceString(d, CL_DRIVER_VERSION);
      h.info.platform_name = PlatformString(p, CL_PLATFORM_NAME);
      cl_uint cu = 0;
      clGetDeviceInfo(d, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof(cu), &cu, nullptr);
      h.info.compute_units = cu;
      cl_device_fp_config fp64 = 0;
      clGetDeviceInfo(d, CL_DEVICE_DOUBLE_FP_CONFIG, sizeof(fp64), &fp64, nullptr);
      h.info.fp64 = fp64 != 0;
      out.push_back(h);
    }
  }
  return out;
}

// FNV-1a, 64 bit: a stable file name for a cache entry (std::hash is not
// guaranteed stable across builds).
uint64_t Fnv1a(const std::string &s) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

std::string BuildLog(cl_program program, cl_device_id device) {
  size_t size = 0;
  clGetProgramBuildInfo(program, device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &size);
  std::string log(size, '\0');
  if (size) clGetProgramBuildInfo(program, device, CL_PROGRAM_BUILD_LOG, size, log.data(), nullptr);
  while (!log.empty() && (log.back() == '\0' || log.back() == '\n')) log.pop_back();
  return log;
}

bool IsPocl(const DeviceInfo &info) {
  return info.platform_name.find("Portable Computing Language") != std::string::npos;
}

// PoCL's kernel cache directory in this process (pocl_cache.c, pocl_cache_init_topdir):
// POCL_CACHE_DIR, else $XDG_CACHE_HOME/pocl/kcache, else $HOME/.cache/pocl/kcache; "" when its
// cache is off or there is no such place. PoCL 3.1 keeps its cache on only when
// POCL_KERNEL_CACHE is unset or starts with '1' (pocl_get_bool_option): "off", "no", "" or
// "true" turn it off too, and then glint must store binaries itself.
std::string PoclCacheDir() {
  const char *use = std::getenv("POCL_KERNEL_CACHE");
  if (use && use[0] != '1') return "";
  if (!PoclCacheDirAtInit().empty()) return PoclCacheDirAtInit();
  const char *xdg = std::getenv("XDG_CACHE_HOME");
  if (xdg && *xdg) return std::string(xdg) + "/pocl/kcache";
  const char *home = std::getenv("HOME");
  if (home && *home) return std::string(home) + "/.cache/pocl/kcache";
  return "";
}

}  // namespace

std::string ClErrorName(cl_int err) {
  switch (err) {
#define GLINT_CASE(x) \
  case x:             \
    return #x;
    GLINT_CASE(CL_DEVICE_NOT_FOUND)
    GLINT_CASE(CL_OUT_OF_RESOURCES)
    GLINT_CASE(CL_OUT_OF_HOST_MEMORY)
    GLINT_CASE(CL_MEM_OBJECT_ALLOCATION_FAILURE)
    GLINT_CASE(CL_BUILD_PROGRAM_FAILURE)
    GLINT_CASE(CL_INVALID_VALUE)
    GLINT_CASE(CL_INVALID_DEVICE)
    GLINT_CASE(CL_INVALID_BINARY)
    GLINT_CASE(CL_INVALID_BUILD_OPTIONS)
    GLINT_CASE(CL_INVALID_PROGRAM_EXECUTABLE)
    GLINT_CASE(CL_INVALID_KERNEL_NAME)
    GLINT_CASE(CL_INVALID_KERNEL_ARGS)
    GLINT_CASE(CL_INVALID_ARG_SIZE)
    GLINT_CASE(CL_INVALID_ARG_VALUE)
    GLINT_CASE(CL_INVALID_WORK_GROUP_SIZE)
    GLINT_CASE(CL_INVALID_BUFFER_SIZE)
    GLINT_CASE(CL_INVALID_MEM_OBJECT)
    GLINT_CASE(CL_INVALID_HOST_PTR)
#undef GLINT_CASE
    default:
      return "OpenCL error " + std::to_string(err);
  }
}

std::vector<DeviceInfo> ListDevices() {
  std::vector<DeviceInfo> out;
  for (auto &h : EnumerateDevices()) out.push_back(h.info);
  return out;
}

Status ClRuntime::Create(const std::string &selector, const std::string &cache_dir,
                         std::unique_ptr<ClRuntime> *out, ProgramStore store) {
  // PoCL keeps its own compiled-kernel cache; point it at ours unless the
  // user chose one, so one --cache-dir holds everything.
  if (!cache_dir.empty() && std::getenv("POCL_CACHE_DIR") == nullptr) {
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(cache_dir) / "pocl", ec);
    if (!ec) setenv("POCL_CACHE_DIR", (std::filesystem::path(cache_dir) / "pocl").c_str(), 0);
  }
  auto devices = EnumerateDevices();
  if (devices.empty()) {
    return Status::FailedPrecondition(
        "no OpenCL device found (is an ICD such as pocl-opencl-icd installed?)");
  }
  const DeviceHandle *chosen = nullptr;
  if (selector.empty()) {
    for (auto &d : devices)
      if (d.info.platform_name.find("Portable Computing Language") != std::string::npos) {
        chosen = &d;
        break;
      }
    if (!chosen) chosen = &devices[0];
  } else if (selector.find_first_not_of("0123456789") == std::string::npos) {
    size_t index = std::stoul(selector);
    if (index >= devices.size()) {
      return Status::InvalidArgument("--device " + selector + ": only " +
                                     std::to_string(devices.size()) + " OpenCL devices");
    }
    chosen = &devices[index];
  } else {
    for (auto &d : devices)
      if (d.info.name.find(selector) != std::string::npos ||
          d.info.platform_name.find(selector) != std::string::npos) {
        chosen = &d;
        break;
      }
    if (!chosen) return Status::InvalidArgument("--device " + selector + ": no device matches");
  }

  std::unique_ptr<ClRuntime> rt(new ClRuntime());
  rt->platform_ = chosen->platform;
  rt->device_ = chosen->device;
  rt->info_ = chosen->info;
  rt->cache_dir_ = cache_dir;
  cl_int err = CL_SUCCESS;
  cl_context_properties props[] = {CL_CONTEXT_PLATFORM,
                                   reinterpret_cast<cl_context_properties>(rt->platform_), 0};
  rt->context_.reset(clCreateContext(props, 1, &rt->device_, nullptr, nullptr, &err));
  if (err != CL_SUCCESS) return Status::Internal("clCreateContext failed: " + ClErrorName(err));
  if (!cache_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(cache_dir, ec);
    if (ec) rt->cache_dir_.clear();  // no disk cache, still serve
  }
  // PoCL: its own cache (which it keeps in any case) instead of program binaries, unless the
  // caller asks for binaries or PoCL's cache is off.
  rt->store_ = ProgramStore::kBinaries;
  if (store != ProgramStore::kBinaries && IsPocl(rt->info_)) {
    rt->platform_cache_dir_ = PoclCacheDir();
    if (!rt->platform_cache_dir_.empty()) rt->store_ = ProgramStore::kPlatformCache;
  }
  // What else decides the compiled code (and keys PoCL's own cache): the platform version (PoCL
  // names its LLVM there), the device version, and PoCL's work-group method. Without them a
  // stamp would claim "loaded" after a PoCL or LLVM upgrade while PoCL compiles again.
  const char *wg = std::getenv("POCL_WORK_GROUP_METHOD");
  rt->build_environment_ = PlatformString(rt->platform_, CL_PLATFORM_VERSION) + '\n' +
                           rt->info_.opencl_version + '\n' + (wg ? wg : "");
  *out = std::move(rt);
  return Status::Ok();
}

// Programs before the context they belong to (member order would do the same; this says so).
ClRuntime::~ClRuntime() {
  programs_.clear();
}

int ClRuntime::programs_compiled() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return compiled_;
}

int ClRuntime::programs_loaded_from_disk() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return loaded_;
}

int ClRuntime::programs_memory_hits() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return memory_hits_;
}

Status ClRuntime::GetProgram(const std::string &source, const std::string &options,
                             cl_program *out) {
  const std::string key = options + '\n' + source;
  std::shared_ptr<ProgramSlot> slot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::shared_ptr<ProgramSlot> &s = programs_[key];
    if (!s) s = std::make_shared<ProgramSlot>();
    slot = s;
  }
  // Two requests needing the same new kernel compile it once (the second waits here). Builds of
  // different programs do not wait for each other here, though PoCL 3.1 serialises them inside
  // its compiler (one at a time per process).
  std::lock_guard<std::mutex> build(slot->build);
  if (slot->program) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++memory_hits_;
    *out = slot->program.get();
    return Status::Ok();
  }
  std::string name;
  if (!cache_dir_.empty()) {
    std::ostringstream hash;
    hash << std::hex
         << Fnv1a(key + '\n' + info_.platform_name + '\n' + info_.name + '\n' +
                  info_.driver_version + '\n' + build_environment_);
    name = hash.str();
  }
  ClProgram program;
  if (store_ == ProgramStore::kPlatformCache) {
    // Built from source every time; PoCL finds its earlier compile of the same source, options
    // and device in its cache (and the work-group functions compiled at first enqueue).
    const std::string stamp = name.empty() ? "" : StampPath(name);
    std::error_code ec;
    // PoCL fails a build when its cache directory has gone (someone cleared the cache while
    // this process runs): make it again.
    std::filesystem::create_directories(platform_cache_dir_, ec);
    const bool seen = !stamp.empty() && std::filesystem::exists(stamp, ec);
    Status s = BuildFromSource(source, options, &program);
    if (!s.ok()) return s;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++(seen ? loaded_ : compiled_);
    }
    if (!stamp.empty() && !seen) {
      std::filesystem::create_directories(std::filesystem::path(stamp).parent_path(), ec);
      if (!ec) std::ofstream(stamp) << options << '\n';
    }
  } else {
    const std::string path =
        name.empty() ? "" : (std::filesystem::path(cache_dir_) / (name + ".clbin")).string();
    if (!path.empty() && LoadBinary(path, options, &program)) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++loaded_;
    } else {
      Status s = BuildFromSource(source, options, &program);
      if (!s.ok()) return s;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        ++compiled_;
      }
      if (!path.empty()) SaveBinary(path, program.get());
    }
  }
  *out = program.get();
  slot->program = std::move(program);
  return Status::Ok();
}

Status ClRuntime::BuildFromSource(const std::string &source, const std::string &options,
                                  ClProgram *out) {
  const char *text = source.c_str();
  size_t len = source.size();
  cl_int err = CL_SUCCESS;
  ClProgram program(clCreateProgramWithSource(context_.get(), 1, &text, &len, &err));
  if (err != CL_SUCCESS)
    return Status::Internal("clCreateProgramWithSource failed: " + ClErrorName(err));
  err = clBuildProgram(program.get(), 1, &device_, options.c_str(), nullptr, nullptr);
  if (err != CL_SUCCESS) {
    std::string log = BuildLog(program.get(), device_);
    return Status::Internal("OpenCL program build failed on " + info_.name + " (" +
                            ClErrorName(err) + ") with options '" + options + "'; build log:\n" +
                            log);
  }
  *out = std::move(program);
  return Status::Ok();
}

// In PoCL's cache directory, so that clearing that cache clears the stamps with it. A stamp
// written after a build whose PoCL cache write failed (a full disk) miscounts the next build as
// loaded; the build itself is right either way.
std::string ClRuntime::StampPath(const std::string &name) const {
  return (std::filesystem::path(platform_cache_dir_) / "glint-programs" / (name + ".built"))
      .string();
}

bool ClRuntime::LoadBinary(const std::string &path, const std::string &options, ClProgram *out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
  if (bytes.empty()) return false;
  const unsigned char *data = bytes.data();
  size_t size = bytes.size();
  cl_int status = CL_SUCCESS, err = CL_SUCCESS;
  ClProgram program(
      clCreateProgramWithBinary(context_.get(), 1, &device_, &size, &data, &status, &err));
  if (err != CL_SUCCESS || status != CL_SUCCESS) return false;
  // A stale or corrupt entry fails here: compile from source instead (and overwrite it).
  if (clBuildProgram(program.get(), 1, &device_, options.c_str(), nullptr, nullptr) != CL_SUCCESS)
    return false;
  *out = std::move(program);
  return true;
}

void ClRuntime::SaveBinary(const std::string &path, cl_program program) {
  size_t size = 0;
  if (clGetProgramInfo(program, CL_PROGRAM_BINARY_SIZES, sizeof(size), &size, nullptr) !=
          CL_SUCCESS ||
      size == 0)
    return;
  std::vector<unsigned char> bytes(size);
  unsigned char *ptr = bytes.data();
  if (clGetProgramInfo(program, CL_PROGRAM_BINARIES, sizeof(ptr), &ptr, nullptr) != CL_SUCCESS)
    return;
  // Write then rename, so a concurrent reader never sees half a file.
  std::string tmp = path + ".tmp" + std::to_string(reinterpret_cast<uintptr_t>(program));
  {
    std::ofstream o(tmp, std::ios::binary);
    if (!o) return;
    o.write(reinterpret_cast<const char *>(bytes.data()), std::streamsize(size));
    if (!o) return;
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) std::filesystem::remove(tmp, ec);
}

}  // namespace glint
