#include "server/host_path.h"

#include "server/output_range.h"

namespace glint {

void HostEvaluateF32(const EvalPlan &plan, const glint::v1::QueryBatch &q, float *out);
void HostEvaluateF64(const EvalPlan &plan, const glint::v1::QueryBatch &q, float *out);

void HostEvaluate(const EvalPlan &plan, const glint::v1::QueryBatch &q, float *out) {
  if (plan.spec.fp64)
    HostEvaluateF64(plan, q, out);
  else
    HostEvaluateF32(plan, q, out);
  SaturateRadiance(out, 3 * size_t(q.count()));
}

}  // namespace glint
