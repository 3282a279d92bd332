#include "server/shm_regions.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "server/shm_guard.h"

namespace glint {
namespace {

std::string Errno() {
  return std::strerror(errno);
}

}  // namespace

Status ValidateRegionName(const std::string &name, const std::string &field) {
  if (name.empty() || name.size() > 64)
    return Status::InvalidArgument(field + ": " + std::to_string(name.size()) +
                                   " characters; expected 1 to 64");
  for (char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok)
      return Status::InvalidArgument(field + ": \"" + name +
                                     "\" has a character outside [A-Za-z0-9._-]");
  }
  return Status::Ok();
}

Status ValidateShmKey(const std::string &key, const std::string &field) {
  // shm_open(3): "a null-terminated string of up to NAME_MAX (255) characters consisting of an
  // initial slash, followed by one or more characters, none of which are slashes".
  if (key.size() < 2 || key.size() > 255)
    return Status::InvalidArgument(field + ": " + std::to_string(key.size()) +
                                   " characters; expected 2 to 255 (shm_open name)");
  if (key[0] != '/')
    return Status::InvalidArgument(field + ": \"" + key +
                                   "\" must start with '/' (shm_open name, e.g. /glint-1234)");
  if (key.find('/', 1) != std::string::npos)
    return Status::InvalidArgument(field + ": \"" + key +
                                   "\" has a '/' after the first character (shm_open name)");
  if (key.find('\0') != std::string::npos || key == "/." || key == "/..")
    return Status::InvalidArgument(field + ": not a valid shm_open name");
  return Status::Ok();
}

ShmRegion::~ShmRegion() {
  UnwatchMapping(watch_);
  if (map_) munmap(map_, map_bytes_);
  if (fd_ >= 0) close(fd_);
}

Status ShmRegion::CheckRange(uint64_t offset, uint64_t bytes, const std::string &field) const {
  const uint64_t size = info_.byte_size();
  // Said apart from the range below, whose end offset + bytes would wrap past 2^64.
  if (offset > size)
    return Status::InvalidArgument(field + ": " + std::to_string(offset) +
                                   " lies beyond region \"" + info_.name() + "\" of " +
                                   std::to_string(size) + " bytes");
  if (bytes > size - offset)
    return Status::InvalidArgument(field + ": bytes [" + std::to_string(offset) + ", " +
                                   std::to_string(offset + bytes) + ") lie beyond region \"" +
                                   info_.name() + "\" of " + std::to_string(size) + " bytes");
  if (lost())
    return Status::FailedPrecondition(
        field + ": region \"" + info_.name() + "\" lost its pages in an earlier call (object " +
        info_.key() +
        " was truncated while the server used it); unregister it and register it "
        "again");
  struct stat st {};
  if (fstat(fd_, &st) != 0)
    return Status::Internal("fstat of region \"" + info_.name() + "\" failed: " + Errno());
  const uint64_t need = info_.offset() + offset + bytes;
  if (uint64_t(st.st_size) < need)
    return Status::InvalidArgument(field + ": region \"" + info_.name() + "\" (object " +
                                   info_.key() + ") is now " + std::to_string(st.st_size) +
                                   " bytes, truncated since registration; the call needs " +
                                   std::to_string(need));
  return Status::Ok();
}

bool WindowsOverlap(const ShmRegion &in, uint64_t in_offset, uint64_t in_bytes,
                    const ShmRegion &out, uint64_t out_offset, uint64_t out_bytes) {
  if (!in.SameObject(out) || in_bytes == 0 || out_bytes == 0) return false;
  // Byte ranges within the object; both windows passed CheckRange, so none of these wrap.
  const uint64_t in_begin = in.info().offset() + in_offset, in_end = in_begin + in_bytes;
  const uint64_t out_begin = out.info().offset() + out_offset, out_end = out_begin + out_bytes;
  return !(out_end <= in_begin || in_end <= out_begin);
}

