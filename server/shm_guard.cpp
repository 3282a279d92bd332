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
std::atomic<int> g_watched{0};  // slots in use

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
  // Not ours: the default action (core) when the access is retried. The handler we displaced is
  // not called: LLVM's (below) restores the handler it displaced, which may be this one, and the
  // retried fault would come back here for ever.
  signal(SIGBUS, SIG_DFL);
}

// Installs OnSigbus unless it is the SIGBUS handler already. Other code installs its own over
// ours: LLVM, which PoCL links, registers a SIGBUS handler (SA_RESETHAND, to delete its temporary
// files) the first time it writes one, e.g. while glint enumerates the OpenCL devices. Its handler
// resets the action to the default as it is entered and only then puts ours back, so when two of
// PoCL's threads fault on a truncated region at once, the second one met the default action and
// the process died (shm_view_test in CI: "Bus error", about 1 run in 100). Callers re-check just
// before memory that may fault is touched (WatchMapping, GuardedCopy, KeepSigbusGuardFirst).
void InstallFirst() {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  struct sigaction current {};
  sigaction(SIGBUS, nullptr, &current);
  if ((current.sa_flags & SA_SIGINFO) && current.sa_sigaction == OnSigbus) return;
  struct sigaction action {};
  action.sa_sigaction = OnSigbus;
  action.sa_flags = SA_SIGINFO | SA_NODEFER;
  sigemptyset(&action.sa_mask);
  sigaction(SIGBUS, &action, nullptr);
}

// Kept out of line so that nothing GuardedCopy holds in registers lives across sigsetjmp.
__attribute__((noinline)) void Copy(void *dst, const void *src, size_t bytes) {
  std::memcpy(dst, src, bytes);
}

}  // namespace

int WatchMapping(void *begin, size_t bytes, std::atomic<bool> *lost) {
  InstallFirst();
  static std::mutex mutex;  // between watchers; the handler needs none
  std::lock_guard<std::mutex> lock(mutex);
  for (int i = 0; i < kWatchSlots; ++i) {
    Watch &w = g_watch[i];
    if (w.begin.load(std::memory_order_relaxed) != 0) continue;
    w.end.store(reinterpret_cast<uintptr_t>(begin) + bytes, std::memory_order_relaxed);
    w.lost.store(lost, std::memory_order_relaxed);
    w.begin.store(reinterpret_cast<uintptr_t>(begin), std::memory_order_release);
    g_watched.fetch_add(1, std::memory_order_relaxed);
    return i;
  }
  return -1;
}

void UnwatchMapping(int handle) {
  if (handle < 0 || handle >= kWatchSlots) return;
  if (g_watch[handle].begin.exchange(0, std::memory_order_release) != 0)
    g_watched.fetch_sub(1, std::memory_order_relaxed);
}

void KeepSigbusGuardFirst() {
  if (g_watched.load(std::memory_order_relaxed) > 0) InstallFirst();
}

bool GuardedCopy(void *dst, const void *src, size_t bytes) {
  InstallFirst();
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
