// GlintClient's normal-map resource calls (glint.v1.GlintService UploadNormalMap, ListNormalMaps,
// DeleteNormalMap).
#include <algorithm>

#include "client/lib/glint_client.h"
#include "client/lib/retry.h"

namespace glint::client {

grpc::Status GlintClient::UploadNormalMap(const std::string &filename, const std::string &bytes,
                                          glint::v1::NormalMapInfo *info) {
  constexpr size_t kChunk = size_t{1} << 20;
  // Retried like Evaluate (client/lib/retry.h): glintd refuses an upload with its retry pushback
  // while other uploads fill its upload gate (server/upload_gate.h), and an upload is
  // idempotent (the map is stored once by its digest).
  return CallWithRetries(options_.retry, Clock::time_point::max(), [&](RetryHint *hint) {
    grpc::ClientContext context;
    PrepareContext(&context);
    std::unique_ptr<grpc::ClientWriter<glint::v1::NormalMapChunk>> writer =
        stub_->UploadNormalMap(&context, info);
    size_t offset = 0;
    do {
      glint::v1::NormalMapChunk chunk;
      if (offset == 0) chunk.set_filename(filename);
      const size_t n = std::min(kChunk, bytes.size() - offset);
      chunk.set_data(bytes.data() + offset, n);
      offset += n;
      // A failed write means the server has finished the call (e.g. refused an oversize file):
      // Finish() below carries its status.
      if (!writer->Write(chunk)) break;
    } while (offset < bytes.size());
    writer->WritesDone();
    grpc::Status status = writer->Finish();
    hint->ReadFrom(context);
    return status;
  });
}

grpc::Status GlintClient::ListNormalMapsPage(const glint::v1::ListNormalMapsRequest &request,
                                             glint::v1::ListNormalMapsResponse *page) {
  grpc::ClientContext context;
  PrepareContext(&context);
  context.set_deadline(std::chrono::system_clock::now() + options_.rpc_timeout);
  return stub_->ListNormalMaps(&context, request, page);
}

grpc::Status GlintClient::ListNormalMaps(glint::v1::ListNormalMapsResponse *maps) {
  glint::v1::ListNormalMapsResponse all;
  glint::v1::ListNormalMapsRequest request;
  request.set_page_size(kNormalMapPageSize);
  do {
    glint::v1::ListNormalMapsResponse page;
    if (grpc::Status s = ListNormalMapsPage(request, &page); !s.ok()) return s;
    // A token that does not advance would loop forever; the server's never repeats.
    if (!page.next_page_token().empty() && page.next_page_token() == request.page_token())
      return grpc::Status(grpc::StatusCode::INTERNAL,
                          "ListNormalMaps: the server returned the same page token twice");
    for (auto &m : *page.mutable_maps()) *all.add_maps() = std::move(m);
    request.set_page_token(page.next_page_token());
  } while (!request.page_token().empty());
  *maps = std::move(all);
  return grpc::Status::OK;
}

grpc::Status GlintClient::DeleteNormalMap(const std::string &digest) {
  grpc::ClientContext context;
  PrepareContext(&context);
  context.set_deadline(std::chrono::system_clock::now() + options_.rpc_timeout);
  glint::v1::DeleteNormalMapRequest request;
  request.set_digest(digest);
  glint::v1::DeleteNormalMapResponse response;
  return stub_->DeleteNormalMap(&context, request, &response);
}

}  // namespace glint::client
