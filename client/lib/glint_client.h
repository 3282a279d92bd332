// Client side of glint.v1.GlintService: one channel, cached capabilities, and an Evaluate that
// picks unary or streamed transport by itself so callers never meet gRPC's message-size limits.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "client/lib/retry.h"
#include "glint/v1/glint.grpc.pb.h"
#include "glint/v1/glint.pb.h"

namespace glint::client {

// The wire contract's sizes (proto/glint/v1/glint.proto), one name each:
// - replies may exceed Capabilities.max_message_bytes by this much (the server's send limit is
//   its receive limit + 4096: stats, a stream result's indices), so a channel receives up to
//   its send limit + this (MakeChannel);
constexpr int kReplyOverheadBytes = 4096;
// - each sample adds this many bytes to a SampleResponse (7 packed floats: wi, pdf, weight);
constexpr uint64_t kSampleReplyBytesPerSample = 28;
// - maps asked for per ListNormalMaps page when listing them all (the server's largest page).
constexpr int32_t kNormalMapPageSize = 1000;

// Called after each part of a batch has come back: `done` of `total` queries evaluated.
// Runs on the calling thread of Evaluate.
using ProgressFn = std::function<void(uint64_t done, uint64_t total)>;

// How the channel authenticates: TLS (server verified against tls_ca_pem, or the system roots
// when it is empty), mutual TLS with a client certificate, and a bearer token sent as
// `authorization: Bearer <token>` on every call. Empty: plaintext, no token.
struct ChannelSecurity {
  bool tls = false;
  std::string tls_ca_pem;    // PEM contents, not paths
  std::string tls_cert_pem;  // client certificate chain (mutual TLS), with tls_key_pem
  std::string tls_key_pem;
  std::string token;
};

// The CLI's --tls-ca, --tls-cert, --tls-key and --token-file (each "" when not given): reads the
// files; without --token-file the token comes from $GLINT_TOKEN when set. TLS is on when any TLS
// file is given. Throws std::runtime_error naming the option and file on an unreadable file, a
// file with no PEM block or no token, or --tls-cert without --tls-key.
ChannelSecurity LoadChannelSecurity(const std::string &tls_ca_file,
                                    const std::string &tls_cert_file,
                                    const std::string &tls_key_file, const std::string &token_file);

// The channel every GlintClient uses: message limits, quick reconnects, and `security`. It sends
// up to `max_message_bytes` and receives up to max_message_bytes + kReplyOverheadBytes, so a
// client whose limit equals the server's receives the server's largest reply.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string &address, int max_message_bytes,
                                           const ChannelSecurity &security);

struct ClientOptions {
  // Requests sent (replies received: this + kReplyOverheadBytes). The server advertises its own
  // limit in Capabilities.max_message_bytes; this only has to be at least as large so that the
  // client is never the side that refuses.
  int max_message_bytes = 64 << 20;
  // Upper bound on the serialized size of one message (a unary request or a stream chunk).
  // Several MiB keeps per-message latency and memory small while amortising per-message
  // overhead (PLATFORM-NOTES: "keep messages to a few MiB and stream larger batches").
  // (On loopback, bench_transport --chunk-bytes, 1-4 MiB chunks took somewhat less CPU per
  // query than 8 MiB on a loaded machine; the Python client mirrors this default and the CLI
  // parity test compares their chunking, so a change goes to both.)
  size_t max_chunk_bytes = 8u << 20;
  // Extra cap on queries per message (0 = only the server's max_batch). Tests use it to force
  // many small chunks against a server with a large max_batch.
  uint32_t max_chunk_queries = 0;
  // Deadline for the cheap RPCs (GetCapabilities). Evaluate has none: a large batch may
  // legitimately take minutes, and the caller can cancel by closing the process.
  std::chrono::milliseconds rpc_timeout{10000};
  // Deadline of one Evaluate call, unary or streamed, from its start, over all its attempts
  // (0 = none).
  std::chrono::milliseconds evaluate_timeout{0};
  // GetCapabilities and Evaluate retry UNAVAILABLE, and RESOURCE_EXHAUSTED that the server
  // marks as "may succeed later" (a full queue, not a limit), with jittered exponential backoff
  // (client/lib/retry.h) within their deadline; max_attempts 1 disables.
  RetryPolicy retry;
  ChannelSecurity security;
};

