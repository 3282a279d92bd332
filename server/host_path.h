// The host scalar path: the same kernels/*.h math compiled as C++ and run in
// a plain loop on one thread. It is the baseline in benchmarks, the fallback
// behind `glintd --device host`, and lets tests run the kernels in double.
#pragma once

#include "glint/v1/glint.pb.h"
#include "server/eval_plan.h"

namespace glint {

// Writes 3 * queries.count() floats. Uses double arithmetic when
// plan.spec.fp64, float otherwise, like the device kernel. A model with a request table
// (NORMAL_MAP) gets it from plan.request_table (ResolveRequestTable) or, when unset, resolves it
// from the material MakeEvalPlan kept; if that fails (map deleted since validation) the output
// is zeros.
void HostEvaluate(const EvalPlan &plan, const glint::v1::QueryBatch &queries, float *out_rgb);

// The model's sample pass (server/model.h ModelSampler): kSampleFloats per sample, sample k of
// query i at i * samples_per_query + k; zeros for a model without one.
void HostSample(const EvalPlan &plan, const glint::v1::QueryBatch &queries,
                uint32_t samples_per_query, float *out);

}  // namespace glint
