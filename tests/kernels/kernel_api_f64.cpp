// kernel_api.h entry points with the kernel headers compiled as C++ in double (GLINT_USE_DOUBLE=1).
// Standard headers first, at file scope: compat.h includes them again inside the namespace, where
// their include guards must turn the inclusion into a no-op.
#include <cassert>
#include <cmath>

#include "kernel_api.h"

namespace k64 {
#define GLINT_USE_DOUBLE 1
#include "kernels/smooth_brdf.h"
}  // namespace k64

#define GLINT_TEST_KERNEL_NS k64
#define GLINT_TEST_API_NS f64
#include "kernel_api_impl.h"
