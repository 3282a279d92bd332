// PoCL's worker threads pinned one per CPU by default (POCL_AFFINITY=1), where that is safe.
//
// PoCL's pthread device wakes its workers for every kernel. Left to the Linux scheduler, both
// workers of this project's 2-core machine were often woken on the enqueuing thread's core, and an
// evaluation then ran on one core at twice its wall time (bench/README.md, "PoCL's worker
// threads"). POCL_AFFINITY=1 pins worker i to CPU i. PoCL pins by absolute CPU index and aborts
// when that fails, so the default applies only when this process may run on every online CPU (a
// container confined to a cpuset keeps PoCL's unpinned default) and PoCL starts one worker per
// online CPU (a user who sets PoCL's worker count keeps the unpinned default); a POCL_AFFINITY the
// user set always wins. It calls setenv: call it before the process starts other threads (glintd
// creates its engine, the first OpenCL call, before its scheduler and gRPC threads).
#pragma once

#include <sched.h>

namespace glint {

// True when pinning PoCL's workers to CPUs 0 .. online_cpus - 1 cannot fail: every one of them is
// in `allowed` (this process's affinity mask) and there is more than one.
bool PoclAffinityIsSafe(const cpu_set_t &allowed, long online_cpus);

// Sets POCL_AFFINITY=1 unless it is set already, PoCL's worker count is set, or pinning is not
// safe for this process. Call it before the first OpenCL call (PoCL reads it when its device
// starts) and before other threads run. Returns whether it set it.
bool DefaultPoclAffinity();

}  // namespace glint
