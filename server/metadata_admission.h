// Admission from call metadata, before a request's body is parsed or (for streams) read.
//
// The client library (client/lib/glint_client.cpp) sends each Evaluate call's query count and
// model as call metadata: `glint-query-count` (decimal; a stream's total over all chunks) and
// `glint-model` (a glint.v1.Model name, e.g. "SMOOTH"). Metadata is a claim, never trusted for
// more than refusing early: a request admitted from its metadata is still checked in full from
// its body, so a lying count (metadata 10, body 1M queries) is refused by the body check, and a
// call without the metadata (another client) is checked from its body alone.
//
// Where gRPC 1.51's callback API lets this run before the body:
//  - EvaluateStream (bidi): the reactor exists once the call's headers have arrived and reads a
//    chunk only when it asks (GRPC_SRM_PAYLOAD_NONE), so a full server or a refused claim ends
//    the stream before its first chunk is read: the body is never received beyond the HTTP/2
//    flow-control window.
//  - Evaluate (unary): not possible. grpc::Server registers unary methods with
//    GRPC_SRM_PAYLOAD_READ_INITIAL_BYTE_BUFFER (src/cpp/server/server_cc.cc,
//    PayloadHandlingForMethod), so the core matches the call to its handler, and creates its
//    ServerContext and any server interceptor, only after the whole message has been received.
//    The cheapest check left is done first thing in the handler: the claim is refused before
//    the body is parsed (no parse, no second copy of it). Refusing earlier would take serving
//    Evaluate as a generic (bidi-style) method through grpc::CallbackGenericService.
#pragma once

#include <grpcpp/grpcpp.h>

#include "server/status.h"
#include "server/validation.h"

namespace glint {

inline constexpr char kQueryCountMetadata[] = "glint-query-count";
inline constexpr char kModelMetadata[] = "glint-model";

// OK when `ctx` carries no claim or one that may be admitted. For a unary call (`per_message`),
// a count above limits.max_batch is refused with INVALID_ARGUMENT (what the body check would
// say, plus that it came from the metadata); for either kind, a malformed count or an unknown
// model name is refused with INVALID_ARGUMENT naming the metadata key.
Status AdmitFromMetadata(const grpc::CallbackServerContext &ctx, const ValidationLimits &limits,
                         bool per_message);

}  // namespace glint
