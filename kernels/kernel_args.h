/* The one argument list every model's kernel entry takes, and the struct that
 * carries it through the portable headers. The host binds these arguments in
 * one place (server/device_engine.cpp, BindKernelArguments) in this order, and
 * the host path fills the same struct (server/host_pass.h), so a model never
 * declares or binds arguments of its own: what a model needs beyond the common
 * inputs travels in its packed parameter block (`params`).
 *
 * Query arrays a request does not carry are bound to a small dummy buffer and
 * never read: which ones are present is in the EvalSpec (build options on the
 * device, run-time values on the host). */
#ifndef GLINT_KERNEL_ARGS_H
#define GLINT_KERNEL_ARGS_H

#include "kernels/compat.h"
#include "kernels/layout.h"

/* What the request asks for. On the device every field is a build-time
 * constant (kernel_spec below), so branches on it fold away and only what the
 * request needs is compiled; the host passes the same values at run time. */
typedef struct {
  int ndf;             /* GLINT_NDF_* */
  int fresnel;         /* GLINT_FRESNEL_* */
  int probe;           /* queries carry wi: return f cos_i, no lights */
  int has_frame;       /* queries carry world position / normal / tangent */
  int has_directional; /* request has directional lights */
  int has_point;       /* request has point lights */
  /* Sample only (the Sample RPC, kernels/sample.h): the queries carry uv, so a
   * sampler of a model that does not read uv (the smooth one) still keys its
   * random numbers on it. 0 in every Evaluate pass. */
  int sample_uv;
} EvalSpec;

typedef struct {
  uint n;                              /* queries */
  const GLINT_GLOBAL float *uv;        /* 2 per query (glint models) */
  const GLINT_GLOBAL float *footprint; /* 4 per query: du/dx, dv/dx, du/dy, dv/dy */
  const GLINT_GLOBAL float *wo;        /* 3 per query */
  const GLINT_GLOBAL float *wi;        /* 3 per query, probes only */
  const GLINT_GLOBAL float *position;  /* 3 per query, framed only */
  const GLINT_GLOBAL float *normal;
  const GLINT_GLOBAL float *tangent;
  const GLINT_GLOBAL float *material;    /* GLINT_MATERIAL_FLOATS */
  const GLINT_GLOBAL float *params;      /* GLINT_MODEL_PARAM_FLOATS, the model's own */
  const GLINT_GLOBAL float *directional; /* GLINT_LIGHT_FLOATS per light */
  uint n_directional;
  const GLINT_GLOBAL float *point; /* GLINT_LIGHT_FLOATS per light */
  uint n_point;
  const GLINT_GLOBAL float *polygons; /* GLINT_POLYGON_FLOATS per light */
  uint n_polygon;
  const GLINT_GLOBAL float *ltc_table; /* of the material's NDF (kernels/area/ltc_lookup.h) */
  /* The model's own read-only table (Model::table, e.g. the Chermain
   * dictionary); the dummy buffer for models without one. */
  const GLINT_GLOBAL float *model_table;
  int area_method;       /* GLINT_AREA_* */
  int area_samples;      /* REFERENCE nodes per dimension, MONTE_CARLO samples */
  uint seed_lo, seed_hi; /* the request seed (kernels/rng.h) */
} KernelInputs;

#ifdef __OPENCL_VERSION__
/* `accumulate`: add to `out` (an earlier pass of the same model wrote it)
 * instead of overwriting it. `material_values`: the same GLINT_MATERIAL_FLOATS floats as the
 * `material` buffer, by value. PoCL loads by-value arguments once per work-group, before its loop
 * over the work-items, so what a kernel computes from them (1 / alpha, the conductor's products
 * of eta and k, and their 16-lane broadcasts) leaves that loop; a load from the buffer stays in
 * every work-item (it follows the padding check, and `out` may alias it). The SMOOTH probe
 * kernel reads it (models/smooth/smooth.cl); the buffer stays for every other reader. */
#define GLINT_KERNEL_ARGS                                                                        \
  uint n, __global const float *uv, __global const float *footprint, __global const float *wo,   \
      __global const float *wi, __global const float *position, __global const float *normal,    \
      __global const float *tangent, __global const float *material, float8 material_values,     \
      __global const float *params, __global const float *directional, uint n_directional,       \
      __global const float *point, uint n_point, __global const float *polygons, uint n_polygon, \
      __global const float *ltc_table, __global const float *model_table, int area_method,       \
      int area_samples, uint seed_lo, uint seed_hi, int accumulate, __global float *out

