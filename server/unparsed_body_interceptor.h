// Gives a typed gRPC handler's unparseable request an INVALID_ARGUMENT that names the message
// (issue 12: "unparseable request bodies get UNIMPLEMENTED with an empty message"). glint.v1's
// methods are registered raw and parse their bodies themselves (server/raw_messages.h); the
// typed services beside them (KServe v2 inference.GRPCInferenceService, grpc.health.v1.Health)
// get gRPC 1.51's callback default instead: when the body does not deserialise, the handler never
// runs and the call ends UNIMPLEMENTED with an empty message, which reads as "wrong method".
//
// A server interceptor sees the received message after deserialisation (POST_RECV_MESSAGE, null
// when it failed) and the status as it is sent (PRE_SEND_STATUS); it rewrites exactly that case:
// the request did not deserialise and the status is UNIMPLEMENTED with no message. A method that
// is really unimplemented (an unknown path, or Health.Watch with a good body) keeps UNIMPLEMENTED.
// With --auth-tokens the caller's token is checked first, as the raw handlers do (a caller
// without a token learns nothing about the body), except on the calls that need none: health and
// KServe's ServerLive / ServerReady. Installed before the metrics interceptor so that /metrics
// counts the status the client gets.
#pragma once

#include <grpcpp/support/server_interceptor.h>

#include "server/auth.h"

namespace glint {

class UnparsedBodyInterceptorFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  // `auth`: glintd's bearer tokens, or null without --auth-tokens; it must outlive the server.
  explicit UnparsedBodyInterceptorFactory(const TokenAuth *auth) : auth_(auth) {}
  grpc::experimental::Interceptor *CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo *info) override;

 private:
  const TokenAuth *auth_;
};

}  // namespace glint
