// The host path's one loop: a model pass (a per-query function of the portable
// headers, the same one its OpenCL entry calls) run over a batch on one thread,
// in float or double. Each model's host glue (models/<name>/host_passes.cpp) is
// compiled twice, with GLINT_USE_DOUBLE 0 and 1 (glint_add_model in
// models/CMakeLists.txt), and defines its passes with GLINT_DEFINE_HOST_PASS.
#pragma once

#include <cfloat>
#include <cstdint>

namespace glint {

// The standard kernel inputs (kernels/kernel_args.h KernelInputs) plus the spec,
// precision-independent so the engine can fill them once.
struct HostInputs {
  // EvalSpec
  int ndf = 1, fresnel = 1, probe = 0, has_frame = 0, has_directional = 0, has_point = 0;
  // KernelInputs
  uint32_t n = 0;
  const float *uv = nullptr, *footprint = nullptr, *wo = nullptr, *wi = nullptr;
  const float *position = nullptr, *normal = nullptr, *tangent = nullptr;
  const float *material = nullptr, *params = nullptr;
  const float *directional = nullptr;
  uint32_t n_directional = 0;
  const float *point = nullptr;
  uint32_t n_point = 0;
  const float *polygons = nullptr;
  uint32_t n_polygon = 0;
  const float *ltc_table = nullptr;
  const float *model_table = nullptr;  // Model::table, or nullptr
  int area_method = 1, area_samples = 64;
  uint32_t seed_lo = 0, seed_hi = 0;
};

// The output contract of kernels/kernel_args.h GLINT_SATURATE_FLOAT: beyond the float range ->
// FLT_MAX, NaN kept. Compared in the working precision before the conversion to float.
template <class Real>
float SaturateToFloat(Real x) {
  return x > Real(FLT_MAX) ? FLT_MAX : float(x);
}

// Writes (or with `accumulate`, adds) 3 floats per query to `out`.
using HostPassFn = void (*)(const HostInputs &in, float *out, bool accumulate);

// The loop: query_fn(spec, inputs, i) -> real3 for every query, stored in float
// and summed in float like the device's kernel_store.
template <class Spec, class Inputs, class QueryFn>
void RunHostPass(const HostInputs &h, QueryFn query_fn, float *out, bool accumulate) {
  Spec spec;
  spec.ndf = h.ndf;
  spec.fresnel = h.fresnel;
  spec.probe = h.probe;
  spec.has_frame = h.has_frame;
  spec.has_directional = h.has_directional;
  spec.has_point = h.has_point;
  Inputs in;
  in.n = h.n;
  in.uv = h.uv;
  in.footprint = h.footprint;
  in.wo = h.wo;
  in.wi = h.wi;
  in.position = h.position;
  in.normal = h.normal;
  in.tangent = h.tangent;
  in.material = h.material;
  in.params = h.params;
  in.directional = h.directional;
  in.n_directional = h.n_directional;
  in.point = h.point;
  in.n_point = h.n_point;
  in.polygons = h.polygons;
  in.n_polygon = h.n_polygon;
  in.ltc_table = h.ltc_table;
  in.model_table = h.model_table;
  in.area_method = h.area_method;
  in.area_samples = h.area_samples;
  in.seed_lo = h.seed_lo;
  in.seed_hi = h.seed_hi;
  for (uint32_t i = 0; i < h.n; ++i) {
    const auto L = query_fn(spec, in, i);
    float *o = out + 3 * size_t(i);
    const float r = SaturateToFloat(L.x), g = SaturateToFloat(L.y), b = SaturateToFloat(L.z);
    o[0] = accumulate ? SaturateToFloat(o[0] + r) : r;
    o[1] = accumulate ? SaturateToFloat(o[1] + g) : g;
    o[2] = accumulate ? SaturateToFloat(o[2] + b) : b;
  }
}

}  // namespace glint

// Inside a model's host_passes.cpp, after its kernel headers were included in
// namespace glint::GLINT_HOST_NAMESPACE: defines glint::<name>F32 or
// glint::<name>F64 (by GLINT_USE_DOUBLE) running `query_fn` in the host loop.
#if defined(GLINT_USE_DOUBLE) && GLINT_USE_DOUBLE
#define GLINT_HOST_NAMESPACE host_f64
#define GLINT_HOST_SYMBOL(name) name##F64
#else
#define GLINT_HOST_NAMESPACE host_f32
#define GLINT_HOST_SYMBOL(name) name##F32
#endif
#define GLINT_DEFINE_HOST_PASS(name, query_fn)                                       \
  namespace glint {                                                                  \
  void GLINT_HOST_SYMBOL(name)(const HostInputs &in, float *out, bool accumulate) {  \
    RunHostPass<GLINT_HOST_NAMESPACE::EvalSpec, GLINT_HOST_NAMESPACE::KernelInputs>( \
        in, GLINT_HOST_NAMESPACE::query_fn, out, accumulate);                        \
  }                                                                                  \
  }

// In a model's descriptor file: declares the fp32 and fp64 functions of a pass
// that its host_passes.cpp defines with GLINT_DEFINE_HOST_PASS.
#define GLINT_DECLARE_HOST_PASS(name)                                \
  namespace glint {                                                  \
  void name##F32(const HostInputs &in, float *out, bool accumulate); \
  void name##F64(const HostInputs &in, float *out, bool accumulate); \
  }
