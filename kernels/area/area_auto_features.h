/* What the AUTO area method (kernels/area/area_auto.h) knows about one polygon
 * light seen from one query before it integrates anything: the cell of its
 * error table (models/smooth/area_auto_table.h). Shared by the kernels and the
 * tool that fits the table (tools/area_auto/), so both bin identically.
 *
 * Features, chosen because the methods' errors depend on them (bench_area's
 * per-band errors and its worst cases, docs/area_speed_accuracy.csv):
 *  - alpha = sqrt(alpha_x alpha_y) (the LTC tables' isotropic lookup): the lobe
 *    width; every method's error grows as it narrows;
 *  - view theta_o: LTC's fit and REFERENCE's nodes degrade at grazing views;
 *    the last bin, 85 deg to the horizon, is where REFERENCE's 4-8 nodes miss
 *    the streak a lobe makes along the horizon and LECOCQ's sub-splitting
 *    (area_lecocq.h lecocq_subsplit) works hardest: pooled with 70-85 deg, its
 *    few training queries were outvoted and AUTO exceeded the budget there;
 *  - the solid angle Omega of the light clipped to the horizon: REFERENCE's
 *    nodes spread over it, MONTE_CARLO's light sampling wastes samples on big
 *    lights and its lobe sampling misses small ones;
 *  - the elevation of the light's centre direction: lights at the horizon are
 *    clipped, where LTC leaks and the lobe is cut;
 *  - alignment u = (angle(mirror direction of wo, light centre) - angular
 *    radius of the light) / alpha: u <= 0 the lobe's peak is inside the light;
 *    u >> 1 only the lobe's tail reaches it and the integral is small, so
 *    relative errors of every approximation are largest.
 * The NDF is the table's outer index. Bin edges below; GLINT_LANES == 1. */
#ifndef GLINT_AREA_AUTO_FEATURES_H
#define GLINT_AREA_AUTO_FEATURES_H

#include "kernels/area/polygon.h"
#include "kernels/area/spherical_triangle.h"
#include "kernels/compat.h"

#define GLINT_AUTO_ALPHA_BINS 6     /* edges 0.02, 0.05, 0.12, 0.3, 0.6 */
#define GLINT_AUTO_VIEW_BINS 4      /* theta_o edges 40, 70, 85 deg */
#define GLINT_AUTO_OMEGA_BINS 4     /* Omega edges 0.02, 0.2, 1.5 sr */
#define GLINT_AUTO_ELEVATION_BINS 2 /* centre elevation edge 25 deg */
#define GLINT_AUTO_ALIGN_BINS 3     /* u edges 0, 2.5 */
#define GLINT_AUTO_CELLS                                                  \
  (GLINT_AUTO_ALPHA_BINS * GLINT_AUTO_VIEW_BINS * GLINT_AUTO_OMEGA_BINS * \
   GLINT_AUTO_ELEVATION_BINS * GLINT_AUTO_ALIGN_BINS)

/* Index of the first edge above x among `n` ascending edges (0..n). */
GLINT_FN int area_auto_bin(real x, real e0, real e1, real e2, real e3, real e4, int n) {
  int b = 0;
  b += (n > 0) & (x >= e0);
  b += (n > 1) & (x >= e1);
  b += (n > 2) & (x >= e2);
  b += (n > 3) & (x >= e3);
  b += (n > 4) & (x >= e4);
  return b;
}

/* The table cell (0 .. GLINT_AUTO_CELLS - 1) of a light (vertices v[0..n-1]
 * relative to the shading point, local frame) seen along the local wo, or -1
 * when nothing of it is above the horizon or wo is below it (every method
 * returns 0 then). */
GLINT_FN int area_auto_cell(real alpha, real3 wo, const GLINT_PRIVATE real3 *v, int n) {
  if (!(wo.z > GLINT_R(0.0))) return -1;
  real3 c[GLINT_POLYGON_MAX_CLIPPED];
  int nc = polygon_clip_to_horizon(v, n, c);
  if (nc < 3) return -1;
  real omega = GLINT_R(0.0);
  for (int i = 1; i + 1 < nc; ++i) omega += spherical_triangle_solid_angle(c[0], c[i], c[i + 1]);
  if (!(omega > GLINT_R(0.0)) || !isfinite(omega)) return -1;
  /* Centre direction: the mean of the unit vertex directions (clipping
   * duplicates weigh a little more; this only bins). */
  real3 centre = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  for (int i = 0; i < nc; ++i) {
    real l = r3_length(c[i]);
    if (l > GLINT_R(0.0)) centre = r3_add(centre, r3_div(c[i], l));
  }
  real lc = r3_length(centre);
  centre =
      lc > GLINT_R(0.0) ? r3_div(centre, lc) : make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(1.0));
  real3 mirror = make_real3(-wo.x, -wo.y, wo.z);
  real angle = acos(clamp(r3_dot(r3_normalize(mirror), centre), GLINT_R(-1.0), GLINT_R(1.0)));
  /* The angular radius of a cap of solid angle omega: 2 pi (1 - cos rho) = omega. */
  real radius =
      acos(clamp(GLINT_R(1.0) - omega / GLINT_R(6.283185307179586), GLINT_R(-1.0), GLINT_R(1.0)));
  real u = (angle - radius) / fmax(alpha, GLINT_R(0.02));
  int ba = area_auto_bin(alpha, GLINT_R(0.02), GLINT_R(0.05), GLINT_R(0.12), GLINT_R(0.3),
                         GLINT_R(0.6), 5);
  /* theta_o >= 40 deg <=> wo.z <= cos 40; counted as "above the edge" by -wo.z. */
  int bv = area_auto_bin(-wo.z, GLINT_R(-0.766044443118978), GLINT_R(-0.342020143325669),
                         GLINT_R(-0.0871557427476582), GLINT_R(0.0), GLINT_R(0.0), 3);
  int bo = area_auto_bin(omega, GLINT_R(0.02), GLINT_R(0.2), GLINT_R(1.5), GLINT_R(0.0),
                         GLINT_R(0.0), 3);
  int be = area_auto_bin(centre.z, GLINT_R(0.422618261740699), GLINT_R(0.0), GLINT_R(0.0),
                         GLINT_R(0.0), GLINT_R(0.0), 1);
  int bu =
      area_auto_bin(u, GLINT_R(0.0), GLINT_R(2.5), GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0), 2);
  return (((ba * GLINT_AUTO_VIEW_BINS + bv) * GLINT_AUTO_OMEGA_BINS + bo) *
              GLINT_AUTO_ELEVATION_BINS +
          be) *
             GLINT_AUTO_ALIGN_BINS +
         bu;
}

#endif /* GLINT_AREA_AUTO_FEATURES_H */
