#include "server/shm_guard.h"

#include <setjmp.h>
#include <signal.h>
#include <sys/mman.h>

#include <cstdint>
#include <cstring>
#include <mutex>

namespace glint {
namespace {

// Where the current thread's GuardedCopy wants a SIGBUS to land; null outside one. Initial-exec
// TLS: reading it in the signal handler is then a plain load (no lazy TLS allocation).
__attribute__((tls_model("initial-exec"))) thread_local sigjmp_buf *t_landing = nullptr;

// The watched mappings. A slot is in use while `begin` is non-zero; it is filled `end` and
// `lost` first and `begin` last, and emptied `begin` first, so the handler (which only reads)
// never pairs a begin with another mapping's end.
struct Watch {
  std::atomic<uintptr_t> begin{0};
  std::atomic<uintptr_t> end{0};
  std::atomic<std::atomic<bool> *> lost{nullptr};
};
Watch g_watch[kWatchSlots];

// Replaces the watched mapping holding `addr` by anonymous memory; false when none holds it.
// mmap is a plain system call here (not on POSIX's async-signal-safe list, but it takes no
// user-space lock); the fault is synchronous, so no other handler code is interrupted.
bool Rescue(uintptr_t addr) {
  for (Watch &w : g_watch) {
    const uintptr_t begin = w.begin.load(std::memory_order_acquire);
    if (begin == 0 || addr < begin) continue;
    const uintptr_t end = w.end.load(std::memory_order_relaxed);
    if (addr >= end) continue;
    void *p = mmap(reinterpret_cast<void *>(begin), end - begin, PROT_READ | PROT_WRITE,
                   MAP_FIXED | MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) return false;
    if (std::atomic<bool> *lost = w.lost.load(std::memory_order_relaxed))
      lost->store(true, std::memory_order_release);
    return true;
  }
  return false;
}

void OnSigbus(int, siginfo_t *info, void *) {
  if (sigjmp_buf *landing = t_landing) siglongjmp(*landing, 1);
  // A watched mapping: retry the access on the zero pages.
  if (info && Rescue(reinterpret_cast<uintptr_t>(info->si_addr))) return;
  // Not ours: the default action (core) when the access is retried. A handler installed before
  // ours is deliberately not called: LLVM's (below) puts back the action it displaced, which is
  // ours when it registered after us, and the retried fault would come back here for ever.
  signal(SIGBUS, SIG_DFL);
}

bool IsInstalled() {
  struct sigaction current {};
  sigaction(SIGBUS, nullptr, &current);
  return (current.sa_flags & SA_SIGINFO) && current.sa_sigaction == OnSigbus;
}

}  // namespace

// Other code installs its own SIGBUS handler over ours: LLVM, which PoCL links, registers one
// (SA_RESETHAND, to delete its temporary files; also for SIGHUP, SIGINT, SIGTERM, ...) the first
// time it writes a file, which PoCL does while glint enumerates the OpenCL devices and when it
// compiles. SA_RESETHAND resets the action to the default as the handler is entered, and LLVM's
// puts back what it displaced only then, so when two of PoCL's threads faulted on a truncated
// region at once, the second met the default action and the process died (shm_view_test in CI:
// "Bus error", 1 run in ~60 when LLVM registered after the guard). The device engine therefore
// installs the guard before its first OpenCL call (LLVM then saves the guard as what it displaced,
// and restores it when one of its handlers runs, e.g. on SIGHUP) and puts it back in front after
// enumerating devices and before its kernels run; WatchMapping and GuardedCopy check too.
void KeepSigbusGuardFirst() {
  if (IsInstalled()) return;  // the common case: one system call, no lock
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  if (IsInstalled()) return;
  struct sigaction action {};
  action.sa_sigaction = OnSigbus;
  action.sa_flags = SA_SIGINFO | SA_NODEFER;
  sigemptyset(&action.sa_mask);
  sigaction(SIGBUS, &action, nullptr);
}

namespace {

// Kept out of line so that nothing GuardedCopy holds in registers lives across sigsetjmp.
__attribute__((noinline)) void Copy(void *dst, const void *src, size_t bytes) {
  std::memcpy(dst, src, bytes);
}

}  // namespace

int WatchMapping(void *begin, size_t bytes, std::atomic<bool> *lost) {
  KeepSigbusGuardFirst();
  static std::mutex mutex;  // between watchers; the handler needs none
  std::lock_guard<std::mutex> lock(mutex);
  for (int i = 0; i < kWatchSlots; ++i) {
    Watch &w = g_watch[i];
    if (w.begin.load(std::memory_order_relaxed) != 0) continue;
    w.end.store(reinterpret_cast<uintptr_t>(begin) + bytes, std::memory_order_relaxed);
    w.lost.store(lost, std::memory_order_relaxed);
    w.begin.store(reinterpret_cast<uintptr_t>(begin), std::memory_order_release);
    return i;
  }
  return -1;
}

void UnwatchMapping(int handle) {
  if (handle < 0 || handle >= kWatchSlots) return;
  g_watch[handle].begin.store(0, std::memory_order_release);
}

bool GuardedCopy(void *dst, const void *src, size_t bytes) {
  KeepSigbusGuardFirst();
  sigjmp_buf landing;
  // savemask 1: the jump restores the signal mask, so the next SIGBUS is delivered again.
  if (sigsetjmp(landing, 1) != 0) {
    t_landing = nullptr;
    return false;
  }
  t_landing = &landing;
  Copy(dst, src, bytes);
  t_landing = nullptr;
  return true;
}

}  // namespace glint
