// File formats of the glint CLI: materials and lights as the proto3 JSON form of the wire
// contract, queries as CSV, radiance as CSV / NumPy .npy (EXR lives in client/preview).
// Every reader and writer throws IoError with a message that names the file (and the line and
// column where there is one), ready to print as it is.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "glint/v1/glint.pb.h"

namespace glint::client {

class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// --- JSON (protobuf's own proto3 JSON parser; unknown fields are errors, to catch typos) ---

// A glint.v1.Material, e.g.
//   {"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1,
//    "schlick": {"f0": [0.9, 0.6, 0.3]}}
glint::v1::Material ReadMaterialJson(const std::string &path);
// A glint.v1.LightList, {"lights": [{"directional": {...}}, {"point": {...}}]}.
std::vector<glint::v1::Light> ReadLightsJson(const std::string &path);
// The same from text in memory; `source` names it in error messages.
glint::v1::Material ParseMaterialJson(std::string_view json, const std::string &source);
std::vector<glint::v1::Light> ParseLightsJson(std::string_view json, const std::string &source);

// --- Queries CSV ---
//
// The header names any of these columns, in any order (each at most once):
//   u,v                        uv; a missing one is 0
//   dudx,dvdx,dudy,dvdy        footprint; a missing one is 0 (no footprint column: no filter)
//   wox,woy,woz                all three, or none for wo = (0, 0, 1)
//   wix,wiy,wiz                all three (BRDF probe) or none
//   px,py,pz,nx,ny,nz,tx,ty,tz all nine (world-space frame: position, normal, tangent) or none
// A partial group is an error naming the first missing column. Unknown or repeated columns,
// a row with a different number of fields than the header, and a field that is not a number
// (std::from_chars, so locale-independent; "nan" and "inf" are numbers and are left for the
// server to refuse) are errors naming the line and column. Blank lines are skipped.
// Optional arrays stay empty when their columns are absent, so the request stays small.
glint::v1::QueryBatch ReadQueriesCsv(const std::string &path);
glint::v1::QueryBatch ParseQueriesCsv(std::string_view text, const std::string &source);

// --- Radiance outputs (rgb: 3 floats per query, in query order) ---

// Header "r,g,b", then one row per query, each value with 9 significant digits, enough to
// read back the same float.
void WriteRadianceCsv(const std::string &path, const std::vector<float> &rgb);

// NumPy .npy format version 1.0: magic "\x93NUMPY", version (1, 0), little-endian uint16 header
// length, header dict {'descr': '<f4', 'fortran_order': False, 'shape': (count, 3), } padded
// with spaces and a final '\n' so the data starts on a 64-byte boundary, then the data.
void WriteRadianceNpy(const std::string &path, const std::vector<float> &rgb, uint64_t count);

// Lays per-query RGB out as an image `width` pixels wide, rows in query order, the unused
// tail of the last row black. width <= 0 means one row holding every query.
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  // width * height * 3, row-major
};
RgbImage QueriesToImage(const std::vector<float> &rgb, int width);

enum class OutputFormat { kCsv, kNpy, kExr, kUnknown };
// From the extension, case-insensitive.
OutputFormat OutputFormatFromPath(const std::string &path);

}  // namespace glint::client
