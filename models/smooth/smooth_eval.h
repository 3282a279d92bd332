/* Per-query evaluation of the smooth model: one function shared by the
 * OpenCL entry point (models/smooth/smooth.cl) and the host scalar path
 * (server/host_path.cpp). On the device every field of EvalSpec is a
 * build-time constant, so the branches below fold away and only what the
 * request asked for is computed; the host passes the same values at run time.
 * Per-query conditions are selects (see compat.h), never branches. */
#ifndef GLINT_SMOOTH_EVAL_H
#define GLINT_SMOOTH_EVAL_H

#include "kernels/compat.h"
#include "kernels/frame.h"
#include "kernels/lights.h"
#include "kernels/smooth_brdf.h"

typedef struct {
  int ndf;             /* GLINT_NDF_* */
  int fresnel;         /* GLINT_FRESNEL_* */
  int probe;           /* queries carry wi: return f cos_i, no lights */
  int has_frame;       /* queries carry world position / normal / tangent */
  int has_directional; /* request has directional lights */
  int has_point;       /* request has point lights */
} EvalSpec;

typedef struct {
  const GLINT_GLOBAL float *wo;       /* 3 per query */
  const GLINT_GLOBAL float *wi;       /* 3 per query, probes only */
  const GLINT_GLOBAL float *position; /* 3 per query, framed only */
  const GLINT_GLOBAL float *normal;
  const GLINT_GLOBAL float *tangent;
} QueryArrays;

typedef struct {
  const GLINT_GLOBAL float *directional; /* GLINT_LIGHT_FLOATS per light */
  uint n_directional;
  const GLINT_GLOBAL float *point;
  uint n_point;
} LightArrays;

/* One query's inputs as real3: directions (wo, and wi for probes) and, for
 * framed queries, the world position, normal and tangent. Fields the spec does
 * not use are ignored. On the device (GLINT_LANES > 1) each field holds a
 * block of queries, loaded by kernels/smooth.cl. */
typedef struct {
  real3 wo;
  real3 wi;
  real3 position;
  real3 normal;
  real3 tangent;
} QueryInputs;

GLINT_FN real3 query_load3(const GLINT_GLOBAL float *a, uint i) {
  return make_real3((real)a[3 * i], (real)a[3 * i + 1], (real)a[3 * i + 2]);
}

/* Query i of the arrays (host path; the device loads blocks itself). */
GLINT_FN QueryInputs query_load(EvalSpec spec, QueryArrays q, uint i) {
  QueryInputs in;
  real3 zero = make_real3(R(0.0), R(0.0), R(0.0));
  in.wo = query_load3(q.wo, i);
  in.wi = zero;
  in.position = zero;
  in.normal = zero;
  in.tangent = zero;
  if (spec.probe) in.wi = query_load3(q.wi, i);
  if (spec.has_frame) {
    in.position = query_load3(q.position, i);
    in.normal = query_load3(q.normal, i);
    in.tangent = query_load3(q.tangent, i);
  }
  return in;
}

/* Reflected radiance towards wo (RGB) for loaded query inputs. Branches here
 * depend only on the spec and the light counts, never on the query, so on
 * the device they are uniform (and mostly folded away at build time). */
GLINT_FN real3 smooth_shade(EvalSpec spec, SmoothMaterial m, QueryInputs in, LightArrays lights) {
  real3 zero = make_real3(R(0.0), R(0.0), R(0.0));
  real3 wo = r3_normalize(in.wo);
  real3 p = zero;
  ShadingFrame frame;
  frame.t = make_real3(R(1.0), R(0.0), R(0.0));
  frame.b = make_real3(R(0.0), R(1.0), R(0.0));
  frame.n = make_real3(R(0.0), R(0.0), R(1.0));
  if (spec.has_frame) {
    frame = frame_from_normal_tangent(in.normal, in.tangent);
    p = in.position;
    wo = frame_to_local(frame, wo);
  }
  if (spec.probe) {
    real3 wi = r3_normalize(in.wi);
    if (spec.has_frame) wi = frame_to_local(frame, wi);
    return smooth_reflect_cos(m, wi, wo);
  }

  real3 radiance = zero;
  if (spec.has_directional) {
    for (uint l = 0; l < lights.n_directional; ++l) {
      const GLINT_GLOBAL float *rec = lights.directional + GLINT_LIGHT_FLOATS * l;
      real3 wi = directional_light_dir(rec);
      if (spec.has_frame) wi = frame_to_local(frame, wi);
      radiance = r3_add(radiance, r3_mul(smooth_reflect_cos(m, wi, wo),
                                         directional_light_irradiance(rec)));
    }
  }
  if (spec.has_point) {
    for (uint l = 0; l < lights.n_point; ++l) {
      const GLINT_GLOBAL float *rec = lights.point + GLINT_LIGHT_FLOATS * l;
      real3 E;
      real3 wi = point_light_dir(rec, p, &E);
      if (spec.has_frame) wi = frame_to_local(frame, wi);
      radiance = r3_add(radiance, r3_mul(smooth_reflect_cos(m, wi, wo), E));
    }
  }
  return radiance;
}

/* Reflected radiance towards wo for query i (RGB): the host path's entry. */
GLINT_FN real3 smooth_shade_query(EvalSpec spec, SmoothMaterial m, QueryArrays q, LightArrays lights,
                                  uint i) {
  return smooth_shade(spec, m, query_load(spec, q, i), lights);
}

#endif /* GLINT_SMOOTH_EVAL_H */
