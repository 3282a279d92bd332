#include "server/kernel_source.h"

#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace glint {

const std::map<std::string, std::string> &EmbeddedKernelSources();  // generated

namespace {

void Expand(const std::string &name, std::set<std::string> *seen, std::string *out) {
  const auto &sources = EmbeddedKernelSources();
  auto it = sources.find(name);
  if (it == sources.end()) throw std::runtime_error("unknown kernel source file: " + name);
  // Each header once: include guards would do the same, but skipping here
  // keeps the program text (and so the cache key) small.
  if (!seen->insert(name).second) return;
  std::istringstream lines(it->second);
  std::string line;
  while (std::getline(lines, line)) {
    auto first = line.find_first_not_of(" \t");
    if (first != std::string::npos && line.compare(first, 10, "#include \"") == 0) {
      auto open = line.find('"', first);
      auto close = line.find('"', open + 1);
      Expand(line.substr(open + 1, close - open - 1), seen, out);
      continue;
    }
    out->append(line);
    out->push_back('\n');
  }
}

}  // namespace

std::string ExpandKernelSource(const std::string &entry_file) {
  std::set<std::string> seen;
  std::string out;
  Expand(entry_file, &seen, &out);
  return out;
}

}  // namespace glint
