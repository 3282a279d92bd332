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

void Scheduler::Hold() {
  std::lock_guard<std::mutex> lock(mutex_);
  held_ = true;
}

void Scheduler::Release() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    held_ = false;
  }
  wake_.notify_all();
}

bool Scheduler::TrySubmit(Job job) {
  return TrySubmit(std::move(job), nullptr);
}

bool Scheduler::TrySubmit(Job job, std::shared_ptr<BatchMember> member) {
  return TrySubmit(std::move(job), std::move(member), nullptr);
}

namespace {

void Answer(std::vector<Scheduler::Respond> *answers) {
  for (Scheduler::Respond &respond : *answers)
    if (respond) respond();
  answers->clear();
}

}  // namespace

void Scheduler::DropDead(std::vector<Respond> *answers) {
  for (auto it = queue_.begin(); it != queue_.end();) {
    Respond answer = it->dead ? it->dead() : Respond();
    if (!answer) {
      ++it;
      continue;
    }
    answers->push_back(std::move(answer));
    it = queue_.erase(it);
  }
}

bool Scheduler::HasRoom() {
  std::vector<Respond> answers;
  bool room;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (queue_.size() + running_ >= max_pending_) DropDead(&answers);
    room = !stopping_ && queue_.size() + running_ < max_pending_;
  }
  Answer(&answers);
  return room;
}

void Scheduler::DropDeadJobs() {
  std::vector<Respond> answers;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    DropDead(&answers);
  }
  Answer(&answers);
}

bool Scheduler::TrySubmit(Job job, std::shared_ptr<BatchMember> member, Dead dead) {
  if (!batching_.max_queries) member.reset();
  const bool gathering = member && batching_.delay.count() > 0;
  std::vector<Respond> answers;
  bool queued = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Full: the slots of queued calls that already died are freed first.
    if (queue_.size() + running_ >= max_pending_) DropDead(&answers);
    if (!stopping_ && queue_.size() + running_ < max_pending_) {
      queue_.push_back(
          {std::move(job), std::move(member), std::chrono::steady_clock::now(), std::move(dead)});
      queued = true;
    }
  }
  Answer(&answers);
  if (!queued) return false;
  // A worker waiting for more members of a batch must hear of this one too, and an idle
  // worker must not miss it because the waiting one took the notification.
  if (gathering)
    wake_.notify_all();
  else
    wake_.notify_one();
  return true;
}

void Scheduler::EnableBatching(BatchOptions options, BatchJob run) {
  std::lock_guard<std::mutex> lock(mutex_);
  batching_ = options;
  batch_job_ = std::move(run);
}

void Scheduler::Gather(std::unique_lock<std::mutex> &lock, const Entry &first,
                       std::vector<Entry> *batch) {
  uint64_t queries = first.member->queries;
  const auto until = first.submitted + batching_.delay;
  for (;;) {
    for (auto it = queue_.begin(); it != queue_.end() && queries < batching_.max_queries;) {
      if (it->member && it->member->key == first.member->key &&
          queries + it->member->queries <= batching_.max_queries) {
        queries += it->member->queries;
        batch->push_back(std::move(*it));
        it = queue_.erase(it);
        ++running_;
      } else {
        ++it;
      }
    }
    if (queries >= batching_.max_queries || stopping_ || std::chrono::steady_clock::now() >= until)
      return;
    wake_.wait_until(lock, until);
  }
}

size_t Scheduler::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size() + running_;
}

void Scheduler::WorkerLoop(int worker) {
  for (;;) {
    Entry first;
    std::vector<Entry> more;  // members gathered with `first`
    std::vector<Respond> dropped;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || (!held_ && !queue_.empty()); });
      // Work whose call died while it waited never starts, here or in a batch.
      DropDead(&dropped);
      if (queue_.empty()) {
        const bool drained = stopping_;  // stopping and drained
        lock.unlock();
        Answer(&dropped);
        if (drained) return;
        continue;
      }
      first = std::move(queue_.front());
      queue_.pop_front();
      ++running_;
      if (first.member) Gather(lock, first, &more);
    }
    Answer(&dropped);
    if (more.empty()) {
      Respond respond = first.job(worker);
      {
        std::lock_guard<std::mutex> lock(mutex_);
        --running_;
      }
      if (respond) respond();
      continue;
    }
    Members members{first.member};
    for (Entry &e : more) members.push_back(e.member);
    std::vector<Respond> responds = batch_job_(worker, members);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      running_ -= members.size();
    }
    for (Respond &respond : responds)
      if (respond) respond();
  }
}

}  // namespace glint