// How the last Evaluate call was carried out (for summaries and tests).
struct EvaluateInfo {
  bool streamed = false;
  uint64_t chunks = 0;         // 1 for a unary call
  uint32_t chunk_queries = 0;  // queries per chunk (the last one may be smaller)
  std::string device;          // from the server's EvaluateStats, if it reported one
  int attempts = 0;            // 1 + retries
  // Servers of a `--server a,b,c` list the chunks were spread over (as separate unary calls
  // that the channel's round_robin policy sends to the next ready server); 1 otherwise.
  size_t servers = 1;
};

// One channel to one server (or one load-balanced target). Thread-safe: concurrent calls,
// including concurrent Evaluate, share the channel and the capabilities cache.
class GlintClient {
 public:
  // `address` is any gRPC target: "127.0.0.1:50051", "dns:///glint:50051", "unix:/path", or a
  // comma-separated list of host:port replicas (client/lib/server_list.h: one round_robin
  // channel; Evaluate spreads a large batch's chunks over them).
  explicit GlintClient(const std::string &address, ClientOptions options = {});
  // For tests and callers that want their own channel arguments or credentials.
  GlintClient(std::shared_ptr<grpc::Channel> channel, ClientOptions options = {});

  const std::string &address() const { return address_; }
  // For callers that open their own calls on the same connection (evaluate_series.h, the
  // load tool's streams).
  const std::shared_ptr<grpc::Channel> &channel() const { return channel_; }
  const ClientOptions &options() const { return options_; }
  // Addresses in the `--server` list this client was made with (1 for one address or a channel).
  size_t servers() const { return servers_; }
  // Adds what every call of this client carries (the bearer token, when one is configured).
  void PrepareContext(grpc::ClientContext *context) const;

  // Always asks the server (and refreshes the cache Evaluate uses).
  grpc::Status GetCapabilities(glint::v1::Capabilities *capabilities);

  // Polls grpc.health.v1.Health/Check (service "") until it answers SERVING or `timeout`
  // passes. On false, `why` (if given) says what the last attempt saw, e.g. "NOT_SERVING" or
  // "UNAVAILABLE: failed to connect to all addresses".
  bool WaitUntilServing(std::chrono::milliseconds timeout, std::string *why = nullptr);

  // Evaluates `request` and fills `radiance` with 3 floats (RGB) per query, in query order.
  // A batch within max_batch and max_chunk_bytes (and half the server's message limit) goes
  // unary; a larger one is split with SliceQueries and sent over EvaluateStream, the first
  // chunk carrying every setting (material, lights, precision, seed, area method). The result is
  // bit-identical either way (the server's determinism contract). `progress` is called as results
  // arrive. `radiance` is untouched on failure.
  grpc::Status Evaluate(const glint::v1::EvaluateRequest &request, std::vector<float> *radiance,
                        ProgressFn progress = {}, EvaluateInfo *info = nullptr);

  // Normal-map resources (client/lib/normal_map_client.cpp). UploadNormalMap sends one file's
  // bytes in chunks of at most 1 MiB; `filename`'s extension tells the server its format.
  grpc::Status UploadNormalMap(const std::string &filename, const std::string &bytes,
                               glint::v1::NormalMapInfo *info);
  // Every map the server holds, in digest order: follows ListNormalMaps' pages (AIP-158,
  // kNormalMapPageSize per call) until next_page_token is empty; `maps` holds them all and no
  // next_page_token. A server older than paging answers everything in one page, which works too.
  grpc::Status ListNormalMaps(glint::v1::ListNormalMapsResponse *maps);
  // One page as asked (page_size, page_token).
  grpc::Status ListNormalMapsPage(const glint::v1::ListNormalMapsRequest &request,
                                  glint::v1::ListNormalMapsResponse *page);
  grpc::Status DeleteNormalMap(const std::string &digest);

