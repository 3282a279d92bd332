// What normal-map uploads in progress may hold at once (UploadNormalMap,
// server/normal_map_rpc.cpp).
//
// Before, nothing bounded them, and two things grew without limit (found by the session 10
// outside-client probe): (1) each upload buffers its file, up to --normal-map-max-upload-mb,
// until the client half-closes, so six streams that never finish held 1.6 GB; (2) each finished
// upload decoded on a thread of its own at the same time as the others, and a decode holds the
// whole image several times over (8/16-bit texels, float normals, the store's tables): a 55 KB
// PNG of 4096 x 4096 flat texels (a "decompression bomb" within the texel limit) takes ~650 MB
// while it decodes, so six concurrent uploads of it took glintd from 0.6 to 4.6 GB, and some
// thirty would exhaust this 23 GB machine.
//
// Now: (1) uploads in progress (from their first chunk until they are answered) hold at most
// `max_bytes` of file data in total and are at most `max_uploads`; an upload that would pass
// either is refused with RESOURCE_EXHAUSTED and the retry pushback (it may succeed once others
// finish); (2) decodes run one at a time (DecodeTurn), so a decode's working memory counts once.
// Peak memory of uploads: max_bytes + one decode (~40 bytes per texel of the largest map).
#pragma once

#include <cstdint>
#include <mutex>
#include <string>

#include "server/status.h"

namespace glint {

class UploadGate {
 public:
  UploadGate(uint64_t max_bytes, uint32_t max_uploads)
      : max_bytes_(max_bytes), max_uploads_(max_uploads) {}

  // A new upload: refused once max_uploads are in progress.
  Status Begin() {
    std::lock_guard<std::mutex> lock(mu_);
    if (uploads_ >= max_uploads_) {
      return Status::ResourceExhausted(
          "normal-map uploads: " + std::to_string(uploads_) +
          " already in progress, the most the server receives at once; retry later");
    }
    ++uploads_;
    return Status::Ok();
  }
  // `bytes` more of an upload's file: refused when all uploads in progress would hold more than
  // max_bytes. `held` is what this upload holds already (its own share of the total).
  Status Reserve(uint64_t bytes, uint64_t held) {
    std::lock_guard<std::mutex> lock(mu_);
    if (bytes_ + bytes > max_bytes_) {
      return Status::ResourceExhausted(
          "normal-map uploads: uploads in progress hold " + std::to_string(bytes_) +
          " bytes (this one " + std::to_string(held) + "), and the server buffers at most " +
          std::to_string(max_bytes_) + " at once (2 x --normal-map-max-upload-mb); retry later");
    }
    bytes_ += bytes;
    return Status::Ok();
  }
  // The upload is answered: its count and its `held` bytes are free again.
  void End(uint64_t held) {
    std::lock_guard<std::mutex> lock(mu_);
    --uploads_;
    bytes_ -= held;
  }
  // Held while an upload decodes and stores its map: one decode at a time.
  std::mutex &DecodeTurn() { return decode_; }

  uint64_t max_bytes() const { return max_bytes_; }
  uint32_t max_uploads() const { return max_uploads_; }

 private:
  const uint64_t max_bytes_;
  const uint32_t max_uploads_;
  std::mutex mu_, decode_;
  uint64_t bytes_ = 0;
  uint32_t uploads_ = 0;
};

}  // namespace glint
