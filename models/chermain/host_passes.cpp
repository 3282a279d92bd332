// The Chermain model's passes on the host, in the precision of GLINT_USE_DOUBLE
// (compiled twice, models/CMakeLists.txt glint_add_model).
#include <cmath>

#include "server/host_pass.h"

namespace glint::GLINT_HOST_NAMESPACE {
#include "models/chermain/chermain_eval.h"
#include "models/chermain/chermain_polygons.h"
#include "models/chermain/chermain_sample.h"
}  // namespace glint::GLINT_HOST_NAMESPACE

GLINT_DEFINE_HOST_PASS(Chermain, chermain_query)
GLINT_DEFINE_HOST_PASS(ChermainPolygons, chermain_polygons_query)
GLINT_DEFINE_HOST_SAMPLE(ChermainSample, chermain_sample)
