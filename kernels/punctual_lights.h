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

/* GLINT_SCALAR_LIGHTS (opt-in per kernel entry: models/kemppinen/kemppinen.cl,
 * models/smooth/smooth.cl): what a light
 * gives every lane of a block alike, computed once in scalars and then broadcast. On a 16-lane
 * device a directional light's normalisation, and without a frame a point light's direction
 * and I / d^2 (the shading point is then the origin for every lane), otherwise run as vector
 * square roots and divisions of broadcast values: LLVM does not narrow them to scalars (PoCL's
 * kernel: vsqrtps and 3 vdivps per light and block for the direction, 3 more for I / d^2), and
 * a 16-lane vdivps/vsqrtps occupies the divider ~10 cycles where the scalar one takes ~4. The
 * scalar operations are the same IEEE operations in the same order as each lane's
 * (r3_normalize, point_light_dir), so the result has the same bits. The smooth model's entry
 * takes it too since session 16 (issue 13), which makes SMOOTH's punctual kernel, the reference
 * of the KEMPPINEN ratio (issue 9), faster. Device only (the host's `real` is already a scalar). */
#if defined(GLINT_SCALAR_LIGHTS) && defined(__OPENCL_VERSION__) && GLINT_LANES > 1
#define GLINT_SCALAR_LIGHTS_ACTIVE 1
typedef real_scalar light_scalar; /* kernels/compat.h */
#if GLINT_USE_DOUBLE
#define GLINT_LIGHT_SCALAR_MAX 1.7976931348623157e308 /* lights_real_max */
#else
#define GLINT_LIGHT_SCALAR_MAX 3.40282346638528859812e38f
#endif

/* directional_light_dir in scalars. */
GLINT_FN real3 directional_light_dir_scalar(const GLINT_GLOBAL float *rec) {
  light_scalar x = (light_scalar)rec[0], y = (light_scalar)rec[1], z = (light_scalar)rec[2];
  light_scalar len = sqrt(x * x + y * y + z * z);
  return make_real3((real)(x / len), (real)(y / len), (real)(z / len));
}

/* point_light_dir for the shading point at the origin (queries without a frame), in scalars:
 * d = the light's position (position - 0 is the position exactly). */
GLINT_FN real3 point_light_dir_origin_scalar(const GLINT_GLOBAL float *rec,
                                             GLINT_PRIVATE real3 *irradiance) {
  light_scalar x = (light_scalar)rec[0], y = (light_scalar)rec[1], z = (light_scalar)rec[2];
  light_scalar d2 = x * x + y * y + z * z;
  if (!(d2 > (light_scalar)0.0)) {
    *irradiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
    return make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  }
  const light_scalar e_max = (light_scalar)GLINT_LIGHT_SCALAR_MAX;
  *irradiance = make_real3((real)fmin((light_scalar)rec[3] / d2, e_max),
                           (real)fmin((light_scalar)rec[4] / d2, e_max),
                           (real)fmin((light_scalar)rec[5] / d2, e_max));
  light_scalar d = sqrt(d2);
  return make_real3((real)(x / d), (real)(y / d), (real)(z / d));
}
#else
#define GLINT_SCALAR_LIGHTS_ACTIVE 0
#endif

GLINT_FN PunctualLight punctual_light(EvalSpec spec, KernelInputs in, ShadingPoint sp, uint l) {
  PunctualLight light;
  if (spec.has_directional && l < in.n_directional) {
    const GLINT_GLOBAL float *rec = in.directional + GLINT_LIGHT_FLOATS * l;
#if GLINT_SCALAR_LIGHTS_ACTIVE
    light.wi = shading_to_local(spec, sp, directional_light_dir_scalar(rec));
#else
    light.wi = shading_to_local(spec, sp, directional_light_dir(rec));
#endif
    light.irradiance = directional_light_irradiance(rec);
    light.solid_angle = (real)rec[6];
    light.kind = GLINT_LIGHT_KIND_DIRECTIONAL;
    light.index = l;
  } else {
    uint k = spec.has_directional ? l - in.n_directional : l;
    const GLINT_GLOBAL float *rec = in.point + GLINT_LIGHT_FLOATS * k;
    real3 E;
#if GLINT_SCALAR_LIGHTS_ACTIVE
    if (!spec.has_frame)
      light.wi = point_light_dir_origin_scalar(rec, &E); /* sp.p = 0 (kernels/query.h) */
    else
      light.wi = shading_to_local(spec, sp, point_light_dir(rec, sp.p, &E));
#else
    light.wi = shading_to_local(spec, sp, point_light_dir(rec, sp.p, &E));
#endif
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