 private:
  grpc::Status CachedCapabilities(glint::v1::Capabilities *capabilities,
                                  std::chrono::system_clock::time_point deadline);
  grpc::Status FetchCapabilities(glint::v1::Capabilities *capabilities,
                                 std::chrono::system_clock::time_point deadline);
  // One attempt of Evaluate; `deadline` is system_clock::time_point::max() for none. `hint`
  // receives the server's retry pushback of the call that failed.
  grpc::Status EvaluateOnce(const glint::v1::EvaluateRequest &request, std::vector<float> *radiance,
                            const ProgressFn &progress, EvaluateInfo *info,
                            std::chrono::system_clock::time_point deadline, RetryHint *hint);
  grpc::Status EvaluateUnary(const glint::v1::EvaluateRequest &request,
                             std::vector<float> *radiance, EvaluateInfo *info,
                             std::chrono::system_clock::time_point deadline, RetryHint *hint);
  // Chunks of `chunk_queries` as concurrent unary calls over a server list's round_robin
  // channel, each retried on its own; results written by position, so bit-identical to one
  // server.
  grpc::Status EvaluateSpread(const glint::v1::EvaluateRequest &request, uint32_t chunk_queries,
                              std::vector<float> *radiance, const ProgressFn &progress,
                              EvaluateInfo *info, std::chrono::system_clock::time_point deadline);
  grpc::Status EvaluateStreamed(const glint::v1::EvaluateRequest &request, uint32_t chunk_queries,
                                std::vector<float> *radiance, const ProgressFn &progress,
                                EvaluateInfo *info, std::chrono::system_clock::time_point deadline,
                                RetryHint *hint);

  std::string address_;
  ClientOptions options_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<glint::v1::GlintService::Stub> stub_;
  size_t servers_ = 1;  // addresses in a --server list
  // The array a streamed batch's results were decoded into last, kept for the next one (its pages
  // mapped already); one output array (12 bytes per query of the largest batch) when idle.
  std::mutex output_mutex_;
  std::vector<float> spare_output_;
  std::mutex caps_mutex_;
  std::optional<glint::v1::Capabilities> caps_;
};

// Queries [begin, end) of `batch` as a batch of its own: every SoA array is cut with its own
// component count, and arrays that are empty in `batch` stay empty. Requires begin <= end <=
// batch.count(); throws std::out_of_range otherwise.
glint::v1::QueryBatch SliceQueries(const glint::v1::QueryBatch &batch, uint32_t begin,
                                   uint32_t end);

// Bytes one query adds to a serialized QueryBatch (packed floats of the arrays present in
// `batch`), used to size stream chunks.
size_t BytesPerQuery(const glint::v1::QueryBatch &batch);

// Queries per Sample call for `count` queries of `query_bytes` each (BytesPerQuery) with
// `samples_per_query` samples: count x K within the server's max_batch, and both messages within
// half the smaller of the server's (caps.max_message_bytes) and the client's message limit: the
// request (`settings_bytes` of material and fields, then the queries) and the response (7 floats
// per sample). At least 1. (glint sample sized calls by the response and the client's limit
// alone, so a server with a smaller --max-message-mb, or K = 1 with a world frame, refused them.)
uint32_t SampleQueriesPerCall(const glint::v1::Capabilities &caps, int client_max_message_bytes,
                              uint32_t samples_per_query, size_t query_bytes, size_t settings_bytes,
                              uint32_t count);

// "INVALID_ARGUMENT", "UNAVAILABLE", ... for messages people read.
const char *StatusCodeName(grpc::StatusCode code);

// "UNAVAILABLE: failed to connect ..." (code name, then the message when there is one).
std::string FormatStatus(const grpc::Status &status);

// What is wrong with stream result number `received` (of `chunks` expected) that should cover
// `n` queries starting at stream query `first`, or "" when it is what was asked for.
std::string ChunkResultProblem(const glint::v1::EvaluateChunkResult &result, uint64_t received,
                               uint64_t chunks, uint64_t first, uint64_t n);
// The same for a result decoded off the wire (glint::wire::DecodeChunkResult) that carried
// `radiance_floats` floats.
std::string ChunkResultProblem(uint64_t chunk_index, uint64_t first_query, uint64_t radiance_floats,
                               uint64_t received, uint64_t chunks, uint64_t first, uint64_t n);

}  // namespace glint::client
