// Image I/O for previews: float / half RGB OpenEXR and a tone-mapped 8-bit sRGB PNG, plus the
// scatter from per-query results back to pixels.
//
// Image layout everywhere: width * height * 3 floats, row-major, top row first (the layout
// of preview_scene.h's pixel indices).
#ifndef GLINT_CLIENT_PREVIEW_IMAGE_IO_H
#define GLINT_CLIENT_PREVIEW_IMAGE_IO_H

#include <cstdint>
#include <string>
#include <vector>

#include "client/preview/preview_scene.h"

namespace glint::client {

// Writes channels R, G, B (FLOAT, or HALF when half_float; ZIP compression, scanlines).
// rgb: width*height*3 floats, row-major, top row first. Throws std::runtime_error with the
// path on failure (including rgb.size() != width*height*3 or a non-positive size).
void WriteExrRgb(const std::string &path, int width, int height, const std::vector<float> &rgb,
                 bool half_float = false);

// Reads channels R, G, B of a scanline or tiled EXR as float (half is widened exactly), from
// the data window. Throws std::runtime_error with the path if the file cannot be read or lacks
// any of R, G, B.
std::vector<float> ReadExrRgb(const std::string &path, int *width, int *height);

// Tone-mapped 8-bit sRGB PNG: exposure scale 2^exposure_stops, then a per-channel extended
// Reinhard curve c (1 + c / W^2) / (1 + c) with white point W = kPngWhitePoint (c >= W maps to
// white; 0.18 maps to 0.154, 1 to 0.53), then the sRGB OETF. Negative values are drawn black.
// NaN/Inf pixels (any channel) are drawn magenta (255, 0, 255) so they are visible. Throws
// std::runtime_error with the path on failure.
inline constexpr float kPngWhitePoint = 4.0f;
void WritePngToneMapped(const std::string &path, int width, int height,
                        const std::vector<float> &rgb, float exposure_stops = 0.0f);

// The 8-bit sRGB bytes WritePngToneMapped stores (3 per pixel, same curve, NaN/Inf magenta),
// for callers that compose several images (contact_sheet.h).
std::vector<uint8_t> ToneMapToSrgb8(int width, int height, const std::vector<float> &rgb,
                                    float exposure_stops = 0.0f);

// Writes 8-bit RGB bytes (3 per pixel, row-major, top row first) as a PNG. Throws
// std::runtime_error with the path on failure.
void WritePngRgb8(const std::string &path, int width, int height,
                  const std::vector<uint8_t> &bytes);

// Scatters per-query RGB (3 * scene.queries.count() floats, in query order) into a
// scene.width x scene.height image (background = 0). Throws std::invalid_argument if the
// sizes do not match.
std::vector<float> ScatterToImage(const PreviewQueries &scene, const std::vector<float> &query_rgb);

}  // namespace glint::client

#endif  // GLINT_CLIENT_PREVIEW_IMAGE_IO_H
