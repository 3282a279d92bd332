// A fixed pool of worker threads, one per engine command queue, fed by a bounded queue.
// gRPC handlers only enqueue; evaluation runs here, never on gRPC's threads.
// When the queue is full, TrySubmit fails at once and the caller answers
// RESOURCE_EXHAUSTED: overload fails fast instead of queueing without bound.
// A job computes, then returns how to answer its client; the worker frees the
// job's slot *before* answering, so a client that sends its next request on
// receipt of the last answer never finds the slot still taken by its own work.
//
// Dynamic batching (EnableBatching): a job submitted with a BatchMember may run together with
// other queued members of the same key in one call of the batch job, which answers each of
// them. Every member keeps its own pending slot (queued or running), so --max-pending and the
// memory bound count requests whether batched or not. A worker that takes a member gathers
// the queued members of its key, oldest first, up to max_queries queries in all, and waits up
// to `delay` after the first one's submission for more while the batch is not full. A member
// gathered alone runs its own job, exactly as without batching.
//
// Dead calls (issue 12): a job may come with a Dead check that tells whether its call already
// died (client cancelled or gone, deadline passed) and, if so, how to answer it. A dead queued
// job never runs and does not keep its pending slot: TrySubmit and HasRoom drop the queued dead
// jobs before refusing for a full queue, a worker drops them whenever it takes a job, and
// DropDeadJobs drops them when gRPC reports a call cancelled (its reactor's OnCancel). Its
// answer is given after the lock is released, exactly once (the entry left the queue under it).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace glint {

class Scheduler {
 public:
  using Respond = std::function<void()>;           // answers the client; may be empty
  using Job = std::function<Respond(int worker)>;  // computes on `worker`
  // Called under the scheduler's lock while the job is queued: an empty Respond while the call
  // is alive; for a dead call, how to answer it (its job then never runs). Must be cheap and
  // must not call back into the scheduler.
  using Dead = std::function<Respond()>;

  // What the scheduler needs to know of a batchable job; the service derives its own member
  // type (server/batch_eval.h) and the batch job casts back.
  struct BatchMember {
    virtual ~BatchMember() = default;
    std::string key;       // members with equal keys may share one launch
    uint32_t queries = 0;  // this member's share of BatchOptions::max_queries
  };
  using Members = std::vector<std::shared_ptr<BatchMember>>;
  // Runs `members` (two or more, oldest first) together on `worker`; one Respond per member,
  // in the same order.
  using BatchJob = std::function<std::vector<Respond>(int worker, const Members &members)>;
  struct BatchOptions {
    std::chrono::microseconds delay{0};
    uint32_t max_queries = 0;  // 0: batching off
  };

  Scheduler(int workers, size_t max_pending);
  ~Scheduler();  // runs every queued job, then joins
  Scheduler(const Scheduler &) = delete;
  Scheduler &operator=(const Scheduler &) = delete;

  bool TrySubmit(Job job);
  // As TrySubmit; with batching enabled, `member` (if not null) may be run by the batch job
  // together with others instead of `job`.
  bool TrySubmit(Job job, std::shared_ptr<BatchMember> member);
  // As above; `dead` (may be empty) lets a dead queued job give up its slot (see the header).
  bool TrySubmit(Job job, std::shared_ptr<BatchMember> member, Dead dead);
  // Whether a job submitted now would find a slot, after dropping the queued dead jobs.
  bool HasRoom();
  // Drops the queued dead jobs and answers them now: a call's OnCancel (the client cancelled, went
  // away, or the deadline passed) frees its slot at once instead of when the queue is next full
  // or a worker takes a job, so --max-pending and the queue-depth metric count live calls only.
  void DropDeadJobs();
  // Jobs are accepted and queued but no worker starts one until Release(): glintd holds its
  // workers while the kernel warm-up builds and runs kernels on the same device queues, since a
  // job and a warm-up thread on one queue would share its kernel objects (clSetKernelArg on one
  // cl_kernel from two threads is a data race). Shutdown runs held jobs as it runs queued ones.
  void Hold();
  void Release();
  // Before any job is submitted.
  void EnableBatching(BatchOptions options, BatchJob run);
  const BatchOptions &batching() const { return batching_; }
  size_t pending() const;  // queued + running
  size_t max_pending() const { return max_pending_; }

 private:
  struct Entry {
    Job job;
    std::shared_ptr<BatchMember> member;
    std::chrono::steady_clock::time_point submitted;
    Dead dead;
  };
  void WorkerLoop(int worker);
  // Moves the queued members of `first`'s key into `batch` (under the lock; see the header).
  void Gather(std::unique_lock<std::mutex> &lock, const Entry &first, std::vector<Entry> *batch);
  // Under the lock: removes the queued jobs whose call died and appends their answers.
  void DropDead(std::vector<Respond> *answers);

  const size_t max_pending_;
  BatchOptions batching_;
  BatchJob batch_job_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Entry> queue_;
  size_t running_ = 0;
  bool stopping_ = false;
  bool held_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace glint
