// A small status type for the engine, independent of gRPC; the service maps it
// to grpc::Status in exactly one place (service.cpp, ToGrpcStatus).
#pragma once

#include <string>
#include <utility>

namespace glint {

class Status {
 public:
  enum class Code {
    kOk,
    kInvalidArgument,
    kResourceExhausted,
    kFailedPrecondition,
    kInternal,
    kNotFound,
    kCancelled,         // the client cancelled the call
    kDeadlineExceeded,  // the call's deadline passed before its work finished
    kUnavailable,       // the server is shutting down
  };

  Status() = default;
  static Status Ok() { return Status(); }
  static Status InvalidArgument(std::string m) {
    return Status(Code::kInvalidArgument, std::move(m));
  }
  static Status ResourceExhausted(std::string m) {
    return Status(Code::kResourceExhausted, std::move(m));
  }
  static Status FailedPrecondition(std::string m) {
    return Status(Code::kFailedPrecondition, std::move(m));
  }
  static Status Internal(std::string m) { return Status(Code::kInternal, std::move(m)); }
  static Status NotFound(std::string m) { return Status(Code::kNotFound, std::move(m)); }
  static Status Cancelled(std::string m) { return Status(Code::kCancelled, std::move(m)); }
  static Status DeadlineExceeded(std::string m) {
    return Status(Code::kDeadlineExceeded, std::move(m));
  }
  static Status Unavailable(std::string m) { return Status(Code::kUnavailable, std::move(m)); }

  bool ok() const { return code_ == Code::kOk; }
  Code code() const { return code_; }
  const std::string &message() const { return message_; }

 private:
  Status(Code code, std::string message) : code_(code), message_(std::move(message)) {}
  Code code_ = Code::kOk;
  std::string message_;
};

}  // namespace glint
