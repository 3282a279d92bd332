/* Entry point for polygon lights on the smooth model (kernels/area/area_lights.h).
 * One query per work-item (GLINT_LANES == 1): horizon clipping and the
 * REFERENCE quadrature branch per query, which the 8-lane SIMD kernel
 * (smooth.cl) cannot do. Built with the same GLINT_NDF, GLINT_FRESNEL,
 * GLINT_HAS_FRAME and GLINT_USE_DOUBLE options as smooth.cl; evaluates only
 * the polygon lights. With `accumulate`, adds to `out` (which already holds
 * the other light kinds' radiance from glint_smooth) instead of writing it. */
#include "kernels/area/area_lights.h"

__kernel void glint_smooth_area(uint n, __global const float *wo, __global const float *position,
                                __global const float *normal, __global const float *tangent,
                                __global const float *material, __global const float *polygons,
                                uint n_polygon, __global const float *ltc_table, int method,
                                int samples, uint seed_lo, uint seed_hi, int accumulate,
                                __global float *out) {
  uint i = (uint)get_global_id(0);
  if (i >= n) return;
  real3 zero = make_real3(R(0.0), R(0.0), R(0.0));
  real3 pos = zero, nrm = zero, tan = zero;
  if (GLINT_HAS_FRAME) {
    pos = make_real3((real)position[3 * i], (real)position[3 * i + 1], (real)position[3 * i + 2]);
    nrm = make_real3((real)normal[3 * i], (real)normal[3 * i + 1], (real)normal[3 * i + 2]);
    tan = make_real3((real)tangent[3 * i], (real)tangent[3 * i + 1], (real)tangent[3 * i + 2]);
  }
  real3 w = make_real3((real)wo[3 * i], (real)wo[3 * i + 1], (real)wo[3 * i + 2]);
  SmoothMaterial m = smooth_material_unpack(material, GLINT_NDF, GLINT_FRESNEL);
  uint key = area_query_key(seed_lo, seed_hi, wo + 3 * i, GLINT_HAS_FRAME ? position + 3 * i : 0);
  real3 L = area_shade_inputs(m, ltc_table, method, samples, GLINT_HAS_FRAME, w, pos, nrm, tan,
                              polygons, n_polygon, key);
  /* Sum in float, as the host path does (server/host_path_impl.inc). */
  float r = (float)L.x, g = (float)L.y, b = (float)L.z;
  if (accumulate) {
    r += out[3 * i];
    g += out[3 * i + 1];
    b += out[3 * i + 2];
  }
  out[3 * i] = r;
  out[3 * i + 1] = g;
  out[3 * i + 2] = b;
}
