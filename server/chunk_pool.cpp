#include "server/chunk_pool.h"

namespace glint {

size_t ChunkMessagePool::ArrayBytes(const glint::v1::EvaluateChunk &m) {
  if (!m.has_request() || !m.request().has_queries()) return 0;
  const glint::v1::QueryBatch &q = m.request().queries();
  size_t floats = 0;
  for (const auto *a :
       {&q.uv(), &q.footprint(), &q.wo(), &q.wi(), &q.position(), &q.normal(), &q.tangent()})
    floats += size_t(a->Capacity());
  return floats * sizeof(float);
}

void ChunkMessagePool::Take(glint::v1::EvaluateChunk *out) {
  std::unique_ptr<glint::v1::EvaluateChunk> m;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (kept_.empty()) return;
    m = std::move(kept_.back());
    kept_.pop_back();
    kept_bytes_ -= ArrayBytes(*m);
  }
  out->Swap(m.get());
}

void ChunkMessagePool::Give(glint::v1::EvaluateChunk *m) {
  const size_t bytes = ArrayBytes(*m);
  if (bytes == 0) return;
  auto kept = std::make_unique<glint::v1::EvaluateChunk>();
  kept->Swap(m);
  std::lock_guard<std::mutex> lock(mu_);
  if (kept_bytes_ + bytes > budget_bytes_) return;  // freed outside the budget
  kept_bytes_ += bytes;
  kept_.push_back(std::move(kept));
}

size_t ChunkMessagePool::kept_bytes() const {
  std::lock_guard<std::mutex> lock(mu_);
  return kept_bytes_;
}

ChunkMessagePool &StreamChunkPool() {
  static ChunkMessagePool pool(size_t{32} << 20);
  return pool;
}

}  // namespace glint
