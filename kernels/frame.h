/* Local shading frame from a world-space normal and tangent (DESIGN.md
 * conventions): +z = normal, +x = tangent made orthogonal to the normal
 * (Gram-Schmidt), +y = z cross x, so (x, y, z) is right-handed. */
#ifndef GLINT_FRAME_H
#define GLINT_FRAME_H

#include "kernels/compat.h"

typedef struct {
  real3 t; /* local +x */
  real3 b; /* local +y */
  real3 n; /* local +z */
} ShadingFrame;

GLINT_FN ShadingFrame frame_from_normal_tangent(real3 normal, real3 tangent) {
  ShadingFrame f;
  f.n = r3_normalize(normal);
  /* Validation guarantees |t . n| < 1 - tolerance, so this cannot vanish. */
  f.t = r3_normalize(r3_sub(tangent, r3_scale(f.n, r3_dot(f.n, tangent))));
  f.b = r3_cross(f.n, f.t);
  return f;
}

/* The frame of queries that carry none: world space is the local frame. */
GLINT_FN ShadingFrame frame_identity(void) {
  ShadingFrame f;
  f.t = make_real3(GLINT_R(1.0), GLINT_R(0.0), GLINT_R(0.0));
  f.b = make_real3(GLINT_R(0.0), GLINT_R(1.0), GLINT_R(0.0));
  f.n = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  return f;
}

GLINT_FN real3 frame_to_local(ShadingFrame f, real3 v) {
  return make_real3(r3_dot(v, f.t), r3_dot(v, f.b), r3_dot(v, f.n));
}

#endif /* GLINT_FRAME_H */
