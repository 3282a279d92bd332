// Reads an int a one-work-item kernel of `program` writes to its only argument: how the device
// tests ask which path the device compiled (e.g. GLINT_KEMPPINEN_FAST_EXP, GLINT_FAST_ROOTS_ACTIVE)
// before they claim to have tested it.
#pragma once

#include <gtest/gtest.h>

#include "server/cl_handle.h"
#include "server/cl_runtime.h"

namespace glint::test {

inline ::testing::AssertionResult ReadDeviceIntFlag(ClRuntime &rt, cl_program program,
                                                    cl_command_queue queue, const char *kernel_name,
                                                    int *value) {
  cl_int err = CL_SUCCESS;
  ClBuffer flag(clCreateBuffer(rt.context(), CL_MEM_WRITE_ONLY, sizeof(int), nullptr, &err));
  if (err != CL_SUCCESS) return ::testing::AssertionFailure() << "clCreateBuffer: " << err;
  ClKernel kernel(clCreateKernel(program, kernel_name, &err));
  if (err != CL_SUCCESS)
    return ::testing::AssertionFailure() << "clCreateKernel " << kernel_name << ": " << err;
  cl_mem m = flag.get();
  if (clSetKernelArg(kernel.get(), 0, sizeof m, &m) != CL_SUCCESS)
    return ::testing::AssertionFailure() << "clSetKernelArg";
  const size_t one = 1;
  if (clEnqueueNDRangeKernel(queue, kernel.get(), 1, nullptr, &one, nullptr, 0, nullptr, nullptr) !=
      CL_SUCCESS)
    return ::testing::AssertionFailure() << "clEnqueueNDRangeKernel " << kernel_name;
  if (clEnqueueReadBuffer(queue, flag.get(), CL_TRUE, 0, sizeof(int), value, 0, nullptr, nullptr) !=
      CL_SUCCESS)
    return ::testing::AssertionFailure() << "clEnqueueReadBuffer";
  return ::testing::AssertionSuccess();
}

}  // namespace glint::test
