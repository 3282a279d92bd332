// The NORMAL_MAP model's passes on the host, in the precision of GLINT_USE_DOUBLE
// (compiled twice, models/CMakeLists.txt glint_add_model).
#include <cmath>

#include "server/host_pass.h"

namespace glint::GLINT_HOST_NAMESPACE {
#include "models/normal_map/normal_map_eval.h"
#include "models/normal_map/normal_map_polygons.h"
#include "models/normal_map/normal_map_sample.h"
}  // namespace glint::GLINT_HOST_NAMESPACE

GLINT_DEFINE_HOST_PASS(NormalMap, normal_map_query)
GLINT_DEFINE_HOST_PASS(NormalMapPolygons, normal_map_polygons_query)
GLINT_DEFINE_HOST_SAMPLE(NormalMapSample, normal_map_sample)
