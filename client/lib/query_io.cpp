#include "client/lib/query_io.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>

namespace glint::client {
namespace {

std::string ReadWholeFile(const std::string &path, const char *what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw IoError("cannot open " + std::string(what) + " file " + path + ": " +
                  std::strerror(errno));
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw IoError("cannot read " + std::string(what) + " file " + path);
  return buffer.str();
}

void ParseJsonInto(std::string_view json, google::protobuf::Message *message,
                   const std::string &source, const char *what) {
  google::protobuf::util::JsonParseOptions options;
  // A misspelt key ("alpha" for "alpha_x") would otherwise silently become a default value.
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(
      google::protobuf::StringPiece(json.data(), json.size()), message, options);
  if (!status.ok()) {
    throw IoError(source + ": not a valid " + what + " (" + message->GetTypeName() +
                  " in proto3 JSON form): " + std::string(status.message()));
  }
}

// RAII FILE* so every error path closes the file.
struct FileCloser {
  void operator()(std::FILE *f) const {
    if (f) std::fclose(f);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

File OpenForWrite(const std::string &path) {
  File f(std::fopen(path.c_str(), "wb"));
  if (!f) throw IoError("cannot write " + path + ": " + std::strerror(errno));
  return f;
}

void WriteAll(std::FILE *f, const void *data, size_t n, const std::string &path) {
  if (n != 0 && std::fwrite(data, 1, n, f) != n) {
    throw IoError("cannot write " + path + ": " + std::strerror(errno));
  }
}

void CloseChecked(File f, const std::string &path) {
  // fclose reports write errors that buffering delayed (e.g. a full disk).
  if (std::fclose(f.release()) != 0) {
    throw IoError("cannot write " + path + ": " + std::strerror(errno));
  }
}

void CheckRgb(const std::vector<float> &rgb, const std::string &path) {
  if (rgb.size() % 3 != 0) {
    throw IoError("cannot write " + path + ": radiance has " + std::to_string(rgb.size()) +
                  " floats, not a multiple of 3");
  }
}

// ---- CSV columns ----------------------------------------------------------------------------

// Column slots in a fixed order; the groups below refer to them by index.
constexpr std::array<const char *, 21> kColumns = {
    "u",   "v",  "dudx", "dvdx", "dudy", "dvdy", "wox", "woy", "woz", "wix", "wiy",
    "wiz", "px", "py",   "pz",   "nx",   "ny",   "nz",  "tx",  "ty",  "tz"};

enum class GroupRule {
  kEachDefaultsToZero,  // uv, footprint: any subset, missing components are 0
  kAllOrNone,           // wi, frame: all columns or none
  kAllOrDefault,        // wo: all columns or none, none means a fixed default
};

struct Group {
  int first_column;  // index into kColumns
  int columns;       // consecutive slots
  GroupRule rule;
  google::protobuf::RepeatedField<float> *(glint::v1::QueryBatch::*array)();
};

// The frame spans three arrays (one Group each) but is all-or-none as a whole: checked over
// these nine columns before the per-array groups are used.
constexpr int kFrameFirst = 12;
constexpr int kFrameColumns = 9;

const Group kGroups[] = {
    {0, 2, GroupRule::kEachDefaultsToZero, &glint::v1::QueryBatch::mutable_uv},
    {2, 4, GroupRule::kEachDefaultsToZero, &glint::v1::QueryBatch::mutable_footprint},
    {6, 3, GroupRule::kAllOrDefault, &glint::v1::QueryBatch::mutable_wo},
    {9, 3, GroupRule::kAllOrNone, &glint::v1::QueryBatch::mutable_wi},
    {12, 3, GroupRule::kAllOrNone, &glint::v1::QueryBatch::mutable_position},
    {15, 3, GroupRule::kAllOrNone, &glint::v1::QueryBatch::mutable_normal},
    {18, 3, GroupRule::kAllOrNone, &glint::v1::QueryBatch::mutable_tangent},
};

constexpr float kDefaultWo[3] = {0.0f, 0.0f, 1.0f};

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

// Splits on ',' into `fields` (views into `line`); quoting is not supported (numbers only).
void SplitFields(std::string_view line, std::vector<std::string_view> *fields) {
  fields->clear();
  size_t start = 0;
  for (;;) {
    const size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      fields->push_back(Trim(line.substr(start)));
      return;
    }
    fields->push_back(Trim(line.substr(start, comma - start)));
    start = comma + 1;
  }
}

// Locale-independent float parse of a whole field; nullopt if it is not a number.
std::optional<float> ParseFloat(std::string_view s, bool *overflow) {
  *overflow = false;
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);  // from_chars rejects a '+' sign
  if (s.empty()) return std::nullopt;
  float value = 0.0f;
  const char *end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, value);
  if (ec == std::errc::result_out_of_range && ptr == end) {
    // Underflow is fine (the nearest float is 0 or a denormal); overflow is not a value.
    double wide = 0.0;
    auto [wptr, wec] = std::from_chars(s.data(), end, wide);
    if (wec == std::errc() && wptr == end &&
        std::fabs(wide) <= static_cast<double>(std::numeric_limits<float>::max())) {
      return static_cast<float>(wide);
    }
    *overflow = true;
    return std::nullopt;
  }
  if (ec != std::errc() || ptr != end) return std::nullopt;
  return value;
}

std::string Where(const std::string &source, size_t line) {
  return source + ":" + std::to_string(line);
}

}  // namespace

