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
#include "server/counted_reactor.h"
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
// service.h); Finish serialises the response into the reply buffer, whose bytes the budget then
// holds (BudgetedUnaryReactor).
template <class Request, class Response>
class OwningUnaryReactor : public BudgetedUnaryReactor {
 public:
  explicit OwningUnaryReactor(grpc::ByteBuffer *reply, DeliveryBudget *budget = nullptr,
                              std::function<void()> on_cancel = {})
      : BudgetedUnaryReactor(budget, std::move(on_cancel)), reply_(reply) {}
  Request request;
  Response response;
  void Finish(grpc::Status s) {
    if (s.ok()) s = SerializeReply(response, reply_);
    response.Clear();  // the serialised copy is what stays until the reply has left
    request.Clear();
    const uint64_t bytes = s.ok() ? reply_->Length() : 0;
    FinishHolding(std::move(s), bytes);
  }
  // Finishes OK with `reply` already encoded (e.g. proto/wire's EncodeEvaluateResponse around a
  // pooled radiance slice): no serialisation, no copy.
  void FinishWithReply(grpc::ByteBuffer reply) {
    *reply_ = std::move(reply);
    response.Clear();
    request.Clear();
    FinishHolding(grpc::Status::OK, reply_->Length());
  }

 private:
  grpc::ByteBuffer *reply_;
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
