// The gRPC service glint.v1.GlintService on the callback API: handlers
// validate nothing themselves and run nothing heavy; they hand a job to the
// Scheduler and finish the RPC from the worker that ran it.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "glint/v1/glint.grpc.pb.h"
#include "server/abandoned_work.h"
#include "server/auth.h"
#include "server/delivery_budget.h"
#include "server/device_engine.h"
#include "server/metrics.h"
#include "server/request_cost.h"
#include "server/scheduler.h"
#include "server/shm_regions.h"
#include "server/sliced_eval.h"
#include "server/validation.h"

namespace glint {

struct ServiceOptions {
  ValidationLimits limits;
  uint64_t max_message_bytes = 64ull << 20;
  bool log_requests = true;
  Metrics *metrics = nullptr;       // --metrics-listen; null: no metric hooks
  const TokenAuth *auth = nullptr;  // --auth-tokens; null: every call is let through
  CostLimits cost;                  // --max-request-cost, --max-query-cost
  double slice_ms = 50;             // target duration of one query slice (server/sliced_eval.h)
  ShmRegistry *shm = nullptr;       // shared-memory regions (server/shm_regions.h); null: none
  // Answered unary replies not yet taken by their clients before new Evaluate calls are
  // refused (server/delivery_budget.h); --max-undelivered-mb.
  uint64_t max_undelivered_bytes = 1ull << 30;
};

// The methods are registered raw (grpc::ByteBuffer in and out) and the handlers parse the
// messages themselves: gRPC 1.51's typed callback handlers answer a body that does not parse
// with UNIMPLEMENTED and an empty message (unary) or end the read loop as if the client had
// half-closed (streams, which then finished OK with the bad chunk unanswered). Parsing here
// gives INVALID_ARGUMENT naming what did not parse. (A new typed callback method is added to
// this chain as glint::v1::GlintService::WithCallbackMethod_<Name><...>.)
// The small unary calls answered at once (normal-map list/delete, shared-memory regions) are raw
// too (server/raw_messages.h AnswerNow), and so are Sample and UploadNormalMap (its chunks
// parsed one by one, server/normal_map_rpc.cpp).
using GlintRawService = glint::v1::GlintService::WithRawCallbackMethod_Evaluate<
    glint::v1::GlintService::WithRawCallbackMethod_EvaluateStream<
        glint::v1::GlintService::WithRawCallbackMethod_GetCapabilities<
            glint::v1::GlintService::WithRawCallbackMethod_Sample<
                glint::v1::GlintService::WithRawCallbackMethod_UploadNormalMap<
                    glint::v1::GlintService::WithRawCallbackMethod_ListNormalMaps<
                        glint::v1::GlintService::WithRawCallbackMethod_DeleteNormalMap<
                            glint::v1::GlintService::WithRawCallbackMethod_RegisterSharedMemory<
                                glint::v1::GlintService::WithRawCallbackMethod_ListSharedMemory<
                                    glint::v1::GlintService::
                                        WithRawCallbackMethod_UnregisterSharedMemory<
                                            glint::v1::GlintService::Service>>>>>>>>>>;

// Evaluates on the OpenCL engine, or on the host path when engine is null.
class GlintServiceImpl final : public GlintRawService {
 public:
  GlintServiceImpl(DeviceEngine *engine, Scheduler *scheduler, ServiceOptions options);

  grpc::ServerUnaryReactor *Evaluate(grpc::CallbackServerContext *ctx,
                                     const grpc::ByteBuffer *request,
                                     grpc::ByteBuffer *response) override;
  grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> *EvaluateStream(
      grpc::CallbackServerContext *ctx) override;
  grpc::ServerUnaryReactor *GetCapabilities(grpc::CallbackServerContext *ctx,
                                            const grpc::ByteBuffer *request,
                                            grpc::ByteBuffer *response) override;

