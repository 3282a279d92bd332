// Owning handles for OpenCL objects (in the spirit of CLBlast's clpp11): each
// releases its object exactly once, moves but never copies, so no error path
// can leak a buffer, kernel, program, queue or context.
#pragma once

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>

#include <utility>

namespace glint {

template <class T, cl_int(CL_API_CALL *Release)(T)>
class ClHandle {
 public:
  ClHandle() = default;
  explicit ClHandle(T handle) : handle_(handle) {}
  ~ClHandle() { reset(); }
  ClHandle(const ClHandle &) = delete;
  ClHandle &operator=(const ClHandle &) = delete;
  ClHandle(ClHandle &&other) noexcept : handle_(std::exchange(other.handle_, nullptr)) {}
  ClHandle &operator=(ClHandle &&other) noexcept {
    if (this != &other) reset(std::exchange(other.handle_, nullptr));
    return *this;
  }

  T get() const { return handle_; }
  explicit operator bool() const { return handle_ != nullptr; }
  // Releases the current object and takes ownership of `handle`.
  void reset(T handle = nullptr) {
    if (handle_) Release(handle_);
    handle_ = handle;
  }

 private:
  T handle_ = nullptr;
};

using ClContext = ClHandle<cl_context, clReleaseContext>;
using ClQueue = ClHandle<cl_command_queue, clReleaseCommandQueue>;
using ClProgram = ClHandle<cl_program, clReleaseProgram>;
using ClKernel = ClHandle<cl_kernel, clReleaseKernel>;
using ClBuffer = ClHandle<cl_mem, clReleaseMemObject>;

}  // namespace glint
