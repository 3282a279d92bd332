/* One query's inputs and its shading point: loading from the standard kernel
 * inputs (kernels/kernel_args.h) and building the local frame, written once
 * for every model and pass.
 *
 * Local frame (DESIGN.md conventions): with world position / normal / tangent
 * the frame is built from them (kernels/frame.h) and lights stay in world
 * space; without them world space is the local frame and the shading point is
 * the origin. */
#ifndef GLINT_QUERY_H
#define GLINT_QUERY_H

#include "kernels/compat.h"
#include "kernels/frame.h"
#include "kernels/kernel_args.h"

/* One query's inputs as real3. Fields the spec does not use are zero. On the
 * device with GLINT_LANES > 1 each field holds a block of queries (loaded by
 * kernels/simd_io.h); query_load reads one query. */
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

/* Query i's directions (and frame when the spec has one). */
GLINT_FN QueryInputs query_load(EvalSpec spec, KernelInputs in, uint i) {
  QueryInputs q;
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  q.wo = query_load3(in.wo, i);
  q.wi = zero;
  q.position = zero;
  q.normal = zero;
  q.tangent = zero;
  if (spec.probe) q.wi = query_load3(in.wi, i);
  if (spec.has_frame) {
    q.position = query_load3(in.position, i);
    q.normal = query_load3(in.normal, i);
    q.tangent = query_load3(in.tangent, i);
  }
  return q;
}

/* Where a query is shaded: its local frame, its position in the lights' space
 * (the origin without a frame) and the unit view direction in the local frame.
 * shading_point_unit takes q.wo already normalised (by the caller's choice of rounding). */
typedef struct {
  ShadingFrame frame;
  real3 p;
  real3 wo;
} ShadingPoint;

GLINT_FN ShadingPoint shading_point_unit(EvalSpec spec, QueryInputs q, real3 wo_unit) {
  ShadingPoint sp;
  sp.wo = wo_unit;
  sp.p = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  sp.frame = frame_identity();
  if (spec.has_frame) {
    sp.frame = frame_from_normal_tangent(q.normal, q.tangent);
    sp.p = q.position;
    sp.wo = frame_to_local(sp.frame, sp.wo);
  }
  return sp;
}

/* The shading point of q, its view direction q.wo normalised by r3_normalize (exact division). */
GLINT_FN ShadingPoint shading_point(EvalSpec spec, QueryInputs q) {
  return shading_point_unit(spec, q, r3_normalize(q.wo));
}

/* A direction of the lights' space (world, or local without a frame) in the local frame. */
GLINT_FN real3 shading_to_local(EvalSpec spec, ShadingPoint sp, real3 w) {
  return spec.has_frame ? frame_to_local(sp.frame, w) : w;
}

#endif /* GLINT_QUERY_H */
