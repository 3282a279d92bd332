// Reusable memory for large gRPC message slices (issue 12, "avoid copies ... page faults of fresh
// buffers"). A stream's chunks and replies are megabytes each. Allocated afresh per message they
// come from mmap (glintd sets a 1 MiB M_MMAP_THRESHOLD to bound its RSS, server/main.cpp), so
// every message faulted in and zeroed about a thousand fresh pages and unmapped them again once
// sent: with that threshold a 1M-probe stream on loopback ran at 6 M/s instead of 17 M/s
// (bench_transport, GLIBC_TUNABLES=glibc.malloc.mmap_threshold=1048576). A pool hands out
// buffers whose pages stay mapped: a slice taken from it gives its buffer back when gRPC drops
// the slice's last reference (after the bytes are on the socket), from whatever thread that is.
// At most `max_kept` idle buffers are kept, so the memory held when idle is bounded by
// max_kept x the largest message.
#pragma once

#include <grpc/slice.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace glint::wire {

class SlicePool : public std::enable_shared_from_this<SlicePool> {
 public:
  static std::shared_ptr<SlicePool> Create(size_t max_kept);
  ~SlicePool();
  SlicePool(const SlicePool &) = delete;
  SlicePool &operator=(const SlicePool &) = delete;

  // A slice of exactly `bytes` bytes (contents undefined) whose memory, 128-byte aligned (PoCL's
  // CL_MEM_USE_HOST_PTR base alignment), is `*data`. The slice keeps the pool alive.
  grpc_slice Take(size_t bytes, uint8_t **data);

  // Idle buffers and their total capacity (tests, diagnostics).
  size_t idle_buffers() const;
  size_t idle_bytes() const;

 private:
  explicit SlicePool(size_t max_kept) : max_kept_(max_kept) {}
  struct Buffer {
    uint8_t *data;
    size_t capacity;
  };
  struct Lease;
  static void Return(void *lease);

  const size_t max_kept_;
  mutable std::mutex mu_;
  std::vector<Buffer> idle_;
};

}  // namespace glint::wire
