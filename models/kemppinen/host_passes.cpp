// The Kemppinen model's pass on the host, in the precision of GLINT_USE_DOUBLE
// (compiled twice, models/CMakeLists.txt glint_add_model).
#include <cmath>

#include "server/host_pass.h"

namespace glint::GLINT_HOST_NAMESPACE {
#include "models/kemppinen/kemppinen_polygons.h"
#include "models/kemppinen/kemppinen_sample.h"
}  // namespace glint::GLINT_HOST_NAMESPACE

GLINT_DEFINE_HOST_PASS(KemppinenLights, kemppinen_query)
GLINT_DEFINE_HOST_PASS(KemppinenPolygons, kemppinen_polygons_query)
GLINT_DEFINE_HOST_SAMPLE(KemppinenSample, kemppinen_sample)
