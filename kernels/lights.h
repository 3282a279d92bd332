/* Light records as the host packs them (one float block per light kind) and
 * the irradiance each delivers at a shading point. Units: directional lights
 * carry irradiance E [W/m^2] on a surface facing them; point lights carry
 * intensity I [W/sr], irradiance I/d^2 at normal incidence. */
#ifndef GLINT_LIGHTS_H
#define GLINT_LIGHTS_H

#include "kernels/compat.h"
#include "kernels/layout.h"

/* Records: kernels/layout.h (GLINT_LIGHT_FLOATS). The directional cone's solid
 * angle is 2 pi (1 - cos gamma), computed on the host in double. */

GLINT_FN real3 light_load3(const GLINT_GLOBAL float *rec, int offset) {
  return make_real3((real)rec[offset], (real)rec[offset + 1], (real)rec[offset + 2]);
}

/* Direction (world or local, as given) towards a directional light. */
GLINT_FN real3 directional_light_dir(const GLINT_GLOBAL float *rec) {
  return r3_normalize(light_load3(rec, 0));
}

GLINT_FN real3 directional_light_irradiance(const GLINT_GLOBAL float *rec) {
  return light_load3(rec, 3);
}

/* The largest finite `real` (a function, not a macro: tests include this
 * header once per precision). */
GLINT_FN real lights_real_max(void) {
#if GLINT_USE_DOUBLE
  return GLINT_R(1.7976931348623157e308);
#else
  return GLINT_R(3.40282346638528859812e38);
#endif
}

/* Unit direction from `p` to a point light and its normal-incidence
 * irradiance I / d^2. A light at the shading point (d = 0) contributes
 * nothing rather than infinity. I / d^2 saturates at the largest finite real
 * instead of overflowing to +Inf (fp32: I = 3e38 at d < 1): a light behind the
 * surface has f = 0, and 0 x Inf made the radiance NaN (issue 8). The sum may
 * still overflow; the kernels saturate the output (GLINT_SATURATE_FLOAT, kernels/kernel_args.h). */
GLINT_FN real3 point_light_dir(const GLINT_GLOBAL float *rec, real3 p,
                               GLINT_PRIVATE real3 *irradiance) {
  real3 d = r3_sub(light_load3(rec, 0), p);
  real d2 = r3_dot(d, d);
  glint_mask at_light = !(d2 > GLINT_R(0.0));
  real d2_safe = glint_select(d2, GLINT_R(1.0), at_light); /* keeps dead lanes finite */
  real3 e = r3_div(light_load3(rec, 3), d2_safe);
  const real e_max = lights_real_max();
  e = make_real3(fmin(e.x, e_max), fmin(e.y, e_max), fmin(e.z, e_max));
  *irradiance = r3_select(e, make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0)), at_light);
  return r3_select(r3_div(d, sqrt(d2_safe)), make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0)),
                   at_light);
}

#endif /* GLINT_LIGHTS_H */
