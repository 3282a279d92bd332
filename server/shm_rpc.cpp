// The shared-memory region RPCs of GlintServiceImpl (RegisterSharedMemory, ListSharedMemory,
// UnregisterSharedMemory) on the server's ShmRegistry (server/shm_regions.h). Each is guarded by
// the bearer-token check like every other glint.v1 handler; the token, when there is one, is the
// owner of the regions (server/shm_io.h ShmOwner).
#include "server/service.h"
#include "server/shm_io.h"
#include "server/shm_regions.h"

namespace glint {
namespace {

grpc::ServerUnaryReactor *Answer(grpc::CallbackServerContext *ctx, const grpc::Status &s) {
  auto *reactor = ctx->DefaultReactor();
  reactor->Finish(s);
  return reactor;
}

Status Disabled() {
  return Status::FailedPrecondition(
      "shared memory is disabled on this server (--max-shm-regions 0)");
}

}  // namespace

grpc::ServerUnaryReactor *GlintServiceImpl::RegisterSharedMemory(
    grpc::CallbackServerContext *ctx, const glint::v1::RegisterSharedMemoryRequest *request,
    glint::v1::RegisterSharedMemoryResponse *) {
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok())
    return Answer(ctx, denied);
  Status s =
      options_.shm ? options_.shm->Register(ShmOwner(options_.auth, *ctx), *request) : Disabled();
  LogLine("RegisterSharedMemory " + request->name() + " " + request->key() + " bytes=" +
          std::to_string(request->byte_size()) + (s.ok() ? " ok" : " refused: " + s.message()));
  return Answer(ctx, ToGrpcStatus(s));
}

grpc::ServerUnaryReactor *GlintServiceImpl::ListSharedMemory(
    grpc::CallbackServerContext *ctx, const glint::v1::ListSharedMemoryRequest *,
    glint::v1::ListSharedMemoryResponse *response) {
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok())
    return Answer(ctx, denied);
  if (options_.shm)
    for (auto &region : options_.shm->List(ShmOwner(options_.auth, *ctx)))
      *response->add_regions() = std::move(region);
  return Answer(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor *GlintServiceImpl::UnregisterSharedMemory(
    grpc::CallbackServerContext *ctx, const glint::v1::UnregisterSharedMemoryRequest *request,
    glint::v1::UnregisterSharedMemoryResponse *) {
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok())
    return Answer(ctx, denied);
  Status s = options_.shm ? options_.shm->Unregister(ShmOwner(options_.auth, *ctx), request->name())
                          : Disabled();
  LogLine("UnregisterSharedMemory " + (request->name().empty() ? "(all)" : request->name()) +
          (s.ok() ? " ok" : " refused: " + s.message()));
  return Answer(ctx, ToGrpcStatus(s));
}

}  // namespace glint
