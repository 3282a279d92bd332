// Test support: every portable kernel header (shared math, area-light
// integrators, every model's per-query code) compiled as C++ twice, in
// namespace k64 (GLINT_USE_DOUBLE 1) and k32 (0), so one test can compare the
// precisions or run the math in double against an independent reference.
//
// Include it once per test file, after the standard headers (the kernel
// headers define the macro GLINT_R(x), the literal in the working precision). A test that adds its
// own adaptors inside both namespaces defines GLINT_TEST_KERNEL_EXTRA to a header path first (e.g.
// models/binomial/tests/binomial_api.inc).
//
// The list of include guards below is the one place that knows them: a kernel
// header missing here is skipped in k32 and the test fails to compile.
#ifdef GLINT_TEST_KERNELS_BOTH_PRECISIONS_H
#error "include tests/support/kernels_both_precisions.h once per translation unit"
#endif
#define GLINT_TEST_KERNELS_BOTH_PRECISIONS_H

#include <cmath>

#define GLINT_TEST_ALL_KERNEL_HEADERS "tests/support/kernels_both_precisions_list.inc"

namespace k64 {
#define GLINT_USE_DOUBLE 1
#include GLINT_TEST_ALL_KERNEL_HEADERS
#ifdef GLINT_TEST_KERNEL_EXTRA
#include GLINT_TEST_KERNEL_EXTRA
#endif
}  // namespace k64

#undef GLINT_COMPAT_H
#undef GLINT_NDF_H
#undef GLINT_FRESNEL_H
#undef GLINT_SMOOTH_BRDF_H
#undef GLINT_FRAME_H
#undef GLINT_LIGHTS_H
#undef GLINT_RNG_H
#undef GLINT_KERNEL_ARGS_H
#undef GLINT_QUERY_H
#undef GLINT_PUNCTUAL_LIGHTS_H
#undef GLINT_POLYGON_H
#undef GLINT_POLYGON_WEDGE_H
#undef GLINT_POLYGON_SCALE_H
#undef GLINT_ATAN_POLY_H
#undef GLINT_LTC_LOOKUP_H
#undef GLINT_AREA_LECOCQ_H
#undef GLINT_AREA_MONTE_CARLO_H
#undef GLINT_AREA_LIGHTS_H
#undef GLINT_AREA_LTC_H
#undef GLINT_AREA_AUTO_H
#undef GLINT_AREA_AUTO_FEATURES_H
#undef GLINT_AREA_AUTO_TABLE_H
#undef GLINT_POLYGON_LIGHTS_H
#undef GLINT_SPHERICAL_TRIANGLE_H
#undef GLINT_SMOOTH_EVAL_H
#undef GLINT_SMOOTH_POLYGONS_H
#undef GLINT_BINOMIAL_COUNT_H
#undef GLINT_BINOMIAL_TRIG_H
#undef GLINT_BINOMIAL_TETRAHEDRAL_H
#undef GLINT_BINOMIAL_STOCHASTIC_H
#undef GLINT_BINOMIAL_EVAL_H
#undef GLINT_CHERMAIN_EVAL_H
#undef GLINT_CHERMAIN_POLYGONS_H
#undef GLINT_KEMPPINEN_EXP_H
#undef GLINT_KEMPPINEN_NDF_H
#undef GLINT_KEMPPINEN_EVAL_H
#undef GLINT_KEMPPINEN_POLYGONS_H
#undef GLINT_KEMPPINEN_IMAGE_H
#undef GLINT_KEMPPINEN_IMAGE_LINES_H
#undef GLINT_NORMAL_MAP_PARAMS_H
#undef GLINT_NORMAL_MAP_PNDF_H
#undef GLINT_NORMAL_MAP_EVAL_H
#undef GLINT_USE_DOUBLE
#undef GLINT_R

namespace k32 {
#define GLINT_USE_DOUBLE 0
#include GLINT_TEST_ALL_KERNEL_HEADERS
#ifdef GLINT_TEST_KERNEL_EXTRA
#include GLINT_TEST_KERNEL_EXTRA
#endif
}  // namespace k32
