/* The Kemppinen model's packed parameter block (GLINT_MODEL_PARAM_FLOATS),
 * shared by its descriptor (kemppinen_model.cpp packs it, defaults applied)
 * and its kernels (kemppinen_ndf.h unpacks it): plain #defines, valid OpenCL C
 * and C++. Offsets (floats):
 *   0 density K_P, 1 microroughness alpha_star, 2 filter_size f,
 *   3 neighbors k, 4 anisotropy a, 5 number of colours n (0 = white),
 *   6 neighbourhood (GLINT_KEMPPINEN_NEIGHBORHOOD_*), 7 unused (0),
 *   8 + 3 c .. 10 + 3 c colour c's r, g, b (c < n <= 8). */
#ifndef GLINT_KEMPPINEN_PARAMS_H
#define GLINT_KEMPPINEN_PARAMS_H

#define GLINT_KEMPPINEN_DENSITY 0
#define GLINT_KEMPPINEN_MICRO 1
#define GLINT_KEMPPINEN_FILTER 2
#define GLINT_KEMPPINEN_NEIGHBORS 3
#define GLINT_KEMPPINEN_ANISO 4
#define GLINT_KEMPPINEN_N_COLORS 5
#define GLINT_KEMPPINEN_NEIGHBORHOOD 6
#define GLINT_KEMPPINEN_COLORS 8
/* Per-glint colours (K25 3.3.6): up to 8 RGB triples. */
#define GLINT_KEMPPINEN_MAX_COLORS 8
#define GLINT_KEMPPINEN_FLOATS (GLINT_KEMPPINEN_COLORS + 3 * GLINT_KEMPPINEN_MAX_COLORS)

/* The neighbourhood of facets a query evaluates (glint.v1.KemppinenNeighborhood;
 * models/kemppinen/kemppinen_ndf.h kemppinen_query_levels): the paper's (two MIP levels blended by
 * the roulette, 2x2 spatial cells), one dithered MIP level with 2x2 spatial
 * cells, or one dithered level and the one spatial cell holding the query. */
#define GLINT_KEMPPINEN_NEIGHBORHOOD_PAPER 0
#define GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_LEVEL 1
#define GLINT_KEMPPINEN_NEIGHBORHOOD_ONE_CELL 2

/* What 0 (unset) means for the optional fields (glint.v1.KemppinenParams). */
#define GLINT_KEMPPINEN_DEFAULT_MICROROUGHNESS 0.02f
#define GLINT_KEMPPINEN_DEFAULT_FILTER_SIZE 0.7f
#define GLINT_KEMPPINEN_DEFAULT_NEIGHBORS 4
#define GLINT_KEMPPINEN_DEFAULT_ANISOTROPY 1.0f

/* Finest angular level: res_a = 2^l <= 2^24 keeps cell indices exact in a
 * float's 24-bit mantissa. Footprints that would need coarser spatial cells
 * (huge footprints at high density) stay at this level; the spatial part of
 * the compensation then accounts for the points outside the explicit block. */
#define GLINT_KEMPPINEN_MAX_LEVEL 24

#endif /* GLINT_KEMPPINEN_PARAMS_H */
