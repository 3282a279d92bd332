/* The smooth model under polygon lights, per query: the shared area-light
 * integrators (kernels/area/area_lights.h, the request's area_method) at the
 * query's shading point. Added to smooth_shade's result for the other light
 * kinds (the pass order in models/smooth/smooth_model.cpp). LTC, the default
 * method, is lane-safe (smooth_polygons_ltc, the 8-lane entry
 * smooth_area_lanes.cl); the others branch per query (smooth_polygons_query,
 * the one-query-per-work-item entry smooth_area.cl). */
#ifndef GLINT_SMOOTH_POLYGONS_H
#define GLINT_SMOOTH_POLYGONS_H

#include "kernels/area/area_ltc.h"
#include "kernels/compat.h"
#include "kernels/kernel_args.h"
#include "kernels/query.h"
#include "kernels/smooth_brdf.h"

/* LTC radiance from every polygon light for the queries q (one or a block of lanes). */
GLINT_FN real3 smooth_polygons_ltc(EvalSpec spec, KernelInputs in, QueryInputs q) {
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  ShadingPoint sp = shading_point(spec, q);
  return area_ltc_shade(m, in.ltc_table, sp.wo, spec.has_frame, sp.frame, sp.p, in.polygons,
                        in.n_polygon);
}

#if !defined(__OPENCL_VERSION__) || GLINT_LANES == 1
#include "kernels/area/area_lights.h"

GLINT_FN real3 smooth_polygons_query(EvalSpec spec, KernelInputs in, uint i) {
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  uint key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                            spec.has_frame ? in.position + 3 * i : 0);
  return area_shade_keyed(m, in.ltc_table, in.area_method, in.area_samples, sp.wo, spec.has_frame,
                          sp.frame, sp.p, in.polygons, in.n_polygon, key);
}
#endif

#endif /* GLINT_SMOOTH_POLYGONS_H */
