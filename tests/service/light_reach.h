// Whether each light of a test's request reaches some of its queries. A one-sided polygon emits
// only towards the side from which its vertices are seen counter-clockwise (glint.proto
// PolygonLight): a light that faces away from every query adds zeros, and a device-vs-host or
// chunking comparison then shows nothing about it (session 19 found a softbox and a 1000-unit
// quad in two lane tests that had never lit a query).
#pragma once

#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/eval_plan.h"
#include "server/host_path.h"

namespace glint::test {

// The indices of `settings`' lights whose radiance is 0 at every query of q (host path, each
// light alone).
inline std::vector<int> LightsReachingNoQuery(const glint::v1::EvaluateRequest &settings,
                                              const glint::v1::QueryBatch &q) {
  std::vector<int> dark;
  for (int i = 0; i < settings.lights_size(); ++i) {
    glint::v1::EvaluateRequest one = settings;
    one.clear_lights();
    *one.add_lights() = settings.lights(i);
    const EvalPlan plan = MakeEvalPlan(one, q);
    std::vector<float> out(3 * size_t(q.count()), 0.0f);
    HostEvaluate(plan, q, out.data());
    bool lit = false;
    for (float v : out) lit = lit || v > 0.0f;
    if (!lit) dark.push_back(i);
  }
  return dark;
}

}  // namespace glint::test
