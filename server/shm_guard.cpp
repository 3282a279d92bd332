#include "server/shm_guard.h"

#include <setjmp.h>
#include <signal.h>

#include <cstring>
#include <mutex>

namespace glint {
namespace {

// Where the current thread's GuardedCopy wants a SIGBUS to land; null outside one. Initial-exec
// TLS: reading it in the signal handler is then a plain load (no lazy TLS allocation).
__attribute__((tls_model("initial-exec"))) thread_local sigjmp_buf *t_landing = nullptr;
struct sigaction g_previous;

void OnSigbus(int sig, siginfo_t *info, void *context) {
  if (sigjmp_buf *landing = t_landing) siglongjmp(*landing, 1);
  // Not a guarded copy: behave as if we were not installed.
  if ((g_previous.sa_flags & SA_SIGINFO) && g_previous.sa_sigaction) {
    g_previous.sa_sigaction(sig, info, context);
  } else if (g_previous.sa_handler != SIG_DFL && g_previous.sa_handler != SIG_IGN) {
    g_previous.sa_handler(sig);
  } else {
    // Returning re-executes the faulting access, which now takes the default action (core).
    signal(SIGBUS, SIG_DFL);
  }
}

void Install() {
  struct sigaction action {};
  action.sa_sigaction = OnSigbus;
  action.sa_flags = SA_SIGINFO | SA_NODEFER;
  sigemptyset(&action.sa_mask);
  sigaction(SIGBUS, &action, &g_previous);
}

// Kept out of line so that nothing GuardedCopy holds in registers lives across sigsetjmp.
__attribute__((noinline)) void Copy(void *dst, const void *src, size_t bytes) {
  std::memcpy(dst, src, bytes);
}

}  // namespace

bool GuardedCopy(void *dst, const void *src, size_t bytes) {
  static std::once_flag installed;
  std::call_once(installed, Install);
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
