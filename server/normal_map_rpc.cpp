// The normal-map resource RPCs of GlintServiceImpl: UploadNormalMap (client-streamed chunks of
// one file), ListNormalMaps, DeleteNormalMap, on the process's NormalMapStore.
#include <mutex>
#include <sstream>
#include <thread>

#include "server/auth.h"
#include "server/normal_map_store.h"
#include "server/raw_messages.h"
#include "server/service.h"
#include "server/upload_gate.h"

namespace glint {
namespace {

// Uploads in progress at once, whatever their size (each waiting decode is a thread).
constexpr uint32_t kMaxUploadsInProgress = 16;

// The process's upload gate (server/upload_gate.h), sized from glintd's flags on first use (an
// upload arrives only once the server is serving, after the flags are applied): two of the
// largest files accepted.
UploadGate &Uploads() {
  static UploadGate gate(2 * NormalMaps().limits().max_upload_bytes, kMaxUploadsInProgress);
  return gate;
}

// Collects the chunks (refusing early once the file is over the size limit), then decodes and
// stores on a thread of its own: decoding a large map takes a while and must not hold a gRPC
// callback thread. Raw like the other methods (service.h): each chunk is parsed here, so one
// that does not parse ends the upload with INVALID_ARGUMENT naming the chunk and the message
// (gRPC's typed reader ended the reads as if the client had half-closed, and the bytes before
// it were decoded as the whole file).
class UploadReactor : public grpc::ServerReadReactor<grpc::ByteBuffer> {
 public:
  // Counted in Uploads() (Begin succeeded) until OnDone.
  UploadReactor(GlintServiceImpl *service, grpc::CallbackServerContext *ctx,
                grpc::ByteBuffer *reply)
      : service_(service),
        ctx_(ctx),
        reply_(reply),
        max_bytes_(NormalMaps().limits().max_upload_bytes) {
    StartRead(&raw_chunk_);
  }

  void OnReadDone(bool ok) override {
    if (ok) {
      if (Status parsed = ParseBody(&raw_chunk_, &chunk_, "chunk " + std::to_string(chunks_read_));
          !parsed.ok())
        return Done(parsed);
      ++chunks_read_;
      if (filename_.empty()) {
        // Refused before the file's bytes are collected (NormalMapStore::Upload checks it too).
        if (Status named = CheckNormalMapFilename(chunk_.filename()); !named.ok())
          return Done(named);
        filename_ = chunk_.filename();
      }
      if (bytes_.size() + chunk_.data().size() > max_bytes_) {
        return Done(Status::InvalidArgument(
            "normal map " + Name() + ": over " + std::to_string(max_bytes_) +
            " bytes; the server accepts at most that (Capabilities.max_normal_map_upload_bytes)"));
      }
      if (Status room = Uploads().Reserve(chunk_.data().size(), bytes_.size()); !room.ok()) {
        AddRetryPushback(ctx_, service_->options().slice_ms);
        return Done(room);
      }
      bytes_ += chunk_.data();
      StartRead(&raw_chunk_);
      return;
    }
    // Reads also end when the call is cancelled (client gone, shutdown): the bytes so far are
    // not a file the client finished sending, so nothing is decoded.
    if (ctx_->IsCancelled()) return Done(Status::Cancelled("the upload was cancelled"));
    std::thread([this] {
      Status s;
      {
        // One decode at a time: each holds the whole image several times over.
        std::lock_guard<std::mutex> turn(Uploads().DecodeTurn());
        s = NormalMaps().Upload(Name(), bytes_, &response_);
      }
      Done(s);
    }).detach();
  }

  void OnDone() override {
    if (!released_) Uploads().End(bytes_.size());  // Done releases first; OnDone follows Finish
    delete this;
  }

 private:
  std::string Name() const { return filename_.empty() ? std::string("(unnamed)") : filename_; }
  void Done(const Status &s) {
    std::ostringstream line;
    line << "UploadNormalMap " << Name() << " bytes=" << bytes_.size() << " "
         << (s.ok() ? response_.digest() + (response_.already_present() ? " (already held)" : "")
                    : "refused: " + s.message());
    service_->LogLine(line.str());
    grpc::Status status = ToGrpcStatus(s);
    if (status.ok()) status = SerializeReply(response_, reply_);
    // The file's bytes and this upload's share of the gate go before the answer, not in OnDone
    // (after the client has it): a client that uploads again on receipt of the answer must find
    // the room this one held (upload_gate_test saw a refusal "uploads in progress hold 2097152
    // bytes" right after both holders were answered), as the scheduler frees a slot before it
    // answers.
    const uint64_t held = bytes_.size();
    std::string().swap(bytes_);
    Uploads().End(held);
    released_ = true;
    Finish(status);
  }

  GlintServiceImpl *service_;
  grpc::CallbackServerContext *ctx_;
  grpc::ByteBuffer *reply_;
  glint::v1::NormalMapInfo response_;
  uint64_t max_bytes_;
  grpc::ByteBuffer raw_chunk_;
  uint64_t chunks_read_ = 0;
  glint::v1::NormalMapChunk chunk_;
  std::string filename_, bytes_;
  bool released_ = false;  // Done gave back this upload's share of the gate
};

}  // namespace

grpc::ServerReadReactor<grpc::ByteBuffer> *GlintServiceImpl::UploadNormalMap(
    grpc::CallbackServerContext *ctx, grpc::ByteBuffer *reply) {
  if (grpc::Status denied = CheckBearer(options_.auth, *ctx); !denied.ok())
    return new RefusedReadReactor<grpc::ByteBuffer>(denied);
  if (Status busy = Uploads().Begin(); !busy.ok()) {
    LogLine("UploadNormalMap refused: " + busy.message());
    AddRetryPushback(ctx, options_.slice_ms);
    return new RefusedReadReactor<grpc::ByteBuffer>(ToGrpcStatus(busy));
  }
  return new UploadReactor(this, ctx, reply);
}

grpc::ServerUnaryReactor *GlintServiceImpl::ListNormalMaps(grpc::CallbackServerContext *ctx,
                                                           const grpc::ByteBuffer *body,
                                                           grpc::ByteBuffer *reply) {
  using glint::v1::ListNormalMapsRequest;
  using glint::v1::ListNormalMapsResponse;
  return AnswerNow<ListNormalMapsRequest, ListNormalMapsResponse>(
      ctx, options_.auth, body, reply,
      [](const ListNormalMapsRequest &request, ListNormalMapsResponse *response) {
        return ToGrpcStatus(NormalMaps().List(request, response));
      });
}

grpc::ServerUnaryReactor *GlintServiceImpl::DeleteNormalMap(grpc::CallbackServerContext *ctx,
                                                            const grpc::ByteBuffer *body,
                                                            grpc::ByteBuffer *reply) {
  using glint::v1::DeleteNormalMapRequest;
  using glint::v1::DeleteNormalMapResponse;
  return AnswerNow<DeleteNormalMapRequest, DeleteNormalMapResponse>(
      ctx, options_.auth, body, reply,
      [&](const DeleteNormalMapRequest &request, DeleteNormalMapResponse *) {
        Status s = NormalMaps().Delete(request.digest());
        LogLine("DeleteNormalMap " + request.digest() +
                (s.ok() ? " ok" : " refused: " + s.message()));
        return ToGrpcStatus(s);
      });
}

}  // namespace glint
