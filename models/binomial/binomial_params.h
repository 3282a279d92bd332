/* The binomial model's packed parameter block (GLINT_MODEL_PARAM_FLOATS),
 * shared by its descriptor (binomial_model.cpp packs it) and its kernels
 * (binomial_count.h unpacks it): plain #defines, valid OpenCL C and C++.
 *   [density, p_mode, r, normal_threshold, slope_cell, interpolation, 0, 0] */
#ifndef GLINT_BINOMIAL_PARAMS_H
#define GLINT_BINOMIAL_PARAMS_H

#define GLINT_BINOMIAL_FLOATS 8
/* p_mode (= glint.v1.ReflectionProbability). */
#define GLINT_P_MODE_AREA 1
#define GLINT_P_MODE_HEURISTIC_R 2
/* footprint interpolation (glint.v1.FootprintInterpolation, packed as 0 / 1 / 2). */
#define GLINT_BINOMIAL_TRILINEAR 0
#define GLINT_BINOMIAL_TETRAHEDRAL 1
#define GLINT_BINOMIAL_STOCHASTIC 2

/* What 0 (unset) means for the optional fields. */
#define GLINT_BINOMIAL_DEFAULT_NORMAL_THRESHOLD 9.0f
#define GLINT_BINOMIAL_DEFAULT_SLOPE_CELL 0.05f

#endif /* GLINT_BINOMIAL_PARAMS_H */