  // Graceful shutdown (server/main.cpp): after BeginShutdown every new call and stream chunk is
  // refused with UNAVAILABLE while queued and running work goes on; after CancelInFlight the
  // running work stops at its next slice boundary with UNAVAILABLE.
  void BeginShutdown() { shutting_down_ = true; }
  void CancelInFlight() { cancel_in_flight_ = true; }
  // Importance sampling (server/sample_service.cpp, server/sample.h).
  grpc::ServerUnaryReactor *Sample(grpc::CallbackServerContext *ctx, const grpc::ByteBuffer *body,
                                   grpc::ByteBuffer *reply) override;
  // Normal-map resources (server/normal_map_rpc.cpp, the store in server/normal_map_store.h).
  grpc::ServerReadReactor<grpc::ByteBuffer> *UploadNormalMap(grpc::CallbackServerContext *ctx,
                                                             grpc::ByteBuffer *reply) override;
  grpc::ServerUnaryReactor *ListNormalMaps(grpc::CallbackServerContext *ctx,
                                           const grpc::ByteBuffer *request,
                                           grpc::ByteBuffer *response) override;
  grpc::ServerUnaryReactor *DeleteNormalMap(grpc::CallbackServerContext *ctx,
                                            const grpc::ByteBuffer *request,
                                            grpc::ByteBuffer *response) override;

  // Same-host shared-memory regions (server/shm_rpc.cpp, server/shm_regions.h).
  grpc::ServerUnaryReactor *RegisterSharedMemory(grpc::CallbackServerContext *ctx,
                                                 const grpc::ByteBuffer *request,
                                                 grpc::ByteBuffer *response) override;
  grpc::ServerUnaryReactor *ListSharedMemory(grpc::CallbackServerContext *ctx,
                                             const grpc::ByteBuffer *request,
                                             grpc::ByteBuffer *response) override;
  grpc::ServerUnaryReactor *UnregisterSharedMemory(grpc::CallbackServerContext *ctx,
                                                   const grpc::ByteBuffer *request,
                                                   grpc::ByteBuffer *response) override;
  // RunBatch for a request with shared_memory (server/shm_io.cpp): the queries are copied out
  // of the caller's (`owner`'s) input region, the radiance goes into its output region, and
  // `response` gets count and stats only.
  Status RunShared(int worker, const glint::v1::EvaluateRequest &request, const std::string &owner,
                   glint::v1::EvaluateResponse *response, std::string *kernel = nullptr,
                   grpc::CallbackServerContext *ctx = nullptr);

  // Validates `queries` against `settings` (already validated) and evaluates
  // them on `worker`'s queue, filling response->radiance. `kernel`, if given, receives
  // the kernel variant that ran (for the request log).
  // Runs in query slices (server/sliced_eval.h) and stops between them when `ctx` (if given)
  // was cancelled or its deadline passed, or the server cancels in-flight work.
  Status RunBatch(int worker, const glint::v1::EvaluateRequest &settings,
                  const glint::v1::QueryBatch &queries, uint64_t first_query, bool streamed,
                  glint::v1::EvaluateResponse *response, std::string *kernel = nullptr,
                  grpc::CallbackServerContext *ctx = nullptr);
  // RunBatch writing the radiance (3 x queries.count() floats) to `out` and the stats to
  // `stats` (the stream writes into its pooled reply buffer, proto/wire/chunk_result.h).
  Status RunBatchInto(int worker, const glint::v1::EvaluateRequest &settings,
                      const glint::v1::QueryBatch &queries, uint64_t first_query, bool streamed,
                      float *out, glint::v1::EvaluateStats *stats, std::string *kernel = nullptr,
                      grpc::CallbackServerContext *ctx = nullptr);

