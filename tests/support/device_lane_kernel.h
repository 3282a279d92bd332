// Runs a kernel of `program` that maps one float array to several float arrays of the same length,
// one work-item per `lanes` elements: how the device unit tests compare a device function with a
// reference element by element (tests/kernels/fast_roots_device_test.cpp,
// models/kemppinen/tests/kemppinen_exp_device_test.cpp). Arguments: the input, then the outputs.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "server/cl_handle.h"
#include "server/cl_runtime.h"
#include "server/kernel_source.h"

namespace glint::test {

// Builds `kernel_source` after `prelude` and the expanded `header` (a kernels/ or models/ path) as
// a 16-lane fp32 device entry in the local frame, on the default device with the kernel cache of
// $GLINT_CACHE_DIR.
inline ::testing::AssertionResult BuildLaneProgram(const std::string &prelude,
                                                   const std::string &header,
                                                   const char *kernel_source,
                                                   std::unique_ptr<ClRuntime> *rt,
                                                   cl_program *program) {
  const char *cache = std::getenv("GLINT_CACHE_DIR");
  if (!ClRuntime::Create("", cache ? cache : "", rt).ok())
    return ::testing::AssertionFailure() << "no OpenCL runtime";
  const Status built = (*rt)->GetProgram(
      prelude + ExpandKernelSource(header) + kernel_source,
      "-DGLINT_LANES=16 -DGLINT_USE_DOUBLE=0 -DGLINT_HAS_FRAME=0 -cl-single-precision-constant",
      program);
  if (!built.ok()) return ::testing::AssertionFailure() << built.message();
  return ::testing::AssertionSuccess();
}

// The same as the 16-lane fp32 entries that ask for fast roots and fused multiply-adds compile it
// (GLINT_FAST_ROOTS, GLINT_CONTRACT_FMA: SMOOTH's and KEMPPINEN's).
inline ::testing::AssertionResult BuildFastRootsLaneProgram(const std::string &header,
                                                            const char *kernel_source,
                                                            std::unique_ptr<ClRuntime> *rt,
                                                            cl_program *program) {
  return BuildLaneProgram("#define GLINT_FAST_ROOTS 1\n#define GLINT_CONTRACT_FMA 1\n", header,
                          kernel_source, rt, program);
}

inline ::testing::AssertionResult RunFloatLaneKernel(
    ClRuntime &rt, cl_program program, cl_command_queue queue, const char *kernel_name,
    size_t lanes, const std::vector<float> &in, const std::vector<std::vector<float> *> &outs) {
  if (lanes == 0 || in.size() % lanes != 0)
    return ::testing::AssertionFailure() << "input of " << in.size() << " is not whole blocks";
  cl_int err = CL_SUCCESS;
  const size_t bytes = in.size() * sizeof(float);
  ClBuffer input(clCreateBuffer(rt.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes,
                                const_cast<float *>(in.data()), &err));
  if (err != CL_SUCCESS) return ::testing::AssertionFailure() << "clCreateBuffer: " << err;
  std::vector<ClBuffer> outputs;
  for (size_t o = 0; o < outs.size(); ++o) {
    outputs.emplace_back(clCreateBuffer(rt.context(), CL_MEM_WRITE_ONLY, bytes, nullptr, &err));
    if (err != CL_SUCCESS) return ::testing::AssertionFailure() << "clCreateBuffer: " << err;
  }
  ClKernel kernel(clCreateKernel(program, kernel_name, &err));
  if (err != CL_SUCCESS)
    return ::testing::AssertionFailure() << "clCreateKernel " << kernel_name << ": " << err;
  for (size_t a = 0; a <= outs.size(); ++a) {
    cl_mem m = a == 0 ? input.get() : outputs[a - 1].get();
    if (clSetKernelArg(kernel.get(), cl_uint(a), sizeof m, &m) != CL_SUCCESS)
      return ::testing::AssertionFailure() << "clSetKernelArg " << a;
  }
  const size_t global = in.size() / lanes;
  if (clEnqueueNDRangeKernel(queue, kernel.get(), 1, nullptr, &global, nullptr, 0, nullptr,
                             nullptr) != CL_SUCCESS)
    return ::testing::AssertionFailure() << "clEnqueueNDRangeKernel " << kernel_name;
  for (size_t o = 0; o < outs.size(); ++o) {
    outs[o]->resize(in.size());
    if (clEnqueueReadBuffer(queue, outputs[o].get(), CL_TRUE, 0, bytes, outs[o]->data(), 0, nullptr,
                            nullptr) != CL_SUCCESS)
      return ::testing::AssertionFailure() << "clEnqueueReadBuffer " << o;
  }
  return ::testing::AssertionSuccess();
}

}  // namespace glint::test
