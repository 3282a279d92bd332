// kernel_api.h entry points with the kernel headers compiled as C++ in float (GLINT_USE_DOUBLE=0).
// Standard headers first, at file scope: compat.h includes them again inside the namespace, where
// their include guards must turn the inclusion into a no-op.
#include <cassert>
#include <cmath>

#include "kernel_api.h"

namespace k32 {
#define GLINT_USE_DOUBLE 0
#include "kernels/smooth_brdf.h"
}  // namespace k32

#define GLINT_TEST_KERNEL_NS k32
#define GLINT_TEST_API_NS f32
#include "kernel_api_impl.h"