/* The struct from the arguments, inside a kernel declared with GLINT_KERNEL_ARGS. */
#define GLINT_KERNEL_INPUTS()                                                                    \
  kernel_inputs_make(n, uv, footprint, wo, wi, position, normal, tangent, material, params,      \
                     directional, n_directional, point, n_point, polygons, n_polygon, ltc_table, \
                     model_table, area_method, area_samples, seed_lo, seed_hi)

GLINT_FN KernelInputs kernel_inputs_make(
    uint n, __global const float *uv, __global const float *footprint, __global const float *wo,
    __global const float *wi, __global const float *position, __global const float *normal,
    __global const float *tangent, __global const float *material, __global const float *params,
    __global const float *directional, uint n_directional, __global const float *point,
    uint n_point, __global const float *polygons, uint n_polygon, __global const float *ltc_table,
    __global const float *model_table, int area_method, int area_samples, uint seed_lo,
    uint seed_hi) {
  KernelInputs in;
  in.n = n;
  in.uv = uv;
  in.footprint = footprint;
  in.wo = wo;
  in.wi = wi;
  in.position = position;
  in.normal = normal;
  in.tangent = tangent;
  in.material = material;
  in.params = params;
  in.directional = directional;
  in.n_directional = n_directional;
  in.point = point;
  in.n_point = n_point;
  in.polygons = polygons;
  in.n_polygon = n_polygon;
  in.ltc_table = ltc_table;
  in.model_table = model_table;
  /* GLINT_AREA_ONLY (KernelSpec::area_only, set only by a caller that asked for a program
   * specialised to one area method, never by glintd): the method is a constant, so the compiler
   * drops the other methods' code (AUTO's choice, REFERENCE's quadrature, ...) from the program
   * and the build takes less time. The engine binds such a program only to plans whose
   * area_method is that method, so the constant equals the argument: same code path, same
   * results (tests/service/area_only_test.cpp). */
#ifdef GLINT_AREA_ONLY
  (void)area_method;
  in.area_method = GLINT_AREA_ONLY;
#else
  in.area_method = area_method;
#endif
  in.area_samples = area_samples;
  in.seed_lo = seed_lo;
  in.seed_hi = seed_hi;
  return in;
}

/* The spec from the build options (server/eval_plan.cpp KernelSpec::BuildOptions). */
#ifndef GLINT_SAMPLE_UV
#define GLINT_SAMPLE_UV 0 /* set only for sample passes whose queries carry uv */
#endif
GLINT_FN EvalSpec kernel_spec(void) {
  EvalSpec spec;
  spec.ndf = GLINT_NDF;
  spec.fresnel = GLINT_FRESNEL;
  spec.probe = GLINT_PROBE;
  spec.has_frame = GLINT_HAS_FRAME;
  spec.has_directional = GLINT_HAS_DIRECTIONAL;
  spec.has_point = GLINT_HAS_POINT;
  spec.sample_uv = GLINT_SAMPLE_UV;
  return spec;
}

/* The output contract: radiance beyond the float range (an extreme light at
 * extreme geometry, which validation accepts) saturates at FLT_MAX instead of
 * +Inf; NaN is left as it is, so the stability sweep still sees a kernel bug.
 * Done in the kernels' stores (and the host loop's), where it costs nothing. */
#define GLINT_SATURATE_FLOAT(x) ((x) > FLT_MAX ? FLT_MAX : (x))

#if GLINT_LANES == 1
/* Writes (or, after an earlier pass, adds) one query's RGB, summed in float as
 * the host path does (server/host_pass.h). Entries with one query per
 * work-item use it; 8-lane entries store blocks (kernels/simd_io.h). */
GLINT_FN void kernel_store(__global float *out, uint i, real3 L, int accumulate) {
  float r = (float)L.x, g = (float)L.y, b = (float)L.z;
  if (accumulate) {
    r += out[3 * i];
    g += out[3 * i + 1];
    b += out[3 * i + 2];
  }
  out[3 * i] = GLINT_SATURATE_FLOAT(r);
  out[3 * i + 1] = GLINT_SATURATE_FLOAT(g);
  out[3 * i + 2] = GLINT_SATURATE_FLOAT(b);
}
#endif
#endif

#endif /* GLINT_KERNEL_ARGS_H */
