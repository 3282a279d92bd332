// One generic (raw bytes) gRPC call driven an operation at a time on its own completion queue:
// what an outside client with its own encoder sends, for tests of bodies and frames glintd must
// refuse (a typed stub cannot send them).
#pragma once

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace glint::test {

class RawCall {
 public:
  RawCall(const std::shared_ptr<grpc::Channel> &channel, const std::string &method)
      : stub_(channel) {
    ctx_.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    call_ = stub_.PrepareCall(&ctx_, method, &cq_);
    Step([&](void *t) { call_->StartCall(t); });
  }
  ~RawCall() {
    cq_.Shutdown();
    void *tag;
    bool ok;
    while (cq_.Next(&tag, &ok)) {
    }
  }
  RawCall(const RawCall &) = delete;
  RawCall &operator=(const RawCall &) = delete;

  // Writes the frames in order, stopping at the first the transport refuses; then half-closes.
  void WriteAllThenClose(const std::vector<grpc::ByteBuffer> &frames) {
    for (const grpc::ByteBuffer &f : frames)
      if (!Step([&](void *t) { call_->Write(f, t); })) break;
    Step([&](void *t) { call_->WritesDone(t); });
  }
  // The next reply message; false once the server has sent its last.
  bool Read(grpc::ByteBuffer *reply) {
    return Step([&](void *t) { call_->Read(reply, t); });
  }
  grpc::Status Finish() {
    grpc::Status status;
    Step([&](void *t) { call_->Finish(&status, t); });
    return status;
  }

 private:
  // Starts one operation and waits for its completion; returns its ok flag.
  template <class Start>
  bool Step(Start &&start) {
    void *want = reinterpret_cast<void *>(intptr_t(next_tag_++));
    start(want);
    void *tag = nullptr;
    bool ok = false;
    EXPECT_TRUE(cq_.Next(&tag, &ok));
    EXPECT_EQ(tag, want);
    return ok;
  }

  grpc::GenericStub stub_;
  grpc::CompletionQueue cq_;
  grpc::ClientContext ctx_;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call_;
  int next_tag_ = 1;
};

}  // namespace glint::test