  // Admission before a job is queued: UNAVAILABLE while shutting down, then the cost limits on
  // the cost of `queries` under `settings` (EstimateQueriesCost, server/request_cost.h: the one
  // per-query cost of every path; `first_query` = the batch's place in a stream).
  Status Admit(const glint::v1::EvaluateRequest &settings, const glint::v1::QueryBatch &queries,
               uint64_t first_query = 0) const;
  // The same when only the query count is known (a shared-memory call before its region is
  // read): the settings' estimate (EstimateRequestCost). A model that counts each query
  // (Model::query_costs) is admitted by RunShared once it has copied them, not here.
  Status AdmitCount(const glint::v1::EvaluateRequest &settings, uint64_t query_count) const;
  // UNAVAILABLE once shutdown has begun (no new work accepted), else OK.
  Status ShutdownStatus() const;
  // Why work for `ctx` must stop now (OK: go on).
  Status StopReason(grpc::CallbackServerContext *ctx) const;
  // Sets `slicing`'s stop check to StopReason(ctx) and counts the queries a stop leaves
  // uncomputed as abandoned work (abandoned()).
  void StopSlicesFor(grpc::CallbackServerContext *ctx, SliceOptions *slicing);
  // The scheduler's Dead check (server/scheduler.h) of a job answering `ctx`: once StopReason
  // fails while the job is queued, the job is dropped without running, `finish` answers with
  // that status, its `queries` are counted as abandoned, and the line "<what> dropped from the
  // queue: <reason>" is logged.
  Scheduler::Dead DeadCall(grpc::CallbackServerContext *ctx, std::string what, uint64_t queries,
                           std::function<void(const Status &)> finish);
  // Queries not computed because their call was cancelled, its deadline passed or shutdown
  // cancelled it (server/abandoned_work.h; /metrics glint_abandoned_queries_total).
  AbandonedWork &abandoned() { return abandoned_; }

  // Dynamic batching (server/batch_service.cpp, server/batch_eval.h). A unary Evaluate call
  // that may share a launch: null when batching is off or the request is not Batchable.
  // `finish` answers the client.
  struct EvaluateMember : Scheduler::BatchMember {
    grpc::CallbackServerContext *ctx = nullptr;
    const glint::v1::EvaluateRequest *request = nullptr;
    glint::v1::EvaluateResponse *response = nullptr;
    std::chrono::steady_clock::time_point received;
    std::function<void(const Status &)> finish;
  };
  std::shared_ptr<Scheduler::BatchMember> MakeEvaluateMember(
      grpc::CallbackServerContext *ctx, const glint::v1::EvaluateRequest *request,
      glint::v1::EvaluateResponse *response, std::chrono::steady_clock::time_point received,
      std::function<void(const Status &)> finish) const;
  // The scheduler's batch job: validates each member, evaluates the valid ones in one launch,
  // fills each response as RunBatch would (plus stats.batch_requests), logs, and answers.
  std::vector<Scheduler::Respond> RunEvaluateBatch(int worker, const Scheduler::Members &members);

  Scheduler &scheduler() { return *scheduler_; }
  // Unary replies answered but not yet taken by their clients (--max-undelivered-mb).
  DeliveryBudget &undelivered() { return undelivered_; }
  const ServiceOptions &options() const { return options_; }
  void LogLine(const std::string &line);

 private:
  class StreamReactor;
  std::string DeviceName() const;

  DeviceEngine *engine_;
  Scheduler *scheduler_;
  ServiceOptions options_;
  DeliveryBudget undelivered_{options_.max_undelivered_bytes};
  std::mutex log_mutex_;
  std::atomic<bool> shutting_down_{false};
  std::atomic<bool> cancel_in_flight_{false};
  AbandonedWork abandoned_;
};

// The one mapping from the engine's Status to gRPC's: unary calls finish with it as is.
grpc::Status ToGrpcStatus(const Status &status);

// A failed stream chunk: the same code as ToGrpcStatus (so a device failure is INTERNAL, not the
// client's fault), the message prefixed with "chunk N: ".
grpc::Status ChunkStatus(uint64_t chunk_index, const Status &status);

// The message a client gets when the queue is full.
Status OverloadStatus(const Scheduler &scheduler);

// Marks the call's refusal as one that can succeed later (a full queue, not a limit): trailing
// metadata `glint-retry-pushback-ms` = `wait_ms`, as gRFC A6's server pushback under our own name
// (gRPC reserves `grpc-` keys). Clients (client/lib/retry.h) retry RESOURCE_EXHAUSTED only with
// it, so a request over --max-request-cost or a size limit is not sent again and again.
void AddRetryPushback(grpc::ServerContextBase *ctx, double wait_ms);

}  // namespace glint
