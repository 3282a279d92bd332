// Test support: normal-map files in memory (PNG through libpng's simplified writer, EXR through
// the preview's EXR writer), to feed the decoder and the store.
#pragma once

#include <png.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "client/preview/image_io.h"

namespace glint::test {

// An 8- or 16-bit RGB PNG of the normals xyz (3 per texel), c = round((n + 1) / 2 * max).
inline std::string PngBytes(uint32_t w, uint32_t h, const std::vector<float> &xyz, bool sixteen) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = w;
  image.height = h;
  image.format = sixteen ? PNG_FORMAT_LINEAR_RGB : PNG_FORMAT_RGB;
  const double max = sixteen ? 65535.0 : 255.0;
  std::vector<uint16_t> v16(xyz.size());
  std::vector<uint8_t> v8(xyz.size());
  for (size_t k = 0; k < xyz.size(); ++k) {
    const double c = std::round((double(xyz[k]) + 1.0) / 2.0 * max);
    v16[k] = uint16_t(c);
    v8[k] = uint8_t(std::fmin(c, 255.0));
  }
  const void *buffer = sixteen ? static_cast<const void *>(v16.data()) : v8.data();
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, buffer, 0, nullptr))
    throw std::runtime_error(image.message);
  std::string out(size, '\0');
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, buffer, 0, nullptr))
    throw std::runtime_error(image.message);
  out.resize(size);
  return out;
}

inline std::string ExrBytes(uint32_t w, uint32_t h, const std::vector<float> &xyz) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("glint_nm_" + std::to_string(::getpid()) + "_" +
                     std::to_string(reinterpret_cast<uintptr_t>(&xyz)) + ".exr");
  client::WriteExrRgb(path.string(), int(w), int(h), xyz, false);
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  std::filesystem::remove(path);
  return s.str();
}

// A w x h map of normals tilted by (sx, sy) plus a deterministic ripple of amplitude `ripple`.
inline std::vector<float> RippleNormals(uint32_t w, uint32_t h, double sx, double sy,
                                        double ripple) {
  std::vector<float> xyz(size_t(w) * h * 3);
  for (uint32_t j = 0; j < h; ++j)
    for (uint32_t i = 0; i < w; ++i) {
      const double s = sx + ripple * std::sin(6.283185307179586 * (i + 0.3 * j) / w);
      const double t = sy + ripple * std::cos(6.283185307179586 * (2 * j + 0.5 * i) / h);
      const double z = std::sqrt(std::fmax(0.0, 1.0 - s * s - t * t));
      float *n = &xyz[(size_t(j) * w + i) * 3];
      n[0] = float(s);
      n[1] = float(t);
      n[2] = float(z);
    }
  return xyz;
}

}  // namespace glint::test
