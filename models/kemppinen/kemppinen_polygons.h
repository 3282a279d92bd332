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
  real alpha = sqrt(m.alpha_x * m.alpha_y);
  uint area_key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                                 spec.has_frame ? in.position + 3 * i : 0);
  for (uint l = 0; l < in.n_polygon; ++l) {
    const GLINT_GLOBAL float *rec = in.polygons + GLINT_POLYGON_FLOATS * l;
    real3 v[GLINT_POLYGON_MAX_VERTICES];
    int n = area_polygon_load(rec, spec.has_frame, sp.frame, sp.p, v);
    if (area_polygon_weight(v, n, rec[1] != 0.0f) == GLINT_R(0.0)) continue;
    real3 L = make_real3((real)rec[2], (real)rec[3], (real)rec[4]);
    real el[GLINT_LTC_ENTRY];
    real ff = area_ltc_form_factor(in.ltc_table, alpha, wo, v, n, el);
    real3 unit = in.area_method == GLINT_AREA_LTC
                     ? r3_scale(area_ltc_albedo(m, el), ff)
                     : area_polygon_integral(m, in.ltc_table, in.area_method, in.area_samples, wo,
                                             v, n, rng_absorb(area_key, l));
    real3 ls = r3_mul(unit, L);
    if (!(ls.x + ls.y + ls.z > GLINT_R(0.0))) continue;
    /* The centre direction: mean of the unit vertex directions. */
    real3 c = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
    for (int k = 0; k < n; ++k) c = r3_add(c, area_safe_normalize(v[k], v[k]));
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
