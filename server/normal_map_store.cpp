#include "server/normal_map_store.h"

#include <algorithm>
#include <new>
#include <string>

#include "models/normal_map/normal_map_params.h"
#include "models/normal_map/normal_map_table.h"
#include "server/normal_map_decode.h"

namespace glint {
namespace {

uint64_t TableBytes(const NormalMapTable &t) {
  return t ? t->size() * sizeof(float) : 0;
}

std::string MiB(uint64_t bytes) {
  return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB";
}

Status NotHeld(const std::string &digest) {
  return Status::NotFound("material.normal_map.digest: " + digest +
                          " is not held by this server (never uploaded, deleted or evicted); "
                          "upload the map again (UploadNormalMap, glint upload)");
}

// Subdivision 4 of a w x h map within the texel limit and the table's side limit.
Status SubdivisionFits(uint32_t w, uint32_t h, uint64_t max_texels) {
  if (uint64_t(w) * h * 16 > max_texels || 4ull * w > GLINT_NM_MAX_SIDE ||
      4ull * h > GLINT_NM_MAX_SIDE)
    return Status::InvalidArgument(
        "material.normal_map.subdivision: 4 turns the " + std::to_string(w) + "x" +
        std::to_string(h) + " map into " + std::to_string(uint64_t(w) * h * 16) +
        " sub-texels, over the server's limit of " + std::to_string(max_texels) +
        " (Capabilities.max_normal_map_texels); expected subdivision 1 for this map");
  return Status::Ok();
}

}  // namespace

bool IsNormalMapDigest(const std::string &d) {
  if (d.size() != 7 + 64 || d.compare(0, 7, "sha256:") != 0) return false;
  for (size_t k = 7; k < d.size(); ++k)
    if (!((d[k] >= '0' && d[k] <= '9') || (d[k] >= 'a' && d[k] <= 'f'))) return false;
  return true;
}

Status CheckNormalMapFilename(const std::string &filename) {
  if (filename.size() <= kMaxNormalMapFilenameBytes) return Status::Ok();
  return Status::InvalidArgument(
      "filename: \"" + filename.substr(0, 32) + "...\" has " + std::to_string(filename.size()) +
      " bytes; expected a file name of at most " + std::to_string(kMaxNormalMapFilenameBytes) +
      " bytes ending in .exr or .png (it picks the decoder and is listed with the map)");
}

NormalMapStore &NormalMaps() {
  static NormalMapStore store;
  return store;
}

NormalMapLimits NormalMapStore::limits() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return limits_;
}

void NormalMapStore::Configure(const NormalMapLimits &limits) {
  std::lock_guard<std::mutex> lock(mutex_);
  limits_ = limits;
  EvictLocked("");
}

uint64_t NormalMapStore::bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return bytes_;
}

void NormalMapStore::TouchLocked(Entry &e) {
  lru_.splice(lru_.begin(), lru_, e.lru);
}

void NormalMapStore::EvictLocked(const std::string &keep) {
  auto it = lru_.end();
  while (bytes_ > limits_.budget_bytes && it != lru_.begin()) {
    --it;
    if (*it == keep) continue;
    auto m = maps_.find(*it);
    bytes_ -= m->second.info.bytes();
    maps_.erase(m);
    it = lru_.erase(it);
  }
}

Status NormalMapStore::Upload(const std::string &filename, const std::string &bytes,
                              glint::v1::NormalMapInfo *info) {
  if (Status named = CheckNormalMapFilename(filename); !named.ok()) return named;
  const NormalMapLimits limits = this->limits();
  if (bytes.size() > limits.max_upload_bytes)
    return Status::InvalidArgument("normal map " + filename + ": " + std::to_string(bytes.size()) +
                                   " bytes; the server accepts at most " +
                                   std::to_string(limits.max_upload_bytes) +
                                   " (Capabilities.max_normal_map_upload_bytes)");
  if (bytes.empty())
    return Status::InvalidArgument("normal map " + filename +
                                   ": empty upload; expected the bytes "
                                   "of an .exr or .png file");
  // Decoding and preprocessing run outside the lock: uploads do not block requests.
  DecodedNormalMap map;
  Status s = DecodeNormalMap(filename, bytes, limits.max_texels, &map);
  if (!s.ok()) return s;
  return Insert(filename, map, info);
}

