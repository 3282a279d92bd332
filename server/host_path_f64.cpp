// The host path in fp64: kernels/*.h compiled as C++ with GLINT_USE_DOUBLE=1.
#include <cmath>

#include "server/eval_plan.h"

namespace glint::host_f64 {
#define GLINT_USE_DOUBLE 1
#include "kernels/area/area_lights.h"
#include "models/binomial/binomial_eval.h"
#include "models/smooth/smooth_eval.h"
#include "server/host_path_impl.inc"
}  // namespace glint::host_f64

namespace glint {
void HostEvaluateF64(const EvalPlan &plan, const glint::v1::QueryBatch &q, float *out) {
  host_f64::RunPlan(plan, q, out);
}
}  // namespace glint
