// Caps the message of every status glintd sends. Refusals quote what was refused (a file name, a
// KServe input or model name), and clients choose those strings: a message longer than the
// client's metadata limit (gRPC's default: 8 KiB soft, 16 KiB hard, for all of grpc-message
// and the other trailers) never arrives. The client's transport drops the call instead and
// reports RESOURCE_EXHAUSTED "received metadata size exceeds hard limit": the wrong code (the
// glint client retries RESOURCE_EXHAUSTED) and no word of what was wrong. A server interceptor
// cuts such a message at kMaxStatusMessageBytes, keeping the code, before it is sent.
#pragma once

#include <grpcpp/support/server_interceptor.h>

#include <cstddef>
#include <string>

namespace glint {

// Well inside gRPC's 8 KiB default, with room for the other trailers.
inline constexpr size_t kMaxStatusMessageBytes = 2048;

// `message` if it fits in `max_bytes`, else its first bytes (cut at a UTF-8 character boundary)
// followed by "... (N bytes in all)", at most `max_bytes` + that suffix.
std::string BoundedStatusMessage(const std::string &message,
                                 size_t max_bytes = kMaxStatusMessageBytes);

class BoundedStatusMessageInterceptorFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor *CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo *info) override;
};

}  // namespace glint