Status NormalMapStore::Insert(const std::string &filename, const DecodedNormalMap &map,
                              glint::v1::NormalMapInfo *info) {
  const NormalMapLimits limits = this->limits();
  const std::string digest = NormalMapDigest(map);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = maps_.find(digest); it != maps_.end()) {
      TouchLocked(it->second);
      *info = it->second.info;
      info->set_already_present(true);
      return Status::Ok();
    }
  }
  std::vector<float> st(size_t(map.width) * map.height * 2);
  for (size_t t = 0; t < st.size() / 2; ++t) {
    st[2 * t] = map.xyz[3 * t];
    st[2 * t + 1] = map.xyz[3 * t + 1];
  }
  auto table =
      std::make_shared<const std::vector<float>>(BuildNormalMapTable(map.width, map.height, st, 1));
  const uint64_t need = TableBytes(table);
  if (need > limits.budget_bytes)
    return Status::ResourceExhausted("normal map " + filename + ": needs " + MiB(need) +
                                     " on the server, more than its whole budget of " +
                                     MiB(limits.budget_bytes) + " (--normal-map-budget-mb)");
  std::lock_guard<std::mutex> lock(mutex_);
  if (auto it = maps_.find(digest); it != maps_.end()) {  // a concurrent upload of the same map
    TouchLocked(it->second);
    *info = it->second.info;
    info->set_already_present(true);
    return Status::Ok();
  }
  Entry &e = maps_[digest];
  e.info.set_digest(digest);
  e.info.set_width(map.width);
  e.info.set_height(map.height);
  e.info.set_bytes(need);
  e.info.set_filename(filename);
  e.tables[0] = std::move(table);
  lru_.push_front(digest);
  e.lru = lru_.begin();
  bytes_ += need;
  *info = e.info;
  EvictLocked(digest);
  return Status::Ok();
}

Status NormalMapStore::Table(const std::string &digest, int subdivision, NormalMapTable *out) {
  const int slot = subdivision == 4 ? 1 : 0;
  std::promise<BuildResult> promise;
  std::unique_lock<std::mutex> lock(mutex_);
  auto it = maps_.find(digest);
  if (it == maps_.end()) return NotHeld(digest);
  TouchLocked(it->second);
  if (it->second.tables[slot]) {
    *out = it->second.tables[slot];
    return Status::Ok();
  }
  if (auto b = building_.find(digest); b != building_.end()) {
    const std::shared_future<BuildResult> pending = b->second;
    lock.unlock();  // wait for the other request's build without holding the store
    *out = pending.get().second;
    return pending.get().first;
  }
  building_.emplace(digest, promise.get_future().share());
  lock.unlock();
  BuildResult result;
  try {  // the waiters must hear of a failure too (a broken promise would throw in them)
    result.first = BuildSubdivided(digest, &result.second);
  } catch (const std::bad_alloc &) {
    result.first = Status::ResourceExhausted(
        "material.normal_map.subdivision: 4: out of memory "
        "building the table of " +
        digest);
  }
  lock.lock();
  building_.erase(digest);
  lock.unlock();
  promise.set_value(result);
  *out = result.second;
  return result.first;
}

