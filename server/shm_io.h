// Evaluate with queries and results in shared memory (glint.proto SharedMemoryIo): the layout
// arithmetic, the checks made before a call is queued, and the copies in and out of the
// mapping. GlintServiceImpl::RunShared (server/shm_io.cpp) runs such a call.
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <memory>
#include <string>

#include "glint/v1/glint.pb.h"
#include "server/auth.h"
#include "server/query_view.h"
#include "server/shm_regions.h"
#include "server/status.h"

namespace glint {

// The owner of the caller's regions: its authorization header when the server checks tokens
// (held in memory only, never logged), else "" (one namespace for the whole server).
std::string ShmOwner(const TokenAuth *auth, const grpc::ServerContextBase &context);

// Floats per query of the input blocks that `io` says are present (wo always: 3).
uint32_t SharedMemoryFloatsPerQuery(const glint::v1::SharedMemoryIo &io);

// What can be checked before queueing: queries empty, count > 0, region names, input_byte_size
// equal to the layout's size. INVALID_ARGUMENT naming the shared_memory field.
Status CheckSharedMemoryRequest(const glint::v1::EvaluateRequest &request);

// The two regions of a call, looked up for `owner` and their ranges checked against the
// objects' current sizes (fstat) at the time of the call.
struct SharedMemoryCall {
  std::shared_ptr<const ShmRegion> in, out;  // held until the call is done
  const uint8_t *input = nullptr;
  float *output = nullptr;
  uint32_t count = 0;
  // The output window shares bytes of the object with the input window (WindowsOverlap): the
  // call is then evaluated on a copy of its queries, never in place.
  bool windows_overlap = false;
};
Status ResolveSharedMemoryCall(const ShmRegistry &registry, const std::string &owner,
                               const glint::v1::SharedMemoryIo &io, SharedMemoryCall *call);

// Copies the input blocks into `queries` (a QueryBatch like one sent over the wire: the same
// validation and kernels then apply), under the SIGBUS guard.
Status LoadSharedQueries(const SharedMemoryCall &call, const glint::v1::SharedMemoryIo &io,
                         glint::v1::QueryBatch *queries);

// The input blocks of `call` as views into the region (server/query_view.h).
QueryView SharedQueryView(const SharedMemoryCall &call, const glint::v1::SharedMemoryIo &io);

// Whether RunShared evaluates `call` on those views (no copy): on the device, with a
// float-aligned input that the output window does not overlap, for kernels that stay safe on
// any bytes (SMOOTH without polygon lights). Otherwise the queries are copied out of the region
// first (LoadSharedQueries), before any radiance is written, so an output window over the
// input (e.g. the radiance written over the queries it came from) gives the results of the
// same queries sent over TCP.
bool EvaluatesInPlace(const SharedMemoryCall &call, const glint::v1::EvaluateRequest &settings,
                      bool on_device);

// Copies 3 * count floats of radiance into the output region, under the SIGBUS guard.
Status StoreSharedRadiance(const SharedMemoryCall &call, const float *rgb);

}  // namespace glint
