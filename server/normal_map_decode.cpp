#include "server/normal_map_decode.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <openssl/evp.h>
#include <png.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <exception>
#include <memory>

namespace glint {
namespace {

bool EndsWith(const std::string &s, const std::string &suffix) {
  if (s.size() < suffix.size()) return false;
  for (size_t k = 0; k < suffix.size(); ++k)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + k])) != suffix[k])
      return false;
  return true;
}

// The file's bytes as an OpenEXR input stream (no temporary file).
class MemoryIStream : public Imf::IStream {
 public:
  MemoryIStream(const std::string &name, const std::string &bytes)
      : Imf::IStream(name.c_str()), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (n < 0 || pos_ + uint64_t(n) > bytes_.size())
      throw std::runtime_error("truncated file: read past its " + std::to_string(bytes_.size()) +
                               " bytes");
    std::memcpy(c, bytes_.data() + pos_, size_t(n));
    pos_ += uint64_t(n);
    return pos_ < bytes_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = pos; }

 private:
  const std::string &bytes_;
  uint64_t pos_ = 0;
};

Status Refuse(const std::string &filename, const std::string &why) {
  return Status::InvalidArgument("normal map " + filename + ": " + why);
}

Status CheckSize(const std::string &filename, int64_t w, int64_t h, uint64_t max_texels) {
  if (w <= 0 || h <= 0)
    return Refuse(filename, "size " + std::to_string(w) + "x" + std::to_string(h) +
                                "; expected a positive width and height");
  if (uint64_t(w) * uint64_t(h) > max_texels)
    return Refuse(filename, std::to_string(w) + "x" + std::to_string(h) + " = " +
                                std::to_string(uint64_t(w) * uint64_t(h)) +
                                " texels; the server accepts at most " +
                                std::to_string(max_texels) +
                                " (Capabilities.max_normal_map_texels)");
  return Status::Ok();
}

Status DecodeExr(const std::string &filename, const std::string &bytes, uint64_t max_texels,
                 DecodedNormalMap *out) {
  try {
    MemoryIStream stream(filename, bytes);
    Imf::InputFile file(stream);
    const Imath::Box2i dw = file.header().dataWindow();
    const int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
    Status s = CheckSize(filename, w, h, max_texels);
    if (!s.ok()) return s;
    for (const char *c : {"R", "G", "B"}) {
      if (!file.header().channels().findChannel(c))
        return Refuse(filename, std::string("no channel ") + c +
                                    "; expected float R, G, B = the tangent-space normal");
    }
    out->width = uint32_t(w);
    out->height = uint32_t(h);
    out->xyz.assign(size_t(w) * size_t(h) * 3, 0.0f);
    Imf::FrameBuffer fb;
    char *base = reinterpret_cast<char *>(out->xyz.data()) -
                 (int64_t(dw.min.x) + int64_t(dw.min.y) * w) * 3 * int64_t(sizeof(float));
    const char *names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c)
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), 3 * sizeof(float),
                                     3 * sizeof(float) * size_t(w)));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
  } catch (const std::exception &e) {
    return Refuse(filename, std::string("not a readable OpenEXR file (") + e.what() + ")");
  }
  return Status::Ok();
}

