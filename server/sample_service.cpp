// The Sample RPC's handler: like Evaluate, the work (validation included) runs on a scheduler
// worker and the RPC is finished from there; server/sample.h does the work.
#include <chrono>
#include <sstream>

#include "server/auth.h"
#include "server/raw_messages.h"
#include "server/request_cost.h"
#include "server/sample.h"
#include "server/service.h"

namespace glint {

grpc::ServerUnaryReactor *GlintServiceImpl::Sample(grpc::CallbackServerContext *ctx,
                                                   const grpc::ByteBuffer *body,
                                                   grpc::ByteBuffer *reply) {
  using Clock = std::chrono::steady_clock;
  // Raw (service.h): the body is parsed here, after the token check, so one that does not parse
  // is INVALID_ARGUMENT naming the message rather than gRPC's bare UNIMPLEMENTED.
  using Reactor = OwningUnaryReactor<glint::v1::SampleRequest, glint::v1::SampleResponse>;
  // Its reply counts in --max-undelivered-mb as Evaluate's; a cancelled call leaves the queue at
  // once (server/raw_messages.h).
  auto *reactor = new Reactor(reply, &undelivered_, [this] { scheduler_->DropDeadJobs(); });
  const glint::v1::SampleRequest *request = &reactor->request;
  glint::v1::SampleResponse *response = &reactor->response;
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok()) {
    reactor->Finish(denied);
    return reactor;
  }
  if (Status parsed = ParseBody(body, &reactor->request, "request"); !parsed.ok()) {
    reactor->Finish(ToGrpcStatus(parsed));
    return reactor;
  }
  if (shutting_down_) {
    reactor->Finish(ToGrpcStatus(ShutdownStatus()));
    return reactor;
  }
  if (Status full = undelivered_.Admit(); !full.ok()) {
    LogLine("Sample n=" + std::to_string(request->queries().count()) +
            " refused: " + full.message());
    AddRetryPushback(ctx, options_.slice_ms);
    reactor->Finish(ToGrpcStatus(full));
    return reactor;
  }
  // Cost admission as Evaluate's (server/request_cost.h): the settings and the cost of each
  // query (a NORMAL_MAP query's by its footprint) are checked here, on gRPC's thread, the
  // queries' values on the worker.
  glint::v1::EvaluateRequest settings;
  const uint32_t count = request->queries().count();
  Status admitted = ValidateSampleSettings(*request, options_.limits, &settings);
  if (admitted.ok())
    admitted = CheckRequestCost(
        EstimateSampleCost(settings, request->samples_per_query(), request->queries()), count,
        options_.cost);
  if (!admitted.ok()) {
    LogLine("Sample n=" + std::to_string(count) + " refused: " + admitted.message());
    reactor->Finish(ToGrpcStatus(admitted));
    return reactor;
  }
  const auto received = Clock::now();
  bool queued = scheduler_->TrySubmit(
      [this, ctx, reactor, request, response, received](int worker) {
        const auto start = Clock::now();
        // In query slices, stopping between them for cancellation, deadline or shutdown.
        SliceOptions slicing;
        slicing.target_ms = options_.slice_ms;
        StopSlicesFor(ctx, &slicing);
        double compile_ms = 0;
        Status st =
            RunSample(engine_, worker, *request, options_.limits, response, &slicing, &compile_ms);
        const auto ms = [](Clock::time_point a, Clock::time_point b) {
          return std::chrono::duration<double, std::milli>(b - a).count();
        };
        response->mutable_stats()->set_queue_ms(ms(received, start));
        // Without the kernel build of a cold sample pass (RunSample's compile_ms).
        response->mutable_stats()->set_compile_ms(compile_ms);
        response->mutable_stats()->set_compute_ms(ms(start, Clock::now()) - compile_ms);
        if (options_.metrics && compile_ms > 0)
          options_.metrics->ObserveCompile(glint::v1::Model_IsValid(request->material().model())
                                               ? glint::v1::Model_Name(request->material().model())
                                               : "?",
                                           compile_ms / 1e3);
        response->mutable_stats()->set_device(DeviceName());
        std::ostringstream line;
        line << "Sample n=" << request->queries().count() << " k=" << request->samples_per_query()
             << " queue_ms=" << response->stats().queue_ms()
             << " compile_ms=" << response->stats().compile_ms()
             << " compute_ms=" << response->stats().compute_ms()
             << (st.ok() ? " ok" : " refused: " + st.message());
        LogLine(line.str());
        if (!st.ok()) response->Clear();
        return [reactor, st] { reactor->Finish(ToGrpcStatus(st)); };
      },
      nullptr,
      DeadCall(ctx, "Sample n=" + std::to_string(request->queries().count()),
               request->queries().count(),
               [reactor](const Status &st) { reactor->Finish(ToGrpcStatus(st)); }));
  if (!queued) {
    Status busy = OverloadStatus(*scheduler_);
    LogLine("Sample n=" + std::to_string(request->queries().count()) + " " + busy.message());
    AddRetryPushback(ctx, options_.slice_ms);
    reactor->Finish(ToGrpcStatus(busy));
  }
  return reactor;
}

}  // namespace glint
