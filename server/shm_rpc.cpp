// The shared-memory region RPCs of GlintServiceImpl (RegisterSharedMemory, ListSharedMemory,
// UnregisterSharedMemory) on the server's ShmRegistry (server/shm_regions.h). Each is guarded by
// the bearer-token check like every other glint.v1 handler; the token, when there is one, is the
// owner of the regions (server/shm_io.h ShmOwner).
#include "server/raw_messages.h"
#include "server/service.h"
#include "server/shm_io.h"
#include "server/shm_regions.h"

namespace glint {
namespace {

Status Disabled() {
  return Status::FailedPrecondition(
      "shared memory is disabled on this server (--max-shm-regions 0)");
}

}  // namespace

using glint::v1::ListSharedMemoryRequest;
using glint::v1::ListSharedMemoryResponse;
using glint::v1::RegisterSharedMemoryRequest;
using glint::v1::RegisterSharedMemoryResponse;
using glint::v1::UnregisterSharedMemoryRequest;
using glint::v1::UnregisterSharedMemoryResponse;

grpc::ServerUnaryReactor *GlintServiceImpl::RegisterSharedMemory(grpc::CallbackServerContext *ctx,
                                                                 const grpc::ByteBuffer *body,
                                                                 grpc::ByteBuffer *reply) {
  return AnswerNow<RegisterSharedMemoryRequest, RegisterSharedMemoryResponse>(
      ctx, options_.auth, body, reply,
      [&](const RegisterSharedMemoryRequest &request, RegisterSharedMemoryResponse *) {
        Status s = options_.shm ? options_.shm->Register(ShmOwner(options_.auth, *ctx), request)
                                : Disabled();
        LogLine("RegisterSharedMemory " + request.name() + " " + request.key() +
                " bytes=" + std::to_string(request.byte_size()) +
                (s.ok() ? " ok" : " refused: " + s.message()));
        return ToGrpcStatus(s);
      });
}

grpc::ServerUnaryReactor *GlintServiceImpl::ListSharedMemory(grpc::CallbackServerContext *ctx,
                                                             const grpc::ByteBuffer *body,
                                                             grpc::ByteBuffer *reply) {
  return AnswerNow<ListSharedMemoryRequest, ListSharedMemoryResponse>(
      ctx, options_.auth, body, reply,
      [&](const ListSharedMemoryRequest &, ListSharedMemoryResponse *response) {
        if (options_.shm)
          for (auto &region : options_.shm->List(ShmOwner(options_.auth, *ctx)))
            *response->add_regions() = std::move(region);
        return grpc::Status::OK;
      });
}

grpc::ServerUnaryReactor *GlintServiceImpl::UnregisterSharedMemory(grpc::CallbackServerContext *ctx,
                                                                   const grpc::ByteBuffer *body,
                                                                   grpc::ByteBuffer *reply) {
  return AnswerNow<UnregisterSharedMemoryRequest, UnregisterSharedMemoryResponse>(
      ctx, options_.auth, body, reply,
      [&](const UnregisterSharedMemoryRequest &request, UnregisterSharedMemoryResponse *) {
        Status s = options_.shm
                       ? options_.shm->Unregister(ShmOwner(options_.auth, *ctx), request.name())
                       : Disabled();
        LogLine("UnregisterSharedMemory " + (request.name().empty() ? "(all)" : request.name()) +
                (s.ok() ? " ok" : " refused: " + s.message()));
        return ToGrpcStatus(s);
      });
}

}  // namespace glint
