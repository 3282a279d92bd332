// When glintd pins PoCL's workers (server/pocl_affinity.h): only where PoCL's pinning of worker i
// to CPU i cannot fail, and never over a POCL_AFFINITY the user set.
#include "server/pocl_affinity.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <initializer_list>
#include <string>

namespace glint {
namespace {

cpu_set_t Cpus(std::initializer_list<int> cpus) {
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int c : cpus) CPU_SET(c, &set);
  return set;
}

TEST(PoclAffinity, SafeOnlyWhenEveryOnlineCpuIsAllowed) {
  EXPECT_TRUE(PoclAffinityIsSafe(Cpus({0, 1}), 2));
  EXPECT_TRUE(PoclAffinityIsSafe(Cpus({0, 1, 2, 3}), 2));
  // A container confined to CPUs 2-3 of 4: PoCL would pin worker 0 to CPU 0 and abort.
  EXPECT_FALSE(PoclAffinityIsSafe(Cpus({2, 3}), 4));
  EXPECT_FALSE(PoclAffinityIsSafe(Cpus({0, 1, 3}), 4));
  // One CPU: nothing to balance.
  EXPECT_FALSE(PoclAffinityIsSafe(Cpus({0}), 1));
  EXPECT_FALSE(PoclAffinityIsSafe(Cpus({0, 1}), 0));
  EXPECT_FALSE(PoclAffinityIsSafe(Cpus({0, 1}), long(CPU_SETSIZE) + 1));
}

TEST(PoclAffinity, TheUsersSettingWins) {
  for (const char *user : {"0", "1", ""}) {
    ASSERT_EQ(setenv("POCL_AFFINITY", user, 1), 0);
    EXPECT_FALSE(DefaultPoclAffinity()) << "POCL_AFFINITY=" << user;
    EXPECT_EQ(std::string(std::getenv("POCL_AFFINITY")), user);
  }
}

// PoCL's worker count set apart from the CPU count: worker i >= CPUs would be pinned to a CPU that
// does not exist and PoCL would abort, so no default.
TEST(PoclAffinity, NoDefaultWhenTheWorkerCountIsSet) {
  ASSERT_EQ(unsetenv("POCL_AFFINITY"), 0);
  for (const char *count : {"POCL_MAX_PTHREAD_COUNT", "POCL_PTHREAD_MIN_THREADS",
                            "POCL_CPU_MAX_CU_COUNT", "POCL_CPU_MIN_CU_COUNT"}) {
    ASSERT_EQ(setenv(count, "4", 1), 0);
    EXPECT_FALSE(DefaultPoclAffinity()) << count;
    EXPECT_EQ(std::getenv("POCL_AFFINITY"), nullptr) << count;
    unsetenv(count);
  }
}

TEST(PoclAffinity, UnsetBecomesOneExactlyWhenSafe) {
  ASSERT_EQ(unsetenv("POCL_AFFINITY"), 0);
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof(allowed), &allowed), 0);
  const bool safe = PoclAffinityIsSafe(allowed, sysconf(_SC_NPROCESSORS_ONLN));
  EXPECT_EQ(DefaultPoclAffinity(), safe);
  const char *now = std::getenv("POCL_AFFINITY");
  if (safe) {
    ASSERT_NE(now, nullptr);
    EXPECT_EQ(std::string(now), "1");
  } else {
    EXPECT_EQ(now, nullptr);
  }
  unsetenv("POCL_AFFINITY");
}

}  // namespace
}  // namespace glint
