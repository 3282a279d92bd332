/* The smooth model under polygon lights, per query: the shared area-light
 * integrators (kernels/area/area_lights.h, the request's area_method) at the
 * query's shading point. One query per work-item (GLINT_LANES == 1): clipping
 * branches per query. Added to smooth_shade's result for the other light
 * kinds (the pass order in models/smooth/smooth_model.cpp). */
#ifndef GLINT_SMOOTH_POLYGONS_H
#define GLINT_SMOOTH_POLYGONS_H

#include "kernels/area/area_lights.h"
#include "kernels/compat.h"
#include "kernels/kernel_args.h"
#include "kernels/query.h"
#include "kernels/smooth_brdf.h"

GLINT_FN real3 smooth_polygons_query(EvalSpec spec, KernelInputs in, uint i) {
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  uint key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                            spec.has_frame ? in.position + 3 * i : 0);
  return area_shade_keyed(m, in.ltc_table, in.area_method, in.area_samples, sp.wo,
                          spec.has_frame, sp.frame, sp.p, in.polygons, in.n_polygon, key);
}

#endif /* GLINT_SMOOTH_POLYGONS_H */
