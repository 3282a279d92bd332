// Normal maps as server resources (issue 11): content-addressed by the SHA-256 of the decoded
// normals (server/normal_map_decode.h), preprocessed once per map and subdivision into the
// NORMAL_MAP model's table (models/normal_map/normal_map_table.h), held under a memory budget
// with least-recently-used eviction. Requests name a map by digest; a missing one is NOT_FOUND
// naming the digest, so a client uploads it again (to whichever replica answered).
//
// Thread-safe. Tables are handed out as shared_ptr: an evicted or deleted map stays alive for
// the requests already holding it.
#pragma once

#include <cstdint>
#include <future>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "server/normal_map_decode.h"
#include "server/status.h"

namespace glint {

struct NormalMapLimits {
  uint64_t budget_bytes = uint64_t{1024} << 20;     // glintd --normal-map-budget-mb
  uint64_t max_upload_bytes = uint64_t{256} << 20;  // one file
  uint64_t max_texels = uint64_t{4096} * 4096;      // width x height (x16 with subdivision 4)
};

using NormalMapTable = std::shared_ptr<const std::vector<float>>;

class NormalMapStore {
 public:
  explicit NormalMapStore(NormalMapLimits limits = {}) : limits_(limits) {}

  NormalMapLimits limits() const;
  // Changes the limits (glintd's flags); evicts down to the new budget.
  void Configure(const NormalMapLimits &limits);

  // Decodes, hashes and preprocesses (subdivision 1) one file. Storing an existing digest only
  // refreshes it (info->already_present). Bad files: INVALID_ARGUMENT; a map larger than the
  // whole budget: RESOURCE_EXHAUSTED. Nothing is stored on failure.
  Status Upload(const std::string &filename, const std::string &bytes,
                glint::v1::NormalMapInfo *info);
  // Upload after decoding: stores already decoded normals (generated maps, warm-up, tests).
  Status Insert(const std::string &filename, const DecodedNormalMap &map,
                glint::v1::NormalMapInfo *info);

  // The model table of `digest` at `subdivision` (1 or 4; 4 is built on first use and kept
  // under the budget). NOT_FOUND naming the digest when the store does not hold it.
  Status Table(const std::string &digest, int subdivision, NormalMapTable *out);
  // What Table would refuse without building anything (cheap, for validation on a gRPC handler
  // thread): NOT_FOUND naming the digest, subdivision 4 over the texel limit. Building a
  // subdivision-4 table (seconds for a large map) is left to Table, which the request's worker
  // calls (ResolveRequestTable); its budget refusal comes from there.
  Status Check(const std::string &digest, int subdivision);

  // One page of the held maps in digest order (AIP-158 paging, glint.proto
  // ListNormalMapsRequest): INVALID_ARGUMENT naming page_size (negative) or page_token (not one
  // this store made).
  Status List(const glint::v1::ListNormalMapsRequest &request,
              glint::v1::ListNormalMapsResponse *out) const;
  Status Delete(const std::string &digest);
  uint64_t bytes() const;
  // Subdivision-4 tables built since the store was made (each map's is built once however many
  // requests ask for it at the same time).
  uint64_t subdivision_builds() const;

 private:
  struct Entry {
    glint::v1::NormalMapInfo info;  // bytes = the sum of its tables
    NormalMapTable tables[2];       // subdivision 1, 4
    std::list<std::string>::iterator lru;
  };
  // Drops least recently used maps (never `keep`) until the total fits the budget.
  void EvictLocked(const std::string &keep);
  void TouchLocked(Entry &e);
  // Builds the subdivision-4 table of `digest` (outside the lock) and stores it.
  Status BuildSubdivided(const std::string &digest, NormalMapTable *out);

  using BuildResult = std::pair<Status, NormalMapTable>;

  mutable std::mutex mutex_;
  NormalMapLimits limits_;
  std::map<std::string, Entry> maps_;
  std::list<std::string> lru_;  // most recent first
  uint64_t bytes_ = 0;
  // Subdivision-4 builds in progress, by digest: a second request for the same table waits for
  // the first one's instead of building it again (seconds of a worker for a large map).
  std::map<std::string, std::shared_future<BuildResult>> building_;
  uint64_t subdivision_builds_ = 0;
};

// ListNormalMaps page sizes: page_size 0 means the default; larger than the maximum is read as
// the maximum. A full page of 255-byte file names serializes to ~0.4 MB, within the smallest
// --max-message-mb (1), so no reply outgrows the message limit however many maps are held.
constexpr size_t kDefaultNormalMapPageSize = 100;
constexpr size_t kMaxNormalMapPageSize = 1000;

// The process's store (glintd configures it from its flags; the NORMAL_MAP model reads it).
NormalMapStore &NormalMaps();

// "sha256:" followed by 64 lowercase hex digits.
bool IsNormalMapDigest(const std::string &digest);

// The longest NormalMapChunk.filename accepted (NAME_MAX). The name is stored with the map and
// returned by every UploadNormalMap and ListNormalMaps reply, so an unbounded one (a chunk may
// carry ~max-message-mb of it) made those replies exceed the message limit: two 0.9 MB names
// at --max-message-mb 1 broke ListNormalMaps for every client until the maps were deleted.
constexpr size_t kMaxNormalMapFilenameBytes = 255;

// Ok, or INVALID_ARGUMENT naming the filename's length and the limit (not echoing all of it).
Status CheckNormalMapFilename(const std::string &filename);

}  // namespace glint
