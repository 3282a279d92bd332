// The output contract's last step: radiance is returned as float, and a result beyond the float
// range (which only extreme light magnitudes at extreme geometry reach, e.g. intensity 3e38 W/sr
// at 1e-6 m, or an fp64 result above 3.4e38) saturates at FLT_MAX instead of +Inf, so every
// accepted request gets finite output (issue 8). NaN is left as it is: it would be a kernel bug,
// and the stability sweep (tests/service/stability_sweep_test.cpp) must still see it.
#pragma once

#include <cstddef>
#include <limits>

namespace glint {

inline void SaturateRadiance(float *rgb, size_t n_floats) {
  constexpr float kMax = std::numeric_limits<float>::max();
  for (size_t i = 0; i < n_floats; ++i)
    if (rgb[i] > kMax) rgb[i] = kMax;  // +Inf only; false for NaN
}

}  // namespace glint