// ---- JSON -----------------------------------------------------------------------------------

glint::v1::Material ParseMaterialJson(std::string_view json, const std::string &source) {
  glint::v1::Material material;
  ParseJsonInto(json, &material, source, "material");
  return material;
}

std::vector<glint::v1::Light> ParseLightsJson(std::string_view json, const std::string &source) {
  glint::v1::LightList list;
  ParseJsonInto(json, &list, source, "light list");
  return {list.lights().begin(), list.lights().end()};
}

glint::v1::Material ReadMaterialJson(const std::string &path) {
  return ParseMaterialJson(ReadWholeFile(path, "material"), path);
}

std::vector<glint::v1::Light> ReadLightsJson(const std::string &path) {
  return ParseLightsJson(ReadWholeFile(path, "lights"), path);
}

// ---- Queries CSV ----------------------------------------------------------------------------

glint::v1::QueryBatch ParseQueriesCsv(std::string_view text, const std::string &source) {
  // Spreadsheet exports often start with a UTF-8 byte order mark.
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);

  size_t pos = 0;
  size_t line_number = 0;
  // Next non-blank line, or nullopt at the end.
  auto next_line = [&]() -> std::optional<std::string_view> {
    while (pos < text.size()) {
      const size_t nl = text.find('\n', pos);
      const size_t end = nl == std::string_view::npos ? text.size() : nl;
      std::string_view line = text.substr(pos, end - pos);
      pos = nl == std::string_view::npos ? text.size() : nl + 1;
      ++line_number;
      if (!Trim(line).empty()) return line;
    }
    return std::nullopt;
  };

  const std::optional<std::string_view> header = next_line();
  if (!header) {
    throw IoError(source + ": empty query file; expected a header line such as wox,woy,woz");
  }
  const size_t header_line = line_number;
  std::vector<std::string_view> fields;
  SplitFields(*header, &fields);

  // slot_of_field[i] = column slot of field i; field_of_slot[s] = field index or -1.
  std::vector<int> slot_of_field(fields.size(), -1);
  std::array<int, kColumns.size()> field_of_slot;
  field_of_slot.fill(-1);
  for (size_t i = 0; i < fields.size(); ++i) {
    const auto it = std::find_if(kColumns.begin(), kColumns.end(),
                                 [&](const char *name) { return fields[i] == name; });
    if (it == kColumns.end()) {
      std::string known;
      for (const char *name : kColumns) {
        if (!known.empty()) known += ',';
        known += name;
      }
      throw IoError(Where(source, header_line) + ": unknown column '" + std::string(fields[i]) +
                    "' (field " + std::to_string(i + 1) + "); known columns: " + known);
    }
    const auto slot = static_cast<int>(it - kColumns.begin());
    if (field_of_slot[slot] != -1) {
      throw IoError(Where(source, header_line) + ": column '" + std::string(fields[i]) +
                    "' appears twice (fields " + std::to_string(field_of_slot[slot] + 1) + " and " +
                    std::to_string(i + 1) + ")");
    }
    field_of_slot[slot] = static_cast<int>(i);
    slot_of_field[i] = slot;
  }

  auto count_present = [&](int first, int n) {
    int present = 0;
    for (int s = first; s < first + n; ++s) present += field_of_slot[s] != -1;
    return present;
  };
  auto first_missing = [&](int first, int n) {
    for (int s = first; s < first + n; ++s) {
      if (field_of_slot[s] == -1) return std::string(kColumns[s]);
    }
    return std::string();
  };
  auto group_columns = [&](int first, int n) {
    std::string names;
    for (int s = first; s < first + n; ++s) {
      if (s != first) names += ',';
      names += kColumns[s];
    }
    return names;
  };
  auto require_all_or_none = [&](int first, int n, const char *label, const char *none_means) {
    const int present = count_present(first, n);
    if (present != 0 && present != n) {
      throw IoError(Where(source, header_line) + ": column '" + first_missing(first, n) +
                    "' is missing: " + label + " needs all of " + group_columns(first, n) +
                    " or none of them (" + none_means + ")");
    }
  };
  require_all_or_none(6, 3, "wo", "none means wo = (0, 0, 1)");
  require_all_or_none(9, 3, "wi", "none means no BRDF probe direction");
  require_all_or_none(kFrameFirst, kFrameColumns, "the world-space frame (p, n, t)",
                      "none means the local shading frame");

  // Which arrays this batch carries; wo always (required on the wire).
  struct ActiveGroup {
    const Group *group;
    google::protobuf::RepeatedField<float> *array;
  };
  glint::v1::QueryBatch batch;
  std::vector<ActiveGroup> active;
  for (const Group &g : kGroups) {
    if (count_present(g.first_column, g.columns) == 0 && g.rule != GroupRule::kAllOrDefault) {
      continue;
    }
    active.push_back({&g, (batch.*g.array)()});
  }

  std::vector<float> row(kColumns.size(), 0.0f);
  uint64_t count = 0;
  while (const std::optional<std::string_view> line = next_line()) {
    SplitFields(*line, &fields);
    if (fields.size() != slot_of_field.size()) {
      throw IoError(Where(source, line_number) + ": expected " +
                    std::to_string(slot_of_field.size()) + " fields as in the header, found " +
                    std::to_string(fields.size()));
    }
    for (size_t i = 0; i < fields.size(); ++i) {
      bool overflow = false;
      const std::optional<float> value = ParseFloat(fields[i], &overflow);
      if (!value) {
        throw IoError(Where(source, line_number) + ", column '" + kColumns[slot_of_field[i]] +
                      "' (field " + std::to_string(i + 1) + "): '" + std::string(fields[i]) +
                      (overflow ? "' is out of float range" : "' is not a number"));
      }
      row[slot_of_field[i]] = *value;
    }
    for (const ActiveGroup &a : active) {
      const Group &g = *a.group;
      for (int c = 0; c < g.columns; ++c) {
        const int slot = g.first_column + c;
        float v = 0.0f;
        if (field_of_slot[slot] != -1) {
          v = row[slot];
        } else if (g.rule == GroupRule::kAllOrDefault) {
          v = kDefaultWo[c];
        }
        a.array->Add(v);
      }
    }
    ++count;
  }
  if (count > std::numeric_limits<uint32_t>::max()) {
    throw IoError(source + ": " + std::to_string(count) + " queries; at most 2^32-1 fit a batch");
  }
  batch.set_count(static_cast<uint32_t>(count));
  return batch;
}

