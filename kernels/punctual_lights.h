/* Directional and point lights seen from a shading point, as one list: the
 * light loop every model runs (the smooth model shades them, the glint models
 * also need the solid angle each one subtends). Records: kernels/lights.h.
 *
 * Light l < n_directional is directional light l, the rest are the point
 * lights, in request order; kinds the spec lacks are compiled out on the
 * device. The branch on l is uniform across a work-item's lanes. */
#ifndef GLINT_PUNCTUAL_LIGHTS_H
#define GLINT_PUNCTUAL_LIGHTS_H

#include "kernels/compat.h"
#include "kernels/kernel_args.h"
#include "kernels/lights.h"
#include "kernels/query.h"

#define GLINT_LIGHT_KIND_DIRECTIONAL 1u
#define GLINT_LIGHT_KIND_POINT 2u

typedef struct {
  real3 wi;         /* unit direction towards the light, local frame */
  real3 irradiance; /* E on a surface facing the light (RGB) */
  real solid_angle; /* of the light's cone (directional) or sphere (point), 0 for a delta light */
  uint kind;        /* GLINT_LIGHT_KIND_* */
  uint index;       /* within its kind */
} PunctualLight;

GLINT_FN uint punctual_light_count(EvalSpec spec, KernelInputs in) {
  return (spec.has_directional ? in.n_directional : 0u) + (spec.has_point ? in.n_point : 0u);
}

/* Solid angle 2 pi (1 - cos gamma) of a cone with sin(gamma) = s, written as
 * 2 pi s^2 / (1 + cos gamma) so small cones do not cancel. */
GLINT_FN real cap_solid_angle(real s) {
  s = clamp(s, GLINT_R(0.0), GLINT_R(1.0));
  return GLINT_R(2.0) * GLINT_PI * s * s /
         (GLINT_R(1.0) + sqrt(fmax(GLINT_R(1.0) - s * s, GLINT_R(0.0))));
}

GLINT_FN PunctualLight punctual_light(EvalSpec spec, KernelInputs in, ShadingPoint sp, uint l) {
  PunctualLight light;
  if (spec.has_directional && l < in.n_directional) {
    const GLINT_GLOBAL float *rec = in.directional + GLINT_LIGHT_FLOATS * l;
    light.wi = shading_to_local(spec, sp, directional_light_dir(rec));
    light.irradiance = directional_light_irradiance(rec);
    light.solid_angle = (real)rec[6];
    light.kind = GLINT_LIGHT_KIND_DIRECTIONAL;
    light.index = l;
  } else {
    uint k = spec.has_directional ? l - in.n_directional : l;
    const GLINT_GLOBAL float *rec = in.point + GLINT_LIGHT_FLOATS * k;
    real3 E;
    light.wi = shading_to_local(spec, sp, point_light_dir(rec, sp.p, &E));
    light.irradiance = E;
    /* A sphere of radius r at distance d subtends a cap with sin(gamma) = r / d
     * (the whole sky from inside it). */
    real dist = r3_length(r3_sub(light_load3(rec, 0), sp.p));
    real radius = (real)rec[6];
    light.solid_angle = cap_solid_angle(glint_select(GLINT_R(1.0), radius / dist, dist > radius));
    light.kind = GLINT_LIGHT_KIND_POINT;
    light.index = k;
  }
  return light;
}

#endif /* GLINT_PUNCTUAL_LIGHTS_H */
