/* One polygon light seen from a shading point, for the models that shade
 * polygon lights one at a time (the glint models scale each light's smooth
 * radiance by their own factor): its vertices in the local frame, whether it
 * faces the point, the smooth radiance from it by the request's area method,
 * and the LTC lobe's integral over it with the table entry used (KK24's
 * reflection probability needs them). The smooth model's own polygon pass sums
 * all lights at once (area_shade_keyed in area_lights.h). */
#ifndef GLINT_POLYGON_LIGHTS_H
#define GLINT_POLYGON_LIGHTS_H

#include "kernels/area/area_lights.h"
#include "kernels/compat.h"
#include "kernels/kernel_args.h"
#include "kernels/query.h"
#include "kernels/smooth_brdf.h"

typedef struct {
  int n;                               /* vertices; 0 when the light does not face the point */
  real3 v[GLINT_POLYGON_MAX_VERTICES]; /* relative to the shading point, local frame */
  real3 radiance;                      /* L_smooth from this light (RGB) */
  real form_factor;                    /* integral of the LTC lobe over the light */
  real ltc[GLINT_LTC_ENTRY];           /* the LTC entry at (sqrt(alpha_x alpha_y), wo.z) */
} PolygonLight;

/* Light l of the request; `area_key` from area_query_key seeds MONTE_CARLO. */
GLINT_FN PolygonLight polygon_light(EvalSpec spec, KernelInputs in, ShadingPoint sp,
                                    SmoothMaterial m, uint l, uint area_key) {
  const GLINT_GLOBAL float *rec = in.polygons + GLINT_POLYGON_FLOATS * l;
  PolygonLight P;
  P.radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  P.form_factor = GLINT_R(0.0);
  P.n = area_polygon_load(rec, spec.has_frame, sp.frame, sp.p, P.v);
  if (area_polygon_weight(P.v, P.n, rec[1] != 0.0f) == GLINT_R(0.0)) {
    P.n = 0;
    return P;
  }
  real alpha = sqrt(m.alpha_x * m.alpha_y);
  P.form_factor = area_ltc_form_factor(in.ltc_table, alpha, sp.wo, P.v, P.n, P.ltc);
  real3 unit = in.area_method == GLINT_AREA_LTC
                   ? r3_scale(area_ltc_albedo(m, P.ltc), P.form_factor)
                   : area_polygon_integral(m, in.ltc_table, in.area_method, in.area_samples, sp.wo,
                                           P.v, P.n, rng_absorb(area_key, l));
  P.radiance = r3_mul(unit, make_real3((real)rec[2], (real)rec[3], (real)rec[4]));
  return P;
}

#endif /* GLINT_POLYGON_LIGHTS_H */