glint::v1::QueryBatch ReadQueriesCsv(const std::string &path) {
  return ParseQueriesCsv(ReadWholeFile(path, "queries"), path);
}

// ---- Outputs --------------------------------------------------------------------------------

void WriteRadianceCsv(const std::string &path, const std::vector<float> &rgb) {
  CheckRgb(rgb, path);
  File f = OpenForWrite(path);
  std::string buffer = "r,g,b\n";
  buffer.reserve(1 << 16);
  char number[32];
  for (size_t i = 0; i < rgb.size(); ++i) {
    // to_chars with precision 9 is %.9g without the locale: 9 significant digits always read
    // back to the same float (FLT_DECIMAL_DIG).
    const auto result =
        std::to_chars(number, number + sizeof number, rgb[i], std::chars_format::general, 9);
    buffer.append(number, result.ptr);
    buffer.push_back(i % 3 == 2 ? '\n' : ',');
    if (buffer.size() > (1 << 16) - 64) {
      WriteAll(f.get(), buffer.data(), buffer.size(), path);
      buffer.clear();
    }
  }
  WriteAll(f.get(), buffer.data(), buffer.size(), path);
  CloseChecked(std::move(f), path);
}

void WriteRadianceNpy(const std::string &path, const std::vector<float> &rgb, uint64_t count) {
  CheckRgb(rgb, path);
  if (rgb.size() != count * 3) {
    throw IoError("cannot write " + path + ": " + std::to_string(rgb.size()) +
                  " floats do not make " + std::to_string(count) + " RGB rows");
  }
  std::string header =
      "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(count) + ", 3), }";
  // magic (6) + version (2) + header length (2) = 10 bytes before the dict; numpy pads the
  // dict with spaces and ends it with '\n' so that the data is 64-byte aligned.
  constexpr size_t kPreamble = 10;
  const size_t unpadded = kPreamble + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header.push_back('\n');
  const size_t header_len = header.size();  // < 65536 always: the dict is ~70 bytes

  std::string out;
  out.reserve(kPreamble + header_len + rgb.size() * 4);
  out.append("\x93NUMPY", 6);
  out.push_back('\x01');
  out.push_back('\x00');
  out.push_back(static_cast<char>(header_len & 0xff));
  out.push_back(static_cast<char>((header_len >> 8) & 0xff));
  out += header;
  // '<f4' is little-endian whatever the host: write the bytes of each float explicitly.
  for (float v : rgb) {
    uint32_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    for (int b = 0; b < 4; ++b) out.push_back(static_cast<char>((bits >> (8 * b)) & 0xff));
  }
  File f = OpenForWrite(path);
  WriteAll(f.get(), out.data(), out.size(), path);
  CloseChecked(std::move(f), path);
}

