#include "proto/wire/slice_pool.h"

#include <algorithm>
#include <cstdlib>
#include <new>

namespace glint::wire {
namespace {

constexpr size_t kAlign = 128;

size_t RoundUp(size_t bytes) {
  return std::max<size_t>(kAlign, (bytes + kAlign - 1) / kAlign * kAlign);
}

}  // namespace

// What a taken slice carries to its destroy callback: the buffer and the pool it returns to.
struct SlicePool::Lease {
  std::shared_ptr<SlicePool> pool;
  Buffer buffer;
};

std::shared_ptr<SlicePool> SlicePool::Create(size_t max_kept) {
  return std::shared_ptr<SlicePool>(new SlicePool(max_kept));
}

SlicePool::~SlicePool() {
  for (const Buffer &b : idle_) std::free(b.data);
}

grpc_slice SlicePool::Take(size_t bytes, uint8_t **data) {
  Buffer buffer{nullptr, 0};
  {
    std::lock_guard<std::mutex> lock(mu_);
    // The smallest idle buffer that fits: a pool serving chunks of a few sizes keeps each size.
    auto best = idle_.end();
    for (auto it = idle_.begin(); it != idle_.end(); ++it)
      if (it->capacity >= bytes && (best == idle_.end() || it->capacity < best->capacity))
        best = it;
    if (best != idle_.end()) {
      buffer = *best;
      idle_.erase(best);
    }
  }
  if (!buffer.data) {
    buffer.capacity = RoundUp(bytes);
    buffer.data = static_cast<uint8_t *>(std::aligned_alloc(kAlign, buffer.capacity));
    if (!buffer.data) throw std::bad_alloc();
  }
  *data = buffer.data;
  auto *lease = new Lease{shared_from_this(), buffer};
  return grpc_slice_new_with_user_data(buffer.data, bytes, &SlicePool::Return, lease);
}

void SlicePool::Return(void *p) {
  std::unique_ptr<Lease> lease(static_cast<Lease *>(p));
  SlicePool &pool = *lease->pool;
  {
    std::lock_guard<std::mutex> lock(pool.mu_);
    if (pool.idle_.size() < pool.max_kept_) {
      pool.idle_.push_back(lease->buffer);
      return;
    }
    // Full: drop the smallest, which is the least likely to fit the next message.
    auto smallest =
        std::min_element(pool.idle_.begin(), pool.idle_.end(),
                         [](const Buffer &a, const Buffer &b) { return a.capacity < b.capacity; });
    if (smallest != pool.idle_.end() && smallest->capacity < lease->buffer.capacity)
      std::swap(*smallest, lease->buffer);
  }
  std::free(lease->buffer.data);
}

size_t SlicePool::idle_buffers() const {
  std::lock_guard<std::mutex> lock(mu_);
  return idle_.size();
}

size_t SlicePool::idle_bytes() const {
  std::lock_guard<std::mutex> lock(mu_);
  size_t n = 0;
  for (const Buffer &b : idle_) n += b.capacity;
  return n;
}

}  // namespace glint::wire