Status ShmRegistry::Register(const std::string &owner,
                             const glint::v1::RegisterSharedMemoryRequest &r) {
  if (limits_.max_regions == 0)
    return Status::FailedPrecondition(
        "shared memory is disabled on this server (--max-shm-regions 0)");
  Status s = ValidateRegionName(r.name(), "name");
  if (s.ok()) s = ValidateShmKey(r.key(), "key");
  if (!s.ok()) return s;
  if (r.byte_size() == 0) return Status::InvalidArgument("byte_size: 0; expected at least 1");
  if (r.byte_size() > limits_.max_bytes)
    return Status::ResourceExhausted("byte_size: " + std::to_string(r.byte_size()) +
                                     " exceeds the limit of " + std::to_string(limits_.max_bytes) +
                                     " bytes (--max-shm-mb)");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = regions_.find(owner);
    if (it != regions_.end()) {
      if (it->second.count(r.name()))
        return Status::InvalidArgument("name: a region \"" + r.name() +
                                       "\" is already registered; unregister it first");
      if (it->second.size() >= limits_.max_regions)
        return Status::ResourceExhausted("regions: " + std::to_string(it->second.size()) +
                                         " registered, the limit (--max-shm-regions)");
    }
  }
  const int fd = shm_open(r.key().c_str(), O_RDWR, 0);
  if (fd < 0) {
    if (errno == ENOENT)
      return Status::NotFound("key: no shared-memory object " + r.key() +
                              " on the server's host (create it with shm_open first)");
    return Status::InvalidArgument("key: shm_open(" + r.key() + ") failed: " + Errno());
  }
  auto region = std::shared_ptr<ShmRegion>(new ShmRegion());
  region->fd_ = fd;
  struct stat st {};
  if (fstat(fd, &st) != 0) return Status::Internal("fstat(" + r.key() + ") failed: " + Errno());
  region->dev_ = uint64_t(st.st_dev);
  region->ino_ = uint64_t(st.st_ino);
  const uint64_t size = uint64_t(st.st_size);
  if (r.offset() >= size)
    return Status::InvalidArgument("offset: " + std::to_string(r.offset()) + " is not inside " +
                                   r.key() + " of " + std::to_string(size) + " bytes");
  if (r.byte_size() > size - r.offset())
    return Status::InvalidArgument("byte_size: " + std::to_string(r.byte_size()) + " at offset " +
                                   std::to_string(r.offset()) + " runs past the end of " + r.key() +
                                   " (" + std::to_string(size) + " bytes)");
  const uint64_t page = uint64_t(sysconf(_SC_PAGESIZE));
  const uint64_t base = r.offset() / page * page;
  region->map_bytes_ = size_t(r.offset() - base + r.byte_size());
  void *map =
      mmap(nullptr, region->map_bytes_, PROT_READ | PROT_WRITE, MAP_SHARED, fd, off_t(base));
  if (map == MAP_FAILED)
    return Status::InvalidArgument("key: mmap of " + r.key() + " failed: " + Errno());
  region->map_ = map;
  region->watch_ = WatchMapping(map, region->map_bytes_, &region->lost_);
  if (region->watch_ < 0)
    return Status::ResourceExhausted("regions: " + std::to_string(kWatchSlots) +
                                     " mapped on this server, the most it watches at once");
  region->window_ = static_cast<uint8_t *>(map) + (r.offset() - base);
  region->info_.set_name(r.name());
  region->info_.set_key(r.key());
  region->info_.set_offset(r.offset());
  region->info_.set_byte_size(r.byte_size());

  std::lock_guard<std::mutex> lock(mutex_);
  auto &mine = regions_[owner];
  // Checked again under the lock: another call may have registered meanwhile.
  if (mine.count(r.name()))
    return Status::InvalidArgument("name: a region \"" + r.name() +
                                   "\" is already registered; unregister it first");
  if (mine.size() >= limits_.max_regions)
    return Status::ResourceExhausted("regions: " + std::to_string(mine.size()) +
                                     " registered, the limit (--max-shm-regions)");
  uint64_t bytes = 0;
  for (const auto &[n, reg] : mine) bytes += reg->info().byte_size();
  if (bytes + r.byte_size() > limits_.max_bytes)
    return Status::ResourceExhausted(
        "byte_size: " + std::to_string(r.byte_size()) + " more bytes would exceed the limit of " +
        std::to_string(limits_.max_bytes) + " registered bytes (--max-shm-mb); " +
        std::to_string(bytes) + " already registered");
  mine.emplace(r.name(), std::move(region));
  return Status::Ok();
}

std::vector<glint::v1::SharedMemoryRegion> ShmRegistry::List(const std::string &owner) const {
  std::vector<glint::v1::SharedMemoryRegion> out;
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = regions_.find(owner);
  if (it == regions_.end()) return out;
  for (const auto &[name, region] : it->second) out.push_back(region->info());
  return out;
}

Status ShmRegistry::Unregister(const std::string &owner, const std::string &name) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = regions_.find(owner);
  if (name.empty()) {
    if (it != regions_.end()) regions_.erase(it);
    return Status::Ok();
  }
  if (it == regions_.end() || !it->second.erase(name))
    return Status::NotFound("name: no region \"" + name + "\" registered by this client");
  if (it->second.empty()) regions_.erase(it);
  return Status::Ok();
}

Status ShmRegistry::Find(const std::string &owner, const std::string &name,
                         const std::string &field, std::shared_ptr<const ShmRegion> *out) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = regions_.find(owner);
  if (it != regions_.end()) {
    auto r = it->second.find(name);
    if (r != it->second.end()) {
      *out = r->second;
      return Status::Ok();
    }
  }
  return Status::NotFound(field + ": no region \"" + name +
                          "\" registered by this client (RegisterSharedMemory first)");
}

void ShmRegistry::Clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  regions_.clear();
}

uint64_t ShmRegistry::total_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  uint64_t bytes = 0;
  for (const auto &[owner, mine] : regions_)
    for (const auto &[name, region] : mine) bytes += region->info().byte_size();
  return bytes;
}

}  // namespace glint
