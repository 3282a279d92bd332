// Same-host shared-memory transport of the client library (glint.proto SharedMemoryIo): the
// client creates a POSIX shared-memory object (shm_open + ftruncate + mmap), registers it with
// glintd, packs the queries into it, and the server writes the radiance back into it; only the
// small request and response messages cross the socket. `--transport auto|tcp|shm` on
// `glint eval` picks it (EvaluateWithTransport).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "client/lib/glint_client.h"
#include "glint/v1/glint.pb.h"

namespace glint::client {

enum class Transport { kAuto, kTcp, kShm };

// "auto", "tcp" or "shm"; throws std::invalid_argument naming the value otherwise.
Transport ParseTransport(const std::string &name);

// True when a server at `address` runs on this host: "unix:" / "unix-abstract:" targets and
// loopback hosts (127.0.0.0/8, [::1], localhost), with or without an "ipv4:"/"ipv6:"/"dns:///"
// scheme. Only such servers can open our shared-memory objects.
bool IsSameHostAddress(const std::string &address);

// A POSIX shared-memory object this process created (O_CREAT | O_EXCL, mode 0600, a name that
// includes the pid and a random part), mapped read-write; unmapped and unlinked on destruction.
class ShmBuffer {
 public:
  static std::unique_ptr<ShmBuffer> Create(size_t bytes, std::string *error);
  ~ShmBuffer();
  ShmBuffer(const ShmBuffer &) = delete;
  ShmBuffer &operator=(const ShmBuffer &) = delete;
  const std::string &key() const { return key_; }  // the shm_open name, "/glint-<pid>-..."
  uint8_t *data() const { return data_; }
  size_t size() const { return size_; }

 private:
  ShmBuffer() = default;
  std::string key_;
  uint8_t *data_ = nullptr;
  size_t size_ = 0;
};

// Packs queries [begin, end) of `q` into `dst` in the SharedMemoryIo layout (blocks uv,
// footprint, wo, wi, position, normal, tangent, each present array contiguous); fills the
// layout flags and input_byte_size of `io`. `dst` must hold SharedMemoryInputBytes bytes.
void PackSharedQueries(const glint::v1::QueryBatch &q, uint32_t begin, uint32_t end, uint8_t *dst,
                       glint::v1::SharedMemoryIo *io);
size_t SharedMemoryInputBytes(const glint::v1::QueryBatch &q, uint32_t count);

// One registered region reused across calls (the server maps it once): each Evaluate packs its
// queries into the region, sends a request naming it as input and output, and copies the
// radiance out. A batch larger than one piece (piece_queries(), capped by the server's
// max_batch) goes as several calls, pipelined over two slots of the region: while glintd
// evaluates piece k in one slot, the client copies piece k-1's radiance out of the other and
// packs piece k+1 into it, so the client's copies overlap the server's work instead of adding
// to it (bench/bench_shm_steps.cpp measures both). Every query is evaluated on its own
// (DESIGN.md "Determinism"), so the result is bit-identical however the batch is cut. A larger
// batch than the region holds replaces it by a larger one. The destructor unregisters and
// unlinks.
class ShmSession {
 public:
  // Queries per call of a pipelined Evaluate. bench_shm_steps on 1M probes with both cores free
  // (nice -15, POCL_AFFINITY=1): pieces of 512K (two calls) 6.5-6.6 ms, one call 7.6-7.7 ms,
  // pieces of 256K 10-20 ms (every further call in flight slowed the kernels beside it).
  static constexpr uint32_t kDefaultPieceQueries = 1u << 19;

  explicit ShmSession(GlintClient *client) : client_(client) {}
  ~ShmSession();
  ShmSession(const ShmSession &) = delete;
  ShmSession &operator=(const ShmSession &) = delete;

  // Creates and registers a region for `count` queries shaped like `q` (Evaluate does this when
  // needed; call it to learn early whether the server accepts shared memory).
  grpc::Status Prepare(const glint::v1::QueryBatch &q, uint32_t count);
  grpc::Status Evaluate(const glint::v1::EvaluateRequest &request, std::vector<float> *radiance,
                        ProgressFn progress = {}, EvaluateInfo *info = nullptr);
  // Unregisters and unlinks now (the destructor does it otherwise).
  void Close();
  // The pipeline's piece size (at least 1; tests use small pieces to cut small batches).
  void set_piece_queries(uint32_t queries) { piece_queries_ = std::max<uint32_t>(queries, 1); }
  uint32_t piece_queries() const { return piece_queries_; }

  // Zero-copy use, as with Triton's system shared memory: the application writes its queries
  // straight into the region and reads the radiance where glintd's kernels wrote it, so no
  // query or result is copied on either side (glintd reads them in place; server/shm_io.h).
  // PrepareInPlace sizes the region for `count` queries (at most the server's max_batch) with
  // the arrays that are non-empty in `shape` (its values are not read) and returns the blocks;
  // EvaluateInPlace evaluates what the blocks hold with `settings` (material, lights, precision,
  // ...; its queries are ignored). The blocks stay valid until the next Prepare or Close.
  struct InPlaceBlocks {
    uint32_t count = 0;
    // Floats per query: uv 2, footprint 4, the others 3; null when absent from `shape`.
    float *uv = nullptr, *footprint = nullptr, *wo = nullptr, *wi = nullptr;
    float *position = nullptr, *normal = nullptr, *tangent = nullptr;
    const float *radiance = nullptr;  // 3 per query, written by EvaluateInPlace
  };
  grpc::Status PrepareInPlace(const glint::v1::QueryBatch &shape, uint32_t count,
                              InPlaceBlocks *blocks);
  grpc::Status EvaluateInPlace(const glint::v1::EvaluateRequest &settings,
                               EvaluateInfo *info = nullptr);

  const ShmBuffer *buffer() const { return buffer_.get(); }
  const std::string &region_name() const { return name_; }

 private:
  // The server's max_batch (Capabilities), once per session.
  grpc::Status FetchLimits();
  // A registered region of at least `bytes` (the current one when it is large enough).
  grpc::Status Reserve(size_t bytes);

  GlintClient *client_;
  std::unique_ptr<ShmBuffer> buffer_;
  std::string name_;  // registered region name, "" when none
  uint32_t piece_queries_ = kDefaultPieceQueries;
  // The layout Prepare made for Evaluate: `slots` slots of `slot_bytes`, each `piece` queries.
  uint32_t piece_ = 0, slots_ = 0;
  size_t slot_bytes_ = 0;
  uint32_t max_batch_ = 0;              // the server's (Capabilities), fetched by the first Prepare
  glint::v1::SharedMemoryIo in_place_;  // the layout PrepareInPlace made; count 0: none
};

// Evaluates over `transport`: kTcp = GlintClient::Evaluate; kShm = an ShmSession for this call
// (its errors returned); kAuto = shared memory when the address is on this host and the server
// accepts the registration, else TCP. `used` (optional) receives "shm" or "tcp".
grpc::Status EvaluateWithTransport(GlintClient &client, Transport transport,
                                   const glint::v1::EvaluateRequest &request,
                                   std::vector<float> *radiance, ProgressFn progress = {},
                                   EvaluateInfo *info = nullptr, std::string *used = nullptr);

}  // namespace glint::client
