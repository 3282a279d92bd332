/* Entry point of the binomial glint model (models/binomial/binomial_eval.h). One query
 * per work-item (GLINT_LANES == 1): the counting loops and the polygon clipping
 * branch per query. Built with the smooth kernel's options (GLINT_NDF,
 * GLINT_FRESNEL, GLINT_HAS_FRAME, GLINT_HAS_DIRECTIONAL, GLINT_HAS_POINT,
 * GLINT_USE_DOUBLE), so light kinds the request lacks are compiled out. */
#include "models/binomial/binomial_eval.h"

__kernel void glint_binomial(uint n, __global const float *uv, __global const float *footprint,
                             __global const float *wo, __global const float *position,
                             __global const float *normal, __global const float *tangent,
                             __global const float *material, __global const float *binomial,
                             __global const float *directional, uint n_directional,
                             __global const float *point, uint n_point,
                             __global const float *polygons, uint n_polygon,
                             __global const float *ltc_table, int area_method, int area_samples,
                             uint seed_lo, uint seed_hi, __global float *out) {
  uint i = (uint)get_global_id(0);
  if (i >= n) return;
  EvalSpec spec;
  spec.ndf = GLINT_NDF;
  spec.fresnel = GLINT_FRESNEL;
  spec.probe = 0;
  spec.has_frame = GLINT_HAS_FRAME;
  spec.has_directional = GLINT_HAS_DIRECTIONAL;
  spec.has_point = GLINT_HAS_POINT;

  QueryArrays arrays;
  arrays.wo = wo;
  arrays.wi = wo; /* unused: no probes */
  arrays.position = position;
  arrays.normal = normal;
  arrays.tangent = tangent;
  BinomialQuery q;
  q.in = query_load(spec, arrays, i);
  q.u = (real)uv[2 * i];
  q.v = (real)uv[2 * i + 1];
  for (int k = 0; k < 4; ++k) q.footprint[k] = (real)footprint[4 * i + k];

  LightArrays lights;
  lights.directional = directional;
  lights.n_directional = n_directional;
  lights.point = point;
  lights.n_point = n_point;
  AreaInputs area;
  area.polygons = polygons;
  area.n_polygon = n_polygon;
  area.ltc_table = ltc_table;
  area.area_method = area_method;
  area.area_samples = area_samples;

  SmoothMaterial m = smooth_material_unpack(material, GLINT_NDF, GLINT_FRESNEL);
  BinomialParams b = binomial_params_unpack(binomial);
  uint area_key =
      area_query_key(seed_lo, seed_hi, wo + 3 * i, GLINT_HAS_FRAME ? position + 3 * i : 0);
  real3 L = binomial_shade(spec, m, b, q, lights, area, seed_lo, seed_hi, area_key);
  out[3 * i] = (float)L.x;
  out[3 * i + 1] = (float)L.y;
  out[3 * i + 2] = (float)L.z;
}
