// The smooth model's entry in the model table (server/model.h): 16-lane SIMD
// passes for probes and directional/point lights, 8 lanes for polygon lights by
// LTC, one query per work-item for polygon lights by the other area methods. No
// parameters of its own.
#include "server/eval_plan.h"
#include "server/host_pass.h"
#include "server/model.h"

GLINT_DECLARE_HOST_SAMPLE(SmoothSample)
GLINT_DECLARE_HOST_PASS(SmoothLights)
GLINT_DECLARE_HOST_PASS(SmoothLightsLanes)
GLINT_DECLARE_HOST_PASS(SmoothPolygons)

namespace glint {
namespace {

bool HasProbesOrPunctualLights(const EvalPlan &plan) {
  // Also when nothing else runs, so a batch always gets its output written.
  return plan.spec.probe || plan.n_directional > 0 || plan.n_point > 0 || plan.n_polygon == 0;
}

// Polygon lights by LTC run 8 queries per work-item (lane-safe); the other area methods branch
// per query and run one per work-item.
bool HasPolygonsLtc(const EvalPlan &plan) {
  return plan.n_polygon > 0 && plan.area_method == GLINT_AREA_LTC;
}

bool HasPolygonsOtherMethod(const EvalPlan &plan) {
  return plan.n_polygon > 0 && plan.area_method != GLINT_AREA_LTC;
}

std::vector<KernelSpec> SmoothWarmSpecs() {
  std::vector<KernelSpec> specs;
  for (int ndf : {GLINT_NDF_GGX, GLINT_NDF_BECKMANN}) {
    KernelSpec probe;
    probe.ndf = ndf;
    probe.probe = true;
    specs.push_back(probe);
    KernelSpec lit;
    lit.ndf = ndf;
    lit.has_frame = true;
    lit.has_directional = true;
    lit.has_point = true;
    specs.push_back(lit);
  }
  KernelSpec area;  // the softbox preview: polygon lights, no frame
  area.has_polygon = true;
  specs.push_back(area);
  return specs;
}

}  // namespace

extern const Model kSmoothModel;
const Model kSmoothModel = {
    .id = glint::v1::SMOOTH,
    .name = "SMOOTH",
    .params_field = nullptr,
    // 16 lanes: fp32 conductor probes +26% per CPU-second over 8 on the AVX-512 CPU device, fp64
    // unchanged, output bit-identical (issue 13; bench/mitsuba_compare.py, README "Performance").
    // The host path runs this pass with lanes too (host_lanes.cpp; bit-identical to the scalar
    // SmoothLights of host_passes.cpp, which tests/service/host_lanes_test.cpp compares it with).
    // fp32 probes: two 16-lane blocks per work-item (models/smooth/README.md, session 17).
    .passes = {{"models/smooth/smooth.cl", "glint_smooth", 16, HasProbesOrPunctualLights,
                SmoothLightsLanesF32, SmoothLightsLanesF64, 0, 2},
               {"models/smooth/smooth_area_lanes.cl", "glint_smooth_area_lanes", 8, HasPolygonsLtc,
                SmoothPolygonsF32, SmoothPolygonsF64},
               {"models/smooth/smooth_area.cl", "glint_smooth_area", 1, HasPolygonsOtherMethod,
                SmoothPolygonsF32, SmoothPolygonsF64}},
    .warm_specs = SmoothWarmSpecs,
    .sample = {"models/smooth/smooth_sample.cl", "glint_smooth_sample", SmoothSampleF32,
               SmoothSampleF64},
};

}  // namespace glint
