#include "server/log_sanitize.h"

#include <cstdio>

namespace glint {

std::string LogSafe(const std::string &line, size_t max_bytes) {
  std::string out;
  out.reserve(line.size() < max_bytes ? line.size() : max_bytes);
  for (size_t i = 0; i < line.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(line[i]);
    std::string piece;
    if (c == '\n') {
      piece = "\\n";
    } else if (c == '\r') {
      piece = "\\r";
    } else if (c == '\t') {
      piece = "\\t";
    } else if (c == '\\') {
      piece = "\\\\";
    } else if (c < 0x20 || c == 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      piece = hex;
    } else {
      piece.assign(1, char(c));
    }
    if (out.size() + piece.size() > max_bytes) {
      out += "... (" + std::to_string(line.size()) + " bytes in all)";
      return out;
    }
    out += piece;
  }
  return out;
}

}  // namespace glint