Status DecodePng(const std::string &filename, const std::string &bytes, uint64_t max_texels,
                 DecodedNormalMap *out) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
    return Refuse(filename, std::string("not a readable PNG file (") + image.message + ")");
  std::unique_ptr<png_image, void (*)(png_image *)> guard(&image, png_image_free);
  const uint32_t format = image.format;
  if (!(format & PNG_FORMAT_FLAG_COLOR) || (format & PNG_FORMAT_FLAG_COLORMAP) ||
      (format & PNG_FORMAT_FLAG_ALPHA))
    return Refuse(filename, std::string("colour type ") +
                                ((format & PNG_FORMAT_FLAG_COLORMAP) ? "palette"
                                 : (format & PNG_FORMAT_FLAG_ALPHA)  ? "with alpha"
                                                                     : "grayscale") +
                                "; expected 8- or 16-bit RGB (3 channels)");
  Status s = CheckSize(filename, image.width, image.height, max_texels);
  if (!s.ok()) return s;
  const bool sixteen = (format & PNG_FORMAT_FLAG_LINEAR) != 0;
  // The file's own encoding (16-bit files are read as linear, 8-bit as sRGB by the simplified
  // API), so no conversion happens: c is the stored value.
  image.format = sixteen ? PNG_FORMAT_LINEAR_RGB : PNG_FORMAT_RGB;
  const size_t n = size_t(image.width) * image.height * 3;
  std::vector<uint16_t> v16(sixteen ? n : 0);
  std::vector<uint8_t> v8(sixteen ? 0 : n);
  void *buffer = sixteen ? static_cast<void *>(v16.data()) : static_cast<void *>(v8.data());
  if (!png_image_finish_read(&image, nullptr, buffer, 0, nullptr))
    return Refuse(filename, std::string("corrupt or truncated PNG data (") + image.message + ")");
  guard.release();
  out->width = image.width;
  out->height = image.height;
  out->xyz.resize(n);
  const float max = sixteen ? 65535.0f : 255.0f;
  for (size_t k = 0; k < n; ++k) out->xyz[k] = 2.0f * float(sixteen ? v16[k] : v8[k]) / max - 1.0f;
  return Status::Ok();
}

}  // namespace

Status DecodeNormalMap(const std::string &filename, const std::string &bytes, uint64_t max_texels,
                       DecodedNormalMap *out) {
  *out = DecodedNormalMap();
  Status s;
  if (EndsWith(filename, ".exr")) {
    s = DecodeExr(filename, bytes, max_texels, out);
  } else if (EndsWith(filename, ".png")) {
    s = DecodePng(filename, bytes, max_texels, out);
  } else {
    return Refuse(filename,
                  "unknown extension; expected .exr (float RGB normals) or .png (8- or "
                  "16-bit RGB)");
  }
  if (!s.ok()) {
    *out = DecodedNormalMap();
    return s;
  }
  // Renormalise; refuse what cannot name a tangent-space normal.
  for (size_t t = 0; t < size_t(out->width) * out->height; ++t) {
    float *n = &out->xyz[3 * t];
    const double len = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
    const std::string where =
        "texel (" + std::to_string(t % out->width) + ", " + std::to_string(t / out->width) + ")";
    if (!std::isfinite(n[0]) || !std::isfinite(n[1]) || !std::isfinite(n[2])) {
      *out = DecodedNormalMap();
      return Refuse(filename, where + " is not finite; expected a unit normal");
    }
    if (!(len > 1e-6) || !(n[2] >= 0.0f)) {
      const std::string why = len > 1e-6 ? " points into the surface (z < 0)" : " has zero length";
      *out = DecodedNormalMap();
      return Refuse(filename, where + why + "; expected a tangent-space normal with z >= 0");
    }
    for (int c = 0; c < 3; ++c) n[c] = float(n[c] / len);
  }
  return Status::Ok();
}

std::string NormalMapDigest(const DecodedNormalMap &map) {
  static_assert(std::endian::native == std::endian::little, "the digest hashes little-endian data");
  std::unique_ptr<EVP_MD_CTX, void (*)(EVP_MD_CTX *)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr);
  const uint32_t size[2] = {map.width, map.height};
  EVP_DigestUpdate(ctx.get(), size, sizeof size);
  EVP_DigestUpdate(ctx.get(), map.xyz.data(), map.xyz.size() * sizeof(float));
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_DigestFinal_ex(ctx.get(), md, &len);
  static const char *hex = "0123456789abcdef";
  std::string out = "sha256:";
  for (unsigned int k = 0; k < len; ++k) {
    out += hex[md[k] >> 4];
    out += hex[md[k] & 15];
  }
  return out;
}

}  // namespace glint
