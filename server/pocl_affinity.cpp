#include "server/pocl_affinity.h"

#include <unistd.h>

#include <cstdlib>

namespace glint {

bool PoclAffinityIsSafe(const cpu_set_t &allowed, long online_cpus) {
  if (online_cpus <= 1 || online_cpus > CPU_SETSIZE) return false;
  for (long cpu = 0; cpu < online_cpus; ++cpu)
    if (!CPU_ISSET(cpu, &allowed)) return false;
  return true;
}

bool DefaultPoclAffinity() {
  if (std::getenv("POCL_AFFINITY") != nullptr) return false;
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof(allowed), &allowed) != 0) return false;
  if (!PoclAffinityIsSafe(allowed, sysconf(_SC_NPROCESSORS_ONLN))) return false;
  return setenv("POCL_AFFINITY", "1", 0) == 0;
}

}  // namespace glint