RgbImage QueriesToImage(const std::vector<float> &rgb, int width) {
  const size_t count = rgb.size() / 3;
  RgbImage image;
  if (count == 0) return image;
  if (width <= 0) {
    if (count > static_cast<size_t>(std::numeric_limits<int>::max())) {
      throw IoError(std::to_string(count) + " queries do not fit one image row; pass a width");
    }
    width = static_cast<int>(count);
  }
  const size_t w = static_cast<size_t>(width);
  const size_t h = (count + w - 1) / w;
  if (h > static_cast<size_t>(std::numeric_limits<int>::max())) {
    throw IoError("image height " + std::to_string(h) + " is too large");
  }
  image.width = width;
  image.height = static_cast<int>(h);
  image.rgb.assign(w * h * 3, 0.0f);  // black tail past the last query
  std::copy(rgb.begin(), rgb.begin() + static_cast<std::ptrdiff_t>(count * 3), image.rgb.begin());
  return image;
}

OutputFormat OutputFormatFromPath(const std::string &path) {
  const size_t dot = path.find_last_of('.');
  const size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) {
    return OutputFormat::kUnknown;
  }
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == "csv") return OutputFormat::kCsv;
  if (ext == "npy") return OutputFormat::kNpy;
  if (ext == "exr") return OutputFormat::kExr;
  return OutputFormat::kUnknown;
}

}  // namespace glint::client
