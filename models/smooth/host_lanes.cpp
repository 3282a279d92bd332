// The smooth model's probe / directional / point pass on the host with lanes (issue 13): the
// same smooth_shade (models/smooth/smooth_eval.h) as the scalar host pass and the 16-lane device
// entry, compiled with `real` holding GLINT_HOST_LANES queries (kernels/host_lanes.h), so one call
// evaluates a block of queries as the device's work-item does. Compiled twice, fp32 (16 lanes of
// float) and fp64 (8 of double); the loop is built for AVX-512, AVX2 and the x86-64 baseline
// (target_clones, chosen at load time by the CPU). -ffp-contract=off (models/smooth/CMakeLists.txt)
// keeps every operation rounded as in the scalar host path: results are bit-identical to it.
#include <algorithm>
#include <cmath>

#include "server/host_pass.h"

#if GLINT_USE_DOUBLE
#define GLINT_HOST_LANES 8
#define GLINT_HOST_LANES_NAMESPACE host_lanes_f64
#else
#define GLINT_HOST_LANES 16
#define GLINT_HOST_LANES_NAMESPACE host_lanes_f32
#endif

namespace glint::GLINT_HOST_LANES_NAMESPACE {
#include "models/smooth/smooth_eval.h"

namespace {

// Queries [base, base + GLINT_HOST_LANES) of an array of xyz triples in lanes; lanes past n
// repeat query n - 1 (finite work, never stored), as kernels/simd_io.h block_load3.
GLINT_FN real3 LoadBlock3(const float *a, uint32_t base, uint32_t n) {
  real3 r;
  for (uint32_t l = 0; l < GLINT_HOST_LANES; ++l) {
    const size_t j = 3 * size_t(std::min(base + l, n - 1));
    r.x.v[l] = a[j];
    r.y.v[l] = a[j + 1];
    r.z.v[l] = a[j + 2];
  }
  return r;
}

// kernels/simd_io.h block_load_queries.
GLINT_FN QueryInputs LoadQueries(const EvalSpec &spec, const KernelInputs &in, uint32_t base) {
  const real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  QueryInputs q;
  q.wo = LoadBlock3(in.wo, base, in.n);
  q.wi = zero;
  q.position = zero;
  q.normal = zero;
  q.tangent = zero;
  if (spec.probe) q.wi = LoadBlock3(in.wi, base, in.n);
  if (spec.has_frame) {
    q.position = LoadBlock3(in.position, base, in.n);
    q.normal = LoadBlock3(in.normal, base, in.n);
    q.tangent = LoadBlock3(in.tangent, base, in.n);
  }
  return q;
}

}  // namespace

// The host pass (server/host_pass.h RunHostPass's output rule: saturated float, and with
// `accumulate` the float sum saturated again), a block of queries per call of smooth_shade.
__attribute__((target_clones("avx512f", "avx2", "default"))) void RunLanes(const HostInputs &h,
                                                                           float *out,
                                                                           bool accumulate) {
  EvalSpec spec;
  KernelInputs in;
  FillKernelInputs(h, &spec, &in);
  for (uint32_t base = 0; base < h.n; base += GLINT_HOST_LANES) {
    const real3 L = smooth_shade(spec, in, LoadQueries(spec, in, base));
    const uint32_t count = std::min<uint32_t>(GLINT_HOST_LANES, h.n - base);
    for (uint32_t l = 0; l < count; ++l) {
      float *o = out + 3 * size_t(base + l);
      const float r = SaturateToFloat(L.x.v[l]), g = SaturateToFloat(L.y.v[l]),
                  b = SaturateToFloat(L.z.v[l]);
      o[0] = accumulate ? SaturateToFloat(o[0] + r) : r;
      o[1] = accumulate ? SaturateToFloat(o[1] + g) : g;
      o[2] = accumulate ? SaturateToFloat(o[2] + b) : b;
    }
  }
}

}  // namespace glint::GLINT_HOST_LANES_NAMESPACE

namespace glint {
void GLINT_HOST_SYMBOL(SmoothLightsLanes)(const HostInputs &in, float *out, bool accumulate) {
  GLINT_HOST_LANES_NAMESPACE::RunLanes(in, out, accumulate);
}
}  // namespace glint
