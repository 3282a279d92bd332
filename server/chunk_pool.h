// Parsed stream chunks kept for reuse across streams (issue 12). A chunk's query arrays are
// megabytes; parsed into fresh messages they grow by doubling (each step a new allocation and a
// copy) and fault in fresh pages, for every chunk of every stream. A stream already reuses the
// messages of its own evaluated chunks (ParseChunkReusing in server/service.cpp); this pool hands
// them on to the next stream, so a client's repeated calls parse into memory that is already
// mapped and large enough. Bounded: at most `budget_bytes` of array capacity is kept idle.
#pragma once

#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

#include "glint/v1/glint.pb.h"

namespace glint {

class ChunkMessagePool {
 public:
  explicit ChunkMessagePool(size_t budget_bytes) : budget_bytes_(budget_bytes) {}

  // Moves a kept message's contents (arrays with their capacity) into the empty `*out`;
  // leaves it untouched when none is kept.
  void Take(glint::v1::EvaluateChunk *out);
  // Keeps `*m`'s contents if they fit the budget (`*m` is left empty either way).
  void Give(glint::v1::EvaluateChunk *m);

  size_t kept_bytes() const;

  // Capacity of a chunk's query arrays, in bytes.
  static size_t ArrayBytes(const glint::v1::EvaluateChunk &m);

 private:
  const size_t budget_bytes_;
  mutable std::mutex mu_;
  std::vector<std::unique_ptr<glint::v1::EvaluateChunk>> kept_;
  size_t kept_bytes_ = 0;
};

// The pool of glintd's streams (32 MiB: four 8 MiB chunks, the client library's default size).
ChunkMessagePool &StreamChunkPool();

}  // namespace glint
