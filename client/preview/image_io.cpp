#include "client/preview/image_io.h"

#include <ImfChannelList.h>
#include <ImfCompression.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <half.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace glint::client {
namespace {

constexpr const char *kChannels[3] = {"R", "G", "B"};

// Size checks shared by the writers; the message names the file because the caller may be
// writing many.
void CheckImageSize(const std::string &what, const std::string &path, int width, int height,
                    const std::vector<float> &rgb) {
  if (width <= 0 || height <= 0) {
    throw std::runtime_error(what + " " + path + ": image size must be positive, got " +
                             std::to_string(width) + "x" + std::to_string(height));
  }
  const size_t expected = size_t{3} * static_cast<size_t>(width) * static_cast<size_t>(height);
  if (rgb.size() != expected) {
    throw std::runtime_error(what + " " + path + ": expected " + std::to_string(expected) +
                             " floats (3 x " + std::to_string(width) + " x " +
                             std::to_string(height) + "), got " + std::to_string(rgb.size()));
  }
}

// sRGB OETF (IEC 61966-2-1), linear [0, 1] -> encoded [0, 1].
float SrgbOetf(float c) {
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

// Extended Reinhard (Reinhard et al. 2002, eq. 4) per channel: unlike plain c / (1 + c) it
// reaches white at a finite value, so bright highlights and light sources read as white.
float ToneMap(float c) {
  if (!(c > 0.0f)) return 0.0f;  // negative radiance is a bug upstream; black, not garbage
  if (c >= kPngWhitePoint) return 1.0f;
  return c * (1.0f + c / (kPngWhitePoint * kPngWhitePoint)) / (1.0f + c);
}

uint8_t Quantize(float encoded) {
  return static_cast<uint8_t>(std::lround(std::clamp(encoded, 0.0f, 1.0f) * 255.0f));
}

}  // namespace

void WriteExrRgb(const std::string &path, int width, int height, const std::vector<float> &rgb,
                 bool half_float) {
  CheckImageSize("WriteExrRgb", path, width, height, rgb);
  // RgbaOutputFile only writes HALF, so both precisions go through the general interface.
  std::vector<Imath::half> halves;
  if (half_float) {
    // Values above 65504 become +Inf in half; that is the format's limit, not clamped here.
    halves.assign(rgb.begin(), rgb.end());
  }
  const Imf::PixelType type = half_float ? Imf::HALF : Imf::FLOAT;
  const size_t component = half_float ? sizeof(Imath::half) : sizeof(float);
  // The library only reads through the slice pointers; Slice takes char* for both directions.
  char *base = half_float ? reinterpret_cast<char *>(halves.data())
                          : reinterpret_cast<char *>(const_cast<float *>(rgb.data()));
  try {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::FrameBuffer frame;
    for (int c = 0; c < 3; ++c) {
      header.channels().insert(kChannels[c], Imf::Channel(type));
      frame.insert(kChannels[c], Imf::Slice(type, base + c * component, 3 * component,
                                            3 * component * static_cast<size_t>(width)));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(frame);
    file.writePixels(height);
  } catch (const std::exception &e) {
    throw std::runtime_error("WriteExrRgb " + path + ": " + e.what());
  }
}

std::vector<float> ReadExrRgb(const std::string &path, int *width, int *height) {
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    const int w = dw.max.x - dw.min.x + 1;
    const int h = dw.max.y - dw.min.y + 1;
    for (const char *name : kChannels) {
      if (file.header().channels().findChannel(name) == nullptr) {
        throw std::runtime_error(std::string("no channel ") + name);
      }
    }
    std::vector<float> rgb(size_t{3} * static_cast<size_t>(w) * static_cast<size_t>(h));
    Imf::FrameBuffer frame;
    for (int c = 0; c < 3; ++c) {
      // Slice::Make subtracts the data-window origin from the base pointer without overflow.
      frame.insert(kChannels[c], Imf::Slice::Make(Imf::FLOAT, rgb.data() + c, dw, 3 * sizeof(float),
                                                  3 * sizeof(float) * static_cast<size_t>(w)));
    }
    file.setFrameBuffer(frame);
    file.readPixels(dw.min.y, dw.max.y);
    *width = w;
    *height = h;
    return rgb;
  } catch (const std::exception &e) {
    throw std::runtime_error("ReadExrRgb " + path + ": " + e.what());
  }
}

std::vector<uint8_t> ToneMapToSrgb8(int width, int height, const std::vector<float> &rgb,
                                    float exposure_stops) {
  CheckImageSize("ToneMapToSrgb8", "(in memory)", width, height, rgb);
  if (!std::isfinite(exposure_stops)) {
    throw std::runtime_error("ToneMapToSrgb8: exposure_stops is not finite");
  }
  const float scale = std::exp2(exposure_stops);
  const size_t pixels = static_cast<size_t>(width) * static_cast<size_t>(height);
  std::vector<uint8_t> bytes(3 * pixels);
  for (size_t i = 0; i < pixels; ++i) {
    const float *in = &rgb[3 * i];
    uint8_t *out = &bytes[3 * i];
    if (!std::isfinite(in[0]) || !std::isfinite(in[1]) || !std::isfinite(in[2])) {
      out[0] = 255;
      out[1] = 0;
      out[2] = 255;
      continue;
    }
    for (int c = 0; c < 3; ++c) out[c] = Quantize(SrgbOetf(ToneMap(in[c] * scale)));
  }
  return bytes;
}

void WritePngRgb8(const std::string &path, int width, int height,
                  const std::vector<uint8_t> &bytes) {
  if (width <= 0 || height <= 0 ||
      bytes.size() != size_t{3} * static_cast<size_t>(width) * static_cast<size_t>(height)) {
    throw std::runtime_error("WritePngRgb8 " + path + ": " + std::to_string(bytes.size()) +
                             " bytes do not make a " + std::to_string(width) + "x" +
                             std::to_string(height) + " RGB image");
  }
  // libpng's simplified API reports errors through image.message instead of longjmp.
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB;
  if (png_image_write_to_file(&image, path.c_str(), /*convert_to_8bit=*/0, bytes.data(),
                              /*row_stride=*/0, /*colormap=*/nullptr) == 0) {
    throw std::runtime_error("WritePngRgb8 " + path + ": " + image.message);
  }
}

void WritePngToneMapped(const std::string &path, int width, int height,
                        const std::vector<float> &rgb, float exposure_stops) {
  CheckImageSize("WritePngToneMapped", path, width, height, rgb);
  if (!std::isfinite(exposure_stops)) {
    throw std::runtime_error("WritePngToneMapped " + path + ": exposure_stops is not finite");
  }
  WritePngRgb8(path, width, height, ToneMapToSrgb8(width, height, rgb, exposure_stops));
}

std::vector<float> ScatterToImage(const PreviewQueries &scene,
                                  const std::vector<float> &query_rgb) {
  const size_t queries = scene.pixel_of_query.size();
  if (query_rgb.size() != 3 * queries) {
    throw std::invalid_argument("ScatterToImage: expected " + std::to_string(3 * queries) +
                                " floats (3 per query), got " + std::to_string(query_rgb.size()));
  }
  const int64_t pixels = int64_t{scene.width} * scene.height;
  std::vector<float> image(3 * static_cast<size_t>(std::max<int64_t>(pixels, 0)), 0.0f);
  for (size_t q = 0; q < queries; ++q) {
    const int32_t p = scene.pixel_of_query[q];
    if (p < 0 || p >= pixels) {
      throw std::invalid_argument("ScatterToImage: query " + std::to_string(q) + " has pixel " +
                                  std::to_string(p) + " outside the " +
                                  std::to_string(scene.width) + "x" + std::to_string(scene.height) +
                                  " image");
    }
    std::copy_n(&query_rgb[3 * q], 3, &image[3 * static_cast<size_t>(p)]);
  }
  return image;
}

}  // namespace glint::client
