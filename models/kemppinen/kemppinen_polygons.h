/* Polygon lights for the Kemppinen glint model (K25 has point lights and
 * environment maps only), one query per work-item (clipping branches per
 * query): APPROXIMATION, the smooth area integral of the request's area
 * method times S = D_star / D (models/kemppinen/kemppinen_ndf.h) at the
 * half-vector of the polygon's centre direction. The expectation over uv is
 * exact away from the disk rim (E[S] = 1); the glint pattern of a large light
 * is that of its centre (one glint value per light instead of each facet's
 * lobe integrated over the light's image in U). Measured against per-direction
 * glints in models/kemppinen/tests/kemppinen_test.cpp. */
#ifndef GLINT_KEMPPINEN_POLYGONS_H
#define GLINT_KEMPPINEN_POLYGONS_H

#include "kernels/area/area_lights.h"
#include "kernels/area/polygon_lights.h"
#include "models/kemppinen/kemppinen_eval.h"

/* Polygon lights for query i, one query per work-item (clipping branches):
 * the APPROXIMATION in the header comment. */
GLINT_FN real3 kemppinen_polygons_query(EvalSpec spec, KernelInputs in, uint i) {
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  KemppinenParams p = kemppinen_params_unpack(in.params);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  real3 wo = sp.wo;
  if (!(wo.z > GLINT_R(0.0))) return radiance;
  real footprint[4];
  kemppinen_load_footprint(in, i, footprint);
  KemppinenFootprint fp = kemppinen_footprint(p, (real)in.uv[2 * i], (real)in.uv[2 * i + 1],
                                              footprint, in.seed_lo, in.seed_hi);
  uint area_key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                                 spec.has_frame ? in.position + 3 * i : 0);
  for (uint l = 0; l < in.n_polygon; ++l) {
    PolygonLight P = polygon_light(spec, in, sp, m, l, area_key);
    real3 ls = P.radiance;
    if (!(ls.x + ls.y + ls.z > GLINT_R(0.0))) continue;
    /* The centre direction: mean of the unit vertex directions. */
    real3 c = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
    for (int k = 0; k < P.n; ++k) c = r3_add(c, area_safe_normalize(P.v[k], P.v[k]));
    real3 up = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
    real3 wc = area_safe_normalize(c, up);
    real3 h = area_safe_normalize(r3_add(wc, wo), up);
    real D = ndf_D(m.ndf, h, m.alpha_x, m.alpha_y);
    radiance = r3_add(radiance,
                      r3_mul(ls, kemppinen_glint_factor(p, fp, m.ndf, h, m.alpha_x, m.alpha_y, D)));
  }
  return radiance;
}

#endif /* GLINT_KEMPPINEN_POLYGONS_H */
