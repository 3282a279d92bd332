// The host path's one loop: a model pass (a per-query function of the portable
// headers, the same one its OpenCL entry calls) run over a batch on one thread,
// in float or double. Each model's host glue (models/<name>/host_passes.cpp) is
// compiled twice, with GLINT_USE_DOUBLE 0 and 1 (glint_add_model in
// models/CMakeLists.txt), and defines its passes with GLINT_DEFINE_HOST_PASS.
#pragma once

#include <cfloat>
#include <cstddef>
#include <cstdint>

namespace glint {

// The standard kernel inputs (kernels/kernel_args.h KernelInputs) plus the spec,
// precision-independent so the engine can fill them once.
struct HostInputs {
  // EvalSpec
  int ndf = 1, fresnel = 1, probe = 0, has_frame = 0, has_directional = 0, has_point = 0;
  int sample_uv = 0;
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

// The EvalSpec and KernelInputs of the kernel headers (in the host's precision namespace) from
// the precision-independent HostInputs.
template <class Spec, class Inputs>
void FillKernelInputs(const HostInputs &h, Spec *spec_out, Inputs *in_out) {
  Spec &spec = *spec_out;
  spec.ndf = h.ndf;
  spec.fresnel = h.fresnel;
  spec.probe = h.probe;
  spec.has_frame = h.has_frame;
  spec.has_directional = h.has_directional;
  spec.has_point = h.has_point;
  spec.sample_uv = h.sample_uv;
  Inputs &in = *in_out;
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
}

// The loop: query_fn(spec, inputs, i) -> real3 for every query, stored in float
// and summed in float like the device's kernel_store.
template <class Spec, class Inputs, class QueryFn>
void RunHostPass(const HostInputs &h, QueryFn query_fn, float *out, bool accumulate) {
  Spec spec;
  Inputs in;
  FillKernelInputs(h, &spec, &in);
  for (uint32_t i = 0; i < h.n; ++i) {
    const auto L = query_fn(spec, in, i);
    float *o = out + 3 * size_t(i);
    const float r = SaturateToFloat(L.x), g = SaturateToFloat(L.y), b = SaturateToFloat(L.z);
    o[0] = accumulate ? SaturateToFloat(o[0] + r) : r;
    o[1] = accumulate ? SaturateToFloat(o[1] + g) : g;
    o[2] = accumulate ? SaturateToFloat(o[2] + b) : b;
  }
}

// A model's sample pass on the host (the Sample RPC, kernels/sample.h): writes
// GLINT_SAMPLE_FLOATS (7: wi, pdf, weight) per sample, sample k of query i at
// i * samples_per_query + k, saturated like the device's sample_store.
using SampleHostFn = void (*)(const HostInputs &in, uint32_t samples_per_query, float *out);
constexpr size_t kSampleFloats = 7;  // = GLINT_SAMPLE_FLOATS (kernels/sample.h)

template <class Spec, class Inputs, class SampleFn>
void RunHostSample(const HostInputs &h, SampleFn sample_fn, uint32_t samples_per_query,
                   float *out) {
  Spec spec;
  Inputs in;
  FillKernelInputs(h, &spec, &in);
  for (uint32_t i = 0; i < h.n; ++i) {
    for (uint32_t k = 0; k < samples_per_query; ++k) {
      const auto b = sample_fn(spec, in, i, k);
      float *o = out + kSampleFloats * (size_t(i) * samples_per_query + k);
      o[0] = float(b.wi.x);
      o[1] = float(b.wi.y);
      o[2] = float(b.wi.z);
      o[3] = SaturateToFloat(b.pdf);
      o[4] = SaturateToFloat(b.weight.x);
      o[5] = SaturateToFloat(b.weight.y);
      o[6] = SaturateToFloat(b.weight.z);
    }
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

// A model's sample pass on the host (server/model.h ModelSampler), like GLINT_DEFINE_HOST_PASS:
// defines glint::<name>F32 or glint::<name>F64 running `sample_fn` (kernels/sample.h).
#define GLINT_DEFINE_HOST_SAMPLE(name, sample_fn)                                              \
  static_assert(GLINT_SAMPLE_FLOATS == glint::kSampleFloats);                                  \
  namespace glint {                                                                            \
  void GLINT_HOST_SYMBOL(name)(const HostInputs &in, uint32_t samples_per_query, float *out) { \
    RunHostSample<GLINT_HOST_NAMESPACE::EvalSpec, GLINT_HOST_NAMESPACE::KernelInputs>(         \
        in, GLINT_HOST_NAMESPACE::sample_fn, samples_per_query, out);                          \
  }                                                                                            \
  }
#define GLINT_DECLARE_HOST_SAMPLE(name)                                         \
  namespace glint {                                                             \
  void name##F32(const HostInputs &in, uint32_t samples_per_query, float *out); \
  void name##F64(const HostInputs &in, uint32_t samples_per_query, float *out); \
  }
