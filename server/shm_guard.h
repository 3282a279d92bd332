// Copies to or from a shared-memory mapping that its client may shrink at any moment: touching a
// page of a MAP_SHARED mapping beyond the object's current end raises SIGBUS, which would kill
// glintd. GuardedCopy catches that fault on the copying thread (a SIGBUS handler that jumps back
// when, and only when, the faulting thread is inside a GuardedCopy) and reports it as false; any
// other SIGBUS keeps its usual meaning (the previous handler, or the default action).
#pragma once

#include <cstddef>

namespace glint {

// memcpy(dst, src, bytes); false when a page of either side was gone (SIGBUS).
bool GuardedCopy(void *dst, const void *src, size_t bytes);

}  // namespace glint
