/* The smooth model per query: f = F G2 D / (4 cos_i cos_o) (kernels/smooth_brdf.h)
 * under BRDF probes, directional and point lights (smooth_shade; the 16-lane
 * entry models/smooth/smooth.cl) and under polygon lights (smooth_polygons;
 * the one-query-per-work-item entry models/smooth/smooth_area.cl, because
 * clipping branches per query). The host path runs the same functions
 * (models/smooth/host_passes.cpp).
 *
 * Branches here depend only on the spec and the light counts, never on the
 * query, so on the device they are uniform (and mostly folded away at build
 * time); per-query conditions are selects (see compat.h). */
#ifndef GLINT_SMOOTH_EVAL_H
#define GLINT_SMOOTH_EVAL_H

#include "kernels/compat.h"
#include "kernels/kernel_args.h"
#include "kernels/punctual_lights.h"
#include "kernels/query.h"
#include "kernels/smooth_brdf.h"

/* Reflected radiance towards wo (RGB) from the probe direction or the
 * directional and point lights, for material m (smooth_shade below unpacks it from
 * in.material; the probe kernel passes the by-value copy, models/smooth/smooth.cl). */
GLINT_FN real3 smooth_shade_material(EvalSpec spec, KernelInputs in, SmoothMaterial m,
                                     QueryInputs q) {
  if (spec.probe) {
    /* Probes normalise both directions by a reciprocal square root each (no division: the
     * probe kernel is bound by its divider, which every division and square root of a 16-lane
     * block queues on, issue 13; kernels/compat.h glint_rsqrt_nn). Validation admits lengths
     * within 1e-3 of 1. */
    ShadingPoint sp =
        shading_point_unit(spec, q, r3_scale(q.wo, glint_rsqrt_nn(r3_dot(q.wo, q.wo))));
    real3 wi = shading_to_local(spec, sp, r3_scale(q.wi, glint_rsqrt_nn(r3_dot(q.wi, q.wi))));
    return smooth_reflect_cos(m, wi, sp.wo);
  }
  ShadingPoint sp = shading_point(spec, q);
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  uint n_lights = punctual_light_count(spec, in);
  /* What depends on wo alone (GGX's r_o, Beckmann's Lambda(wo)) once per query, not per light:
   * the same operations, the same bits (kernels/smooth_brdf.h smooth_view). */
  SmoothView view = smooth_view(m, sp.wo);
  for (uint l = 0; l < n_lights; ++l) {
    PunctualLight light = punctual_light(spec, in, sp, l);
    radiance =
        r3_add(radiance, r3_mul(smooth_reflect_cos_view(m, view, light.wi), light.irradiance));
  }
  return radiance;
}

GLINT_FN real3 smooth_shade(EvalSpec spec, KernelInputs in, QueryInputs q) {
  return smooth_shade_material(spec, in,
                               smooth_material_unpack(in.material, spec.ndf, spec.fresnel), q);
}

GLINT_FN real3 smooth_query(EvalSpec spec, KernelInputs in, uint i) {
  return smooth_shade(spec, in, query_load(spec, in, i));
}

#endif /* GLINT_SMOOTH_EVAL_H */
