// Unary reactors whose answered replies count in the --max-undelivered-mb DeliveryBudget:
// BudgetedUnaryReactor, the common part (also the base of OwningUnaryReactor in
// server/raw_messages.h, the raw methods'), and CountedUnaryReactor for a typed unary callback
// method that does scheduler work (KServe ModelInfer: gRPC serialises its typed response after
// Finish and keeps it until the bytes have left or the call died).
#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <functional>
#include <utility>

#include "server/delivery_budget.h"

namespace glint {

// A unary reactor whose answered reply is held in the --max-undelivered-mb DeliveryBudget (if
// given) from Finish until OnDone, i.e. until gRPC is done with the bytes (sent, or the call
// died), and which runs `on_cancel` (if set) when gRPC reports the call cancelled (client
// cancel, disconnect or deadline): the service drops the call's queued job there
// (Scheduler::DropDeadJobs). Deletes itself in OnDone.
class BudgetedUnaryReactor : public grpc::ServerUnaryReactor {
 public:
  BudgetedUnaryReactor(DeliveryBudget *budget, std::function<void()> on_cancel)
      : budget_(budget), on_cancel_(std::move(on_cancel)) {}
  void OnCancel() override {
    if (on_cancel_) on_cancel_();
  }
  void OnDone() override {
    if (budget_) budget_->Release(held_);
    delete this;
  }

 protected:
  // Finishes the call; an OK answer of `reply_bytes` is held in the budget until OnDone.
  void FinishHolding(grpc::Status s, uint64_t reply_bytes) {
    if (s.ok() && budget_) {
      held_ = reply_bytes;
      budget_->Hold(held_);
    }
    grpc::ServerUnaryReactor::Finish(std::move(s));
  }

 private:
  DeliveryBudget *budget_;
  std::function<void()> on_cancel_;
  uint64_t held_ = 0;
};

// A typed method's messages belong to gRPC and live until OnDone: the parsed request (for
// ModelInfer, all input tensors: ~4x the output), the typed response and its serialised copy.
// All three are charged, not only the reply's bytes, so the budget bounds what a client that
// never reads holds on the server.
class CountedUnaryReactor : public BudgetedUnaryReactor {
 public:
  CountedUnaryReactor(const google::protobuf::Message *request,
                      const google::protobuf::Message *response, DeliveryBudget *budget,
                      std::function<void()> on_cancel)
      : BudgetedUnaryReactor(budget, std::move(on_cancel)),
        request_(request),
        response_(response) {}
  void Finish(grpc::Status s) {
    const uint64_t bytes = s.ok() ? request_->ByteSizeLong() + 2 * response_->ByteSizeLong() : 0;
    FinishHolding(std::move(s), bytes);
  }

 private:
  const google::protobuf::Message *request_;
  const google::protobuf::Message *response_;
};

}  // namespace glint
