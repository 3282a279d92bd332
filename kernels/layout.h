/* The numbers host and device must agree on, in one place: enum values the
 * kernels are specialised by (build options GLINT_NDF, GLINT_FRESNEL) and the
 * area-method switch, and the layouts of the float records the host packs
 * (server/eval_plan.cpp) and the kernels read. Plain #defines, so the header is
 * valid OpenCL C and C++ and host code can include it outside any namespace.
 * Model-specific parameter layouts live with their model (models/<name>/). */
#ifndef GLINT_LAYOUT_H
#define GLINT_LAYOUT_H

/* Normal distribution (= glint.v1.Ndf). */
#define GLINT_NDF_GGX 1
#define GLINT_NDF_BECKMANN 2

/* Fresnel kind (the glint.v1.Material `fresnel` oneof). */
#define GLINT_FRESNEL_SCHLICK 1
#define GLINT_FRESNEL_CONDUCTOR 2
#define GLINT_FRESNEL_DIELECTRIC 3

/* Polygon-light integration (= glint.v1.AreaMethod; UNSPECIFIED -> LTC). */
#define GLINT_AREA_LTC 1
#define GLINT_AREA_LECOCQ 2
#define GLINT_AREA_LECOCQ_PEARSON 3
#define GLINT_AREA_MONTE_CARLO 4
#define GLINT_AREA_REFERENCE 5
/* Per query and light, one of the above chosen for an error budget (kernels/area/area_auto.h). */
#define GLINT_AREA_AUTO 6

/* Material block: [alpha_x, alpha_y, a.rgb, b.rgb] with (a, b) = Schlick
 * (f0, 0), conductor (eta, k) or dielectric (ior x 3, 0). */
#define GLINT_MATERIAL_FLOATS 8
/* A model's own parameter block (models/<name>/), zero-padded: 32 floats for the
 * largest, CHERMAIN's 8 parameters and colour table of 8 RGB colours. */
#define GLINT_MODEL_PARAM_FLOATS 32

/* Directional light: [dir.xyz (towards the light), E.rgb, cone solid angle, 0].
 * Point light:       [pos.xyz, I.rgb, radius, 0]. */
#define GLINT_LIGHT_FLOATS 8

/* Polygon light: [n_vertices, two_sided, L.rgb, 0, 0, 0, x0, y0, z0, ..., x15, y15, z15]. */
#define GLINT_POLYGON_MAX_VERTICES 16
#define GLINT_POLYGON_VERTEX_OFFSET 8
#define GLINT_POLYGON_FLOATS (GLINT_POLYGON_VERTEX_OFFSET + 3 * GLINT_POLYGON_MAX_VERTICES)

/* LTC tables (data/ltc/): GLINT_LTC_GRID^2 entries of GLINT_LTC_ENTRY floats. */
#define GLINT_LTC_GRID 64
#define GLINT_LTC_ENTRY 8

#endif /* GLINT_LAYOUT_H */
