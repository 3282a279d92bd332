#include "server/pocl_affinity.h"

#include <unistd.h>

#include <cstdlib>
#include <initializer_list>

namespace glint {

bool PoclAffinityIsSafe(const cpu_set_t &allowed, long online_cpus) {
  if (online_cpus <= 1 || online_cpus > CPU_SETSIZE) return false;
  for (long cpu = 0; cpu < online_cpus; ++cpu)
    if (!CPU_ISSET(cpu, &allowed)) return false;
  return true;
}

bool DefaultPoclAffinity() {
  if (std::getenv("POCL_AFFINITY") != nullptr) return false;
  // PoCL's worker count can be set apart from the CPU count (POCL_PTHREAD_MIN_THREADS=4 on 2 CPUs
  // oversubscribes); pinning worker i >= online CPUs would fail and abort, so a user who sets the
  // count keeps PoCL's unpinned default.
  for (const char *count : {"POCL_MAX_PTHREAD_COUNT", "POCL_PTHREAD_MIN_THREADS",
                            "POCL_CPU_MAX_CU_COUNT", "POCL_CPU_MIN_CU_COUNT"})
    if (std::getenv(count) != nullptr) return false;
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof(allowed), &allowed) != 0) return false;
  if (!PoclAffinityIsSafe(allowed, sysconf(_SC_NPROCESSORS_ONLN))) return false;
  return setenv("POCL_AFFINITY", "1", 0) == 0;
}

}  // namespace glint
