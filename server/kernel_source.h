// Kernel sources are embedded in the binary (kernels/embed_sources.cmake);
// this expands an entry file's quoted #includes of sibling headers into one
// translation unit, so the OpenCL compiler never needs a file system path.
#pragma once

#include <string>

namespace glint {

// Returns the entry file (e.g. "models/smooth/smooth.cl", a path relative to the
// project root) with every `#include "x.h"` of an
// embedded file replaced by its (recursively expanded) contents, each file at
// most once. Throws std::runtime_error for an unknown file.
std::string ExpandKernelSource(const std::string &entry_file);

}  // namespace glint