Status NormalMapStore::BuildSubdivided(const std::string &digest, NormalMapTable *out) {
  NormalMapTable base;
  uint32_t w = 0, h = 0;
  uint64_t max_texels = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = maps_.find(digest);
    if (it == maps_.end()) return NotHeld(digest);
    base = it->second.tables[0];
    w = it->second.info.width();
    h = it->second.info.height();
    max_texels = limits_.max_texels;
  }
  if (Status s = SubdivisionFits(w, h, max_texels); !s.ok()) return s;
  std::vector<float> st(base->begin() + GLINT_NM_HEADER_FLOATS,
                        base->begin() + GLINT_NM_HEADER_FLOATS + ptrdiff_t(w) * h * 2);
  auto table = std::make_shared<const std::vector<float>>(BuildNormalMapTable(w, h, st, 4));
  if (TableBytes(base) + TableBytes(table) > limits().budget_bytes)
    return Status::ResourceExhausted("material.normal_map.subdivision: 4 needs " +
                                     MiB(TableBytes(table)) + " more on the server for " + digest +
                                     ", over its budget of " + MiB(limits().budget_bytes) +
                                     " (--normal-map-budget-mb); expected subdivision 1 here");
  std::lock_guard<std::mutex> lock(mutex_);
  ++subdivision_builds_;
  auto it = maps_.find(digest);
  if (it != maps_.end() && !it->second.tables[1]) {  // still held: keep the new table
    it->second.tables[1] = table;
    it->second.info.set_bytes(it->second.info.bytes() + TableBytes(table));
    bytes_ += TableBytes(table);
    EvictLocked(digest);
  } else if (it != maps_.end()) {
    table = it->second.tables[1];
  }
  *out = table;
  return Status::Ok();
}

uint64_t NormalMapStore::subdivision_builds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return subdivision_builds_;
}

Status NormalMapStore::Check(const std::string &digest, int subdivision) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = maps_.find(digest);
  if (it == maps_.end()) return NotHeld(digest);
  if (subdivision != 4 || it->second.tables[1]) return Status::Ok();
  return SubdivisionFits(it->second.info.width(), it->second.info.height(), limits_.max_texels);
}

namespace {

// A page token is the last digest of the page before, behind a prefix that marks it as ours.
// The order is the digests' (maps_ is sorted by them), not recency: recency changes with every
// request that uses a map, so pages in that order skipped and repeated maps between calls.
constexpr const char *kPageTokenPrefix = "after:";

}  // namespace

Status NormalMapStore::List(const glint::v1::ListNormalMapsRequest &request,
                            glint::v1::ListNormalMapsResponse *out) const {
  if (request.page_size() < 0) {
    return Status::InvalidArgument("page_size: " + std::to_string(request.page_size()) +
                                   "; expected 0 (the default, " +
                                   std::to_string(kDefaultNormalMapPageSize) + ") or more");
  }
  const size_t page_size = request.page_size() == 0 ? kDefaultNormalMapPageSize
                                                    : std::min<size_t>(size_t(request.page_size()),
                                                                       kMaxNormalMapPageSize);
  std::string after;
  if (!request.page_token().empty()) {
    const std::string &token = request.page_token();
    const size_t prefix = std::char_traits<char>::length(kPageTokenPrefix);
    if (token.compare(0, prefix, kPageTokenPrefix) != 0 ||
        !IsNormalMapDigest(token.substr(prefix))) {
      return Status::InvalidArgument(
          "page_token: not a token this server made; pass a previous reply's next_page_token, "
          "or none for the first page");
    }
    after = token.substr(prefix);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = after.empty() ? maps_.begin() : maps_.upper_bound(after);
  for (; it != maps_.end() && size_t(out->maps_size()) < page_size; ++it)
    *out->add_maps() = it->second.info;
  if (it != maps_.end())
    out->set_next_page_token(kPageTokenPrefix + out->maps().rbegin()->digest());
  return Status::Ok();
}

Status NormalMapStore::Delete(const std::string &digest) {
  // A malformed digest is the client's mistake, not a map this server lacks: say what a digest
  // looks like (as material.normal_map.digest's refusal does) instead of NOT_FOUND, which tells
  // the client to upload again (outside-client probe, session 11).
  if (!IsNormalMapDigest(digest)) {
    const std::string shown = digest.size() <= 80 ? digest : digest.substr(0, 80) + "...";
    return Status::InvalidArgument(
        "digest: \"" + shown +
        "\"; expected \"sha256:\" and 64 lowercase hex digits, as UploadNormalMap returns");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = maps_.find(digest);
  if (it == maps_.end())
    return Status::NotFound("digest: " + digest + " is not held by this server");
  bytes_ -= it->second.info.bytes();
  lru_.erase(it->second.lru);
  maps_.erase(it);
  return Status::Ok();
}

}  // namespace glint
