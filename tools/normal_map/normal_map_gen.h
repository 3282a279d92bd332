// Normal-map generators for the material families of Yan et al. 2014 (Sec. 7, Fig. 10), used by
// `glint normal-map` and the tests: tangent-space unit normals (z >= 0) of a periodic size x size
// map, deterministic from the seed (a 64-bit Mersenne Twister, whose sequence the C++ standard
// fixes, with our own uniform and normal transforms).
//  - bumpy:     isotropic Gaussian-spectrum heightfield, random phase, inverse FFT ("Snail").
//  - flakes:    Poisson-disk Voronoi cells, each with one normal drawn from Beckmann
//               ("Metallic paint": no interpolation is needed or desirable).
//  - brushed:   anisotropic Gaussian spectrum, long along u, short along v ("Blender" lid).
//  - scratches: straight grooves of random direction, length and depth plus round dents
//               ("Cutlery": scratched metal with dents).
#pragma once

#include <cstdint>
#include <string>

#include "server/normal_map_decode.h"

namespace glint::normal_map_gen {

struct Options {
  std::string kind;     // bumpy | flakes | brushed | scratches
  uint32_t size = 512;  // bumpy and brushed: a power of two (FFT)
  uint64_t seed = 1;
  // RMS slope of the heightfields (bumpy, brushed) / Beckmann alpha of the flakes.
  double roughness = 0.2;
};

// Fills `out` or returns false with the reason in `error`.
bool Generate(const Options &options, DecodedNormalMap *out, std::string *error);

}  // namespace glint::normal_map_gen
