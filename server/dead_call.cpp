// Queued work whose call already died (issue 12): the client cancelled or went away, or the
// deadline passed. Such a job must neither start nor keep a --max-pending slot that a live
// client could use; the scheduler asks this check while the job waits (server/scheduler.h).
#include "server/service.h"

namespace glint {

Scheduler::Dead GlintServiceImpl::DeadCall(grpc::CallbackServerContext *ctx, std::string what,
                                           uint64_t queries,
                                           std::function<void(const Status &)> finish) {
  // Runs under the scheduler's lock, while the job is queued: the call is not finished yet (only
  // the job or this answer finishes it), so `ctx` is alive. IsCancelled and the deadline are
  // cheap reads; the answer itself runs after the lock is released.
  return [this, ctx, what = std::move(what), queries,
          finish = std::move(finish)]() -> Scheduler::Respond {
    Status reason = StopReason(ctx);
    if (reason.ok()) return {};
    abandoned_.Count(reason, queries);  // dropped before its first slice: none was computed
    return [this, what, finish, reason] {
      LogLine(what + " dropped from the queue: " + reason.message());
      finish(reason);
    };
  };
}

}  // namespace glint
