// Copies to or from a shared-memory mapping that its client may shrink at any moment: touching a
// page of a MAP_SHARED mapping beyond the object's current end raises SIGBUS, which would kill
// glintd. GuardedCopy catches that fault on the copying thread (a SIGBUS handler that jumps back
// when, and only when, the faulting thread is inside a GuardedCopy) and reports it as false; any
// other SIGBUS takes the default action (the process dumps core, as without the handler; a
// handler installed before this one is deliberately not called, shm_guard.cpp says why).
//
// Mappings that other threads read and write without a copy (the device engine's kernels on a
// region, server/shm_io.cpp) are watched instead (WatchMapping): a SIGBUS inside a watched
// mapping, on any thread, maps anonymous zero pages over the whole mapping (MAP_FIXED; what
// Wayland compositors do for wl_shm pools) and sets its `lost` flag, and the faulting access is
// retried: it then reads zeros or writes memory nobody reads. The call that was using the
// mapping sees `lost` afterwards and refuses to answer; the region stays lost (its mapping no
// longer shows the object) until it is unregistered.
#pragma once

#include <atomic>
#include <cstddef>

namespace glint {

// memcpy(dst, src, bytes); false when a page of either side was gone (SIGBUS).
bool GuardedCopy(void *dst, const void *src, size_t bytes);

// Watches [begin, begin + bytes) (page-aligned start, as mmap returned it) until UnwatchMapping;
// `lost` must outlive the watch. Returns a handle, or -1 when the fixed table (kWatchSlots
// mappings for the whole process) is full.
constexpr int kWatchSlots = 1024;
int WatchMapping(void *begin, size_t bytes, std::atomic<bool> *lost);
void UnwatchMapping(int handle);

// Installs the handler, or puts it back in front when other code installed a SIGBUS handler over
// it (LLVM does, inside PoCL; shm_guard.cpp says why that kills). The device engine calls it before
// its first OpenCL call, after enumerating devices and before its kernels run; one system call
// when the handler is in front already.
void KeepSigbusGuardFirst();

}  // namespace glint
