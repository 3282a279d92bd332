// Decoding an uploaded normal-map file (models/normal_map/README.md "Normal maps"): OpenEXR with
// float R, G, B = the tangent-space unit normal (x along +u, y along +v, z out of the surface),
// or an 8- or 16-bit RGB PNG with n = 2 c / max - 1; every normal is renormalised. File row r
// is texel row j = r (v in [r / H, (r + 1) / H)). Anything else is refused with a message that
// names the file and what was expected.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "server/status.h"

namespace glint {

struct DecodedNormalMap {
  uint32_t width = 0, height = 0;
  std::vector<float> xyz;  // 3 per texel, unit, z >= 0, row-major
};

// `max_texels` bounds width x height (checked from the header before the pixels are read).
Status DecodeNormalMap(const std::string &filename, const std::string &bytes, uint64_t max_texels,
                       DecodedNormalMap *out);

// "sha256:<hex>" of the decoded normals: SHA-256 (OpenSSL libcrypto) over width and height as
// little-endian uint32 and then x, y, z of every texel as little-endian float32, row-major.
std::string NormalMapDigest(const DecodedNormalMap &map);

}  // namespace glint
