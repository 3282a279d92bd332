/* Entry point of the smooth model. Specialised by build options (see
 * server/kernel_spec.cpp): GLINT_NDF, GLINT_FRESNEL, GLINT_PROBE,
 * GLINT_HAS_FRAME, GLINT_HAS_DIRECTIONAL, GLINT_HAS_POINT, GLINT_USE_DOUBLE.
 * Inputs stay float on the wire and in buffers; `real` is the arithmetic. */
#include "smooth_eval.h"

__kernel void glint_smooth(uint n, __global const float *wo, __global const float *wi,
                           __global const float *position, __global const float *normal,
                           __global const float *tangent, __global const float *material,
                           __global const float *directional, uint n_directional,
                           __global const float *point, uint n_point, __global float *out) {
  uint i = get_global_id(0);
  if (i >= n) return; /* the global size is padded to a multiple of the local size */

  EvalSpec spec;
  spec.ndf = GLINT_NDF;
  spec.fresnel = GLINT_FRESNEL;
  spec.probe = GLINT_PROBE;
  spec.has_frame = GLINT_HAS_FRAME;
  spec.has_directional = GLINT_HAS_DIRECTIONAL;
  spec.has_point = GLINT_HAS_POINT;

  QueryArrays q;
  q.wo = wo;
  q.wi = wi;
  q.position = position;
  q.normal = normal;
  q.tangent = tangent;

  LightArrays lights;
  lights.directional = directional;
  lights.n_directional = n_directional;
  lights.point = point;
  lights.n_point = n_point;

  SmoothMaterial m = smooth_material_unpack(material, GLINT_NDF, GLINT_FRESNEL);
  real3 L = smooth_shade_query(spec, m, q, lights, i);
  out[3 * i + 0] = (float)L.x;
  out[3 * i + 1] = (float)L.y;
  out[3 * i + 2] = (float)L.z;
}
