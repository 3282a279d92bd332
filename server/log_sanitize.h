// glintd's request log carries strings clients chose (a normal map's file name, a KServe input
// name, a digest, anything a refusal quotes). Written raw, a client could forge log lines with
// an embedded newline (or hide text with a carriage return or terminal escapes) and make every
// request write as much log as its message limit allows. LogSafe makes one log line of it.
#pragma once

#include <cstddef>
#include <string>

namespace glint {

// The longest log line glintd writes, in bytes (before the "glintd: " prefix).
inline constexpr size_t kMaxLogLineBytes = 4096;

// `line` as one line: control characters (below 0x20, and 0x7f) written as \n, \r, \t or \xNN
// and a backslash as \\ (so an escape in the output always came from this function); beyond
// `max_bytes` of output the rest is replaced by "... (N bytes in all)". Other bytes, UTF-8
// included, are kept.
std::string LogSafe(const std::string &line, size_t max_bytes = kMaxLogLineBytes);

}  // namespace glint
