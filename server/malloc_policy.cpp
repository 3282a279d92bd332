#include "server/malloc_policy.h"

#include <malloc.h>

namespace glint {

bool ConfigureMallocForMessages() {
  bool ok = mallopt(M_ARENA_MAX, 2) == 1;
  ok = mallopt(M_TRIM_THRESHOLD, 64 << 20) == 1 && ok;
  ok = mallopt(M_MMAP_THRESHOLD, 32 << 20) == 1 && ok;
  return ok;
}

}  // namespace glint
