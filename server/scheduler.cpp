#include "server/scheduler.h"

namespace glint {

Scheduler::Scheduler(int workers, size_t max_pending) : max_pending_(max_pending) {
  for (int worker = 0; worker < workers; ++worker)
    workers_.emplace_back([this, worker] { WorkerLoop(worker); });
}

Scheduler::~Scheduler() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (auto &t : workers_) t.join();
}

bool Scheduler::TrySubmit(Job job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ || queue_.size() + running_ >= max_pending_) return false;
    queue_.push_back(std::move(job));
  }
  wake_.notify_one();
  return true;
}

size_t Scheduler::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size() + running_;
}

void Scheduler::WorkerLoop(int worker) {
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping and drained
      job = std::move(queue_.front());
      queue_.pop_front();
      ++running_;
    }
    Respond respond = job(worker);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      --running_;
    }
    if (respond) respond();
  }
}

}  // namespace glint
