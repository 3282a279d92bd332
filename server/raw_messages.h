// Messages of the methods glintd registers raw (grpc::ByteBuffer in and out, server/service.h):
// the handlers parse the request themselves so that a body that does not parse is answered
// INVALID_ARGUMENT naming the message (gRPC 1.51's typed callback handlers answer UNIMPLEMENTED
// with an empty message), and only after the bearer-token check.
#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <functional>
#include <string>

#include "server/auth.h"
#include "server/delivery_budget.h"
#include "server/status.h"

namespace glint {

// Parses a raw request body. gRPC has already checked the frame (length prefix, size limit);
// what fails here is the protobuf inside it: truncated, a wrong wire type, a length past the end.
// The body buffer is released once parsed: only the parsed message stays in memory.
Status ParseBody(const grpc::ByteBuffer *body, google::protobuf::Message *out,
                 const std::string &what);

// Serialises a response into the raw reply buffer.
grpc::Status SerializeReply(const google::protobuf::Message &message, grpc::ByteBuffer *out);

// A unary call's reactor that owns its typed request and response (the methods are raw, see
// service.h); Finish serialises the response into the reply buffer. With a DeliveryBudget, the
// reply's bytes are held in it from Finish until OnDone. `on_cancel` (if set) runs when gRPC
// reports the call cancelled (client cancel, disconnect or deadline): the service drops the
// call's queued job there (Scheduler::DropDeadJobs).
template <class Request, class Response>
class OwningUnaryReactor : public grpc::ServerUnaryReactor {
 public:
  explicit OwningUnaryReactor(grpc::ByteBuffer *reply, DeliveryBudget *budget = nullptr,
                              std::function<void()> on_cancel = {})
      : reply_(reply), budget_(budget), on_cancel_(std::move(on_cancel)) {}
  Request request;
  Response response;
  void Finish(grpc::Status s) {
    if (s.ok()) s = SerializeReply(response, reply_);
    response.Clear();  // the serialised copy is what stays until the reply has left
    request.Clear();
    if (s.ok() && budget_) {
      held_ = reply_->Length();
      budget_->Hold(held_);
    }
    grpc::ServerUnaryReactor::Finish(s);
  }
  void OnCancel() override {
    if (on_cancel_) on_cancel_();
  }
  void OnDone() override {
    if (budget_) budget_->Release(held_);
    delete this;
  }

 private:
  grpc::ByteBuffer *reply_;
  DeliveryBudget *budget_;
  std::function<void()> on_cancel_;
  uint64_t held_ = 0;
};

// A raw unary method answered at once (no scheduler work): the token check, then the body
// parsed as a Request, then `handle(request, &response)`; the response is serialised into
// `reply` when `handle` returns OK.
template <class Request, class Response, class Handle>
grpc::ServerUnaryReactor *AnswerNow(grpc::CallbackServerContext *ctx, const TokenAuth *auth,
                                    const grpc::ByteBuffer *body, grpc::ByteBuffer *reply,
                                    Handle &&handle) {
  grpc::ServerUnaryReactor *reactor = ctx->DefaultReactor();
  grpc::Status s = CheckBearer(auth, *ctx);
  Request request;
  if (s.ok()) {
    if (Status parsed = ParseBody(body, &request, "request"); !parsed.ok())
      s = grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, parsed.message());
  }
  Response response;
  if (s.ok()) s = handle(request, &response);
  if (s.ok()) s = SerializeReply(response, reply);
  reactor->Finish(s);
  return reactor;
}

}  // namespace glint
