// A fixed pool of worker threads, one per engine command queue, fed by a bounded queue.
// gRPC handlers only enqueue; evaluation runs here, never on gRPC's threads.
// When the queue is full, TrySubmit fails at once and the caller answers
// RESOURCE_EXHAUSTED: overload fails fast instead of queueing without bound.
// A job computes, then returns how to answer its client; the worker frees the
// job's slot *before* answering, so a client that sends its next request on
// receipt of the last answer never finds the slot still taken by its own work.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace glint {

class Scheduler {
 public:
  using Respond = std::function<void()>;           // answers the client; may be empty
  using Job = std::function<Respond(int worker)>;  // computes on `worker`

  Scheduler(int workers, size_t max_pending);
  ~Scheduler();  // runs every queued job, then joins
  Scheduler(const Scheduler &) = delete;
  Scheduler &operator=(const Scheduler &) = delete;

  bool TrySubmit(Job job);
  size_t pending() const;  // queued + running
  size_t max_pending() const { return max_pending_; }

 private:
  void WorkerLoop(int worker);

  const size_t max_pending_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> queue_;
  size_t running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace glint
