// Bytes of answered unary replies that their clients have not taken yet.
//
// The scheduler frees a request's --max-pending slot before answering it (so that a client's
// next request never finds the slot still held by its own work), so a reply waiting on a client
// that does not read (full HTTP/2 window) was held outside every bound: 30 such clients took
// glintd from 172 MB to 744 MB at --max-pending 2 (an outside-client probe). Each reply is
// counted from Finish until gRPC's OnDone (its bytes have left or the call died), and new
// Evaluate, Sample and ModelInfer calls are refused with RESOURCE_EXHAUSTED and a retry pushback
// while the count is at the limit (--max-undelivered-mb), which adds that limit to the memory
// bound.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "server/status.h"

namespace glint {

class DeliveryBudget {
 public:
  explicit DeliveryBudget(uint64_t limit_bytes) : limit_(limit_bytes) {}

  void Hold(uint64_t bytes) { held_.fetch_add(bytes, std::memory_order_relaxed); }
  void Release(uint64_t bytes) { held_.fetch_sub(bytes, std::memory_order_relaxed); }
  // True when a new reply must wait: the held bytes reached the limit.
  bool Full() const { return held_.load(std::memory_order_relaxed) >= limit_; }
  // New work that would add a reply (Evaluate, Sample, ModelInfer) is refused while Full():
  // RESOURCE_EXHAUSTED naming the flag, a refusal that can succeed later (the caller adds the
  // retry pushback). OK otherwise.
  Status Admit() const {
    if (!Full()) return Status::Ok();
    return Status::ResourceExhausted(
        "server busy: " + std::to_string(held() >> 20) +
        " MiB of answered replies not yet read by their clients (--max-undelivered-mb " +
        std::to_string(limit() >> 20) + "); retry later or send to another replica");
  }
  uint64_t held() const { return held_.load(std::memory_order_relaxed); }
  uint64_t limit() const { return limit_; }

 private:
  const uint64_t limit_;
  std::atomic<uint64_t> held_{0};
};

}  // namespace glint
