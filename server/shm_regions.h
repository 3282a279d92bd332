// Same-host shared memory (README "Shared memory", glint.proto SharedMemoryIo), after Triton's
// system shared-memory extension: a client creates a POSIX shared-memory object, registers a
// window of it, and names the region in Evaluate instead of sending arrays.
//
// The registry maps each registered window once (MAP_SHARED, read-write) and keeps the object's
// descriptor, so a later size check (fstat) sees the object as it is now even after the client
// unlinked its name. Regions belong to an owner: the caller's bearer token when the server has
// --auth-tokens, else the whole server (every loopback client shares one namespace). A region in
// use by a running call stays mapped until that call is done, even when unregistered meanwhile.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/status.h"

namespace glint {

struct ShmLimits {
  uint32_t max_regions = 16;               // per owner; 0 disables shared memory
  uint64_t max_bytes = uint64_t(4) << 30;  // registered window bytes per owner
  // Obsolete (--shm-direct-output, accepted and ignored): the kernels always write the radiance
  // straight into the output region now, because every mapping is watched (server/shm_guard.h
  // WatchMapping): a client that shrinks its object mid-call loses its own call, not the server.
  bool direct_output = false;
};

// One registered window, mapped. Immutable once made; unmapped when the last holder lets go.
class ShmRegion {
 public:
  ~ShmRegion();
  const glint::v1::SharedMemoryRegion &info() const { return info_; }
  uint8_t *data() const { return window_; }
  // OK when the window [offset, offset + bytes) of this region still lies inside the object
  // (fstat now: the client may have truncated it since registration). `field` names the request
  // field in the message.
  // Also refused once the region is lost().
  Status CheckRange(uint64_t offset, uint64_t bytes, const std::string &field) const;
  // True once a thread faulted on the mapping (its object shrank under it) and the SIGBUS
  // handler replaced the mapping by zero pages (server/shm_guard.h): the region no longer shows
  // the client's object, and every later call on it is refused.
  bool lost() const { return lost_.load(std::memory_order_acquire); }
  // Whether `other` maps the same shared-memory object (the file's device and inode, so two
  // regions registered under different names or windows of one object are recognised).
  bool SameObject(const ShmRegion &other) const { return dev_ == other.dev_ && ino_ == other.ino_; }

 private:
  friend class ShmRegistry;
  ShmRegion() = default;
  glint::v1::SharedMemoryRegion info_;
  int fd_ = -1;
  void *map_ = nullptr;  // page-aligned start of the mapping
  size_t map_bytes_ = 0;
  uint8_t *window_ = nullptr;  // map_ + (offset % page size)
  mutable std::atomic<bool> lost_{false};
  int watch_ = -1;              // WatchMapping handle
  uint64_t dev_ = 0, ino_ = 0;  // fstat of the object at registration (SameObject)
};

class ShmRegistry {
 public:
  explicit ShmRegistry(ShmLimits limits = {}) : limits_(limits) {}
  const ShmLimits &limits() const { return limits_; }

  // Opens, checks and maps the window. INVALID_ARGUMENT names the field (name, key, offset,
  // byte_size); NOT_FOUND when no object has that key; ALREADY-registered names are refused
  // (INVALID_ARGUMENT); RESOURCE_EXHAUSTED beyond the owner's limits.
  Status Register(const std::string &owner, const glint::v1::RegisterSharedMemoryRequest &r);
  std::vector<glint::v1::SharedMemoryRegion> List(const std::string &owner) const;
  // `name` empty: every region of the owner. NOT_FOUND for an unknown name.
  Status Unregister(const std::string &owner, const std::string &name);
  // The owner's region `name` (NOT_FOUND naming `field` otherwise).
  Status Find(const std::string &owner, const std::string &name, const std::string &field,
              std::shared_ptr<const ShmRegion> *out) const;
  // Drops every region (shutdown); mappings in use by a call go when the call is done.
  void Clear();
  uint64_t total_bytes() const;

 private:
  ShmLimits limits_;
  mutable std::mutex mutex_;
  // owner -> name -> region
  std::map<std::string, std::map<std::string, std::shared_ptr<const ShmRegion>>> regions_;
};

// Checks a region name ([A-Za-z0-9._-], 1-64 characters) and a key (shm_open: a leading '/', no
// other '/', 2-255 characters, no NUL).
Status ValidateRegionName(const std::string &name, const std::string &field);

// Whether the input window [in_offset, in_offset + in_bytes) of `in` and the output window
// [out_offset, out_offset + out_bytes) of `out` (offsets within the registered windows) share a
// byte of one object (regions over the same object at different offsets included: the overlap
// is a property of the object's bytes). Such a call must not be evaluated in place: the kernels
// would read the queries while writing the radiance, so a query whose input bytes another
// query's radiance overwrote would be evaluated from those bytes, wrong and different from run
// to run (found by the session 9 outside-client probe). RunShared copies its queries out of
// the region first instead (server/shm_io.h EvaluatesInPlace), which makes the overlap harmless.
bool WindowsOverlap(const ShmRegion &in, uint64_t in_offset, uint64_t in_bytes,
                    const ShmRegion &out, uint64_t out_offset, uint64_t out_bytes);
Status ValidateShmKey(const std::string &key, const std::string &field);

}  // namespace glint
