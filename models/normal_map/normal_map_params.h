/* The NORMAL_MAP model's (Yan et al. 2014) constants, packed parameter block
 * and per-map table layout, shared by its descriptor (normal_map_model.cpp),
 * the table builder (normal_map_table.cpp, run by the server's normal-map store
 * on upload) and its kernels (normal_map_pndf.h): plain #defines, valid OpenCL C
 * and C++.
 *
 * Parameter block (GLINT_MODEL_PARAM_FLOATS):
 *   [sigma_r, cutoff_sigma, subdivision, 0...] */
#ifndef GLINT_NORMAL_MAP_PARAMS_H
#define GLINT_NORMAL_MAP_PARAMS_H

#define GLINT_NM_DEFAULT_SIGMA_R 0.01f
#define GLINT_NM_DEFAULT_CUTOFF 5.0f
#define GLINT_NM_MIN_SIGMA_R 1e-4f
#define GLINT_NM_MAX_SIGMA_R 0.5f
#define GLINT_NM_MIN_CUTOFF 2.0f
#define GLINT_NM_MAX_CUTOFF 10.0f

/* The Gaussian pixel filter G_p has a standard deviation of GLINT_NM_PIXEL_SIGMA
 * pixels: its uv covariance is GLINT_NM_PIXEL_SIGMA^2 J J^T for the footprint
 * Jacobian J (du/dx, dv/dx; du/dy, dv/dy). */
#define GLINT_NM_PIXEL_SIGMA 0.5f
/* Smallest footprint standard deviation in vertex spacings: a zero footprint
 * becomes this (almost a point lookup), so the Gaussian stays proper. */
#define GLINT_NM_MIN_FOOTPRINT_SIGMA 0.01f
/* A footprint whose cut-off box is wider than this many map periods is shrunk to
 * it: the map tiles uv space and each period copy is one traversal. */
#define GLINT_NM_MAX_PERIODS 2.0f

/* ---- Table (Model::request_table), one per (map, subdivision) ----
 * header[GLINT_NM_HEADER_FLOATS] = [W, H, levels, subdivision, 0, 0, 0, 0]
 *   W x H vertices: vertex (i, j) is the normal at uv ((i + 0.5) / W, (j + 0.5) / H)
 *   (texel centres; with subdivision 4 the 4x up-sampled grid), periodic. Cell
 *   (i, j) lies between vertices (i, j) and (i + 1, j + 1) (indices mod W, H) and
 *   is split into two triangles on which (s, t) is linear (Yan et al. 2014 Sec. 5).
 * vertices: 2 floats (s, t) per vertex, row-major (j * W + i), from the header on.
 * min-max quadtree (Sec. 6): level k = 1 .. levels - 1; a level-k node (x, y)
 *   covers cells [x 2^k, (x + 1) 2^k) x [y 2^k, (y + 1) 2^k) clipped to the map;
 *   level k has ceil(W / 2^k) x ceil(H / 2^k) nodes of 4 floats
 *   (s_min, s_max, t_min, t_max over the vertices of its cells, row-major), stored
 *   level after level; the top level (levels - 1) is one node. Level 0 (the
 *   cells) is not stored: a cell's bounds are its 4 vertices. */
#define GLINT_NM_HEADER_FLOATS 8
/* Largest W or H after subdivision: indices stay exact in float (2^24). */
#define GLINT_NM_MAX_SIDE 16777216u
/* levels <= 25 for W, H <= 2^24 (the top node covers 2^24 cells). */
#define GLINT_NM_MAX_LEVELS 25
/* The traversal's stack (normal_map_pndf.h): popping a level-k node pushes at
 * most 4 level-(k-1) nodes; when the 4 children of the node popped at level k
 * are pushed, at most 3 siblings of each ancestor level remain. So the stack
 * never holds more than 3 (levels - 2) + 4 <= 3 GLINT_NM_MAX_LEVELS + 1 entries
 * (only levels >= 1 are pushed). */
#define GLINT_NM_STACK (3 * GLINT_NM_MAX_LEVELS + 1)

#endif /* GLINT_NORMAL_MAP_PARAMS_H */
