/* The Chermain et al. 2020 model's constants and packed parameter block
 * (GLINT_MODEL_PARAM_FLOATS), shared by its descriptor (chermain_model.cpp
 * packs it), its kernels (chermain_eval.h unpacks it) and the dictionary
 * generator (tools/chermain): plain #defines, valid OpenCL C and C++.
 *   [log_density, relative_area, density_randomisation, max_anisotropy,
 *    dictionary_size, n_colors, 0, 0, colour 0 rgb, colour 1 rgb, ..., colour 7 rgb] */
#ifndef GLINT_CHERMAIN_PARAMS_H
#define GLINT_CHERMAIN_PARAMS_H

#define GLINT_CHERMAIN_FLOATS 32
/* The colour table (Alg. 3 l. 11-12): up to 8 RGB colours from float 8 on. */
#define GLINT_CHERMAIN_MAX_COLORS 8
#define GLINT_CHERMAIN_COLOR_OFFSET 8

/* The dictionary (paper Sec. 4.4, 7.3): multiscale 1D marginals of nLevels
 * levels, each tabulated at GLINT_CHERMAIN_BINS nodes over
 * [0, 4 alpha_dict / sqrt(2)] (the marginals are even: only x >= 0 is stored),
 * converging to the Beckmann marginal of alpha_dict. Marginal m, level l,
 * node k is float ((m * LEVELS) + l) * BINS + k of the table. */
#define GLINT_CHERMAIN_LEVELS 16
#define GLINT_CHERMAIN_BINS 64
#define GLINT_CHERMAIN_ALPHA_DICT 0.5
#define GLINT_CHERMAIN_LOBE_SIGMA 0.02
/* 4 alpha_dict / sqrt(2): four standard deviations of the target marginal. */
#define GLINT_CHERMAIN_X_MAX 1.4142135623730951
/* The marginals shipped in data/chermain/ (a dictionary of size N uses the
 * first N: every marginal has its own random stream, so a smaller dictionary
 * is a prefix of a larger one). */
#define GLINT_CHERMAIN_MAX_DICTIONARY 512
#define GLINT_CHERMAIN_TABLE_FLOATS \
  (GLINT_CHERMAIN_MAX_DICTIONARY * GLINT_CHERMAIN_LEVELS * GLINT_CHERMAIN_BINS)

/* What 0 (unset) means for the optional fields. */
#define GLINT_CHERMAIN_DEFAULT_MAX_ANISOTROPY 8.0f
#define GLINT_CHERMAIN_DEFAULT_DICTIONARY_SIZE 192.0f
#define GLINT_CHERMAIN_DEFAULT_RELATIVE_AREA 1.0f

#endif /* GLINT_CHERMAIN_PARAMS_H */
