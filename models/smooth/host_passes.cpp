// The smooth model's passes on the host, in the precision of GLINT_USE_DOUBLE
// (compiled twice, models/CMakeLists.txt glint_add_model).
#include <cmath>

#include "server/host_pass.h"

namespace glint::GLINT_HOST_NAMESPACE {
#include "models/smooth/smooth_eval.h"
#include "models/smooth/smooth_polygons.h"
#include "models/smooth/smooth_sample.h"
}  // namespace glint::GLINT_HOST_NAMESPACE

GLINT_DEFINE_HOST_PASS(SmoothLights, smooth_query)
GLINT_DEFINE_HOST_PASS(SmoothPolygons, smooth_polygons_query)
GLINT_DEFINE_HOST_SAMPLE(SmoothSample, smooth_sample)
