/* The Kemppinen model's packed parameter block (GLINT_MODEL_PARAM_FLOATS),
 * shared by its descriptor (kemppinen_model.cpp packs it, defaults applied)
 * and its kernels (kemppinen_ndf.h unpacks it): plain #defines, valid OpenCL C
 * and C++.
 *   [density K_P, microroughness alpha_star, filter_size f, neighbors k,
 *    anisotropy a, colour 0, colour 1, number of colours (0, 1, 2)]
 * with a colour packed as r + 256 g + 65536 b, 8 bits per channel. */
#ifndef GLINT_KEMPPINEN_PARAMS_H
#define GLINT_KEMPPINEN_PARAMS_H

#define GLINT_KEMPPINEN_FLOATS 8

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
