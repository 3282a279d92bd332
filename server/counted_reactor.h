// The reactor of a typed unary callback method that does scheduler work (KServe ModelInfer): as
// OwningUnaryReactor (server/raw_messages.h) for the raw methods, its reply is counted in the
// --max-undelivered-mb DeliveryBudget from Finish until OnDone (gRPC serialises the typed
// response after Finish and keeps it until the bytes have left or the call died), and a
// cancelled call's queued job is dropped at once through `on_cancel`.
#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <functional>
#include <utility>

#include "server/delivery_budget.h"

namespace glint {

class CountedUnaryReactor : public grpc::ServerUnaryReactor {
 public:
  CountedUnaryReactor(const google::protobuf::Message *response, DeliveryBudget *budget,
                      std::function<void()> on_cancel)
      : response_(response), budget_(budget), on_cancel_(std::move(on_cancel)) {}
  void Finish(grpc::Status s) {
    if (s.ok() && budget_) {
      held_ = response_->ByteSizeLong();
      budget_->Hold(held_);
    }
    grpc::ServerUnaryReactor::Finish(std::move(s));
  }
  void OnCancel() override {
    if (on_cancel_) on_cancel_();
  }
  void OnDone() override {
    if (budget_) budget_->Release(held_);
    delete this;
  }

 private:
  const google::protobuf::Message *response_;
  DeliveryBudget *budget_;
  std::function<void()> on_cancel_;
  uint64_t held_ = 0;
};

}  // namespace glint
