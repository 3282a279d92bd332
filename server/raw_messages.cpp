#include "server/raw_messages.h"

#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/impl/codegen/proto_utils.h>
#include <grpcpp/support/proto_buffer_writer.h>

namespace glint {

// Parses a raw request body. gRPC has already checked the frame (length prefix, size limit);
// what fails here is the protobuf inside it: truncated, a wrong wire type, a length past the end.
// The body buffer is released once parsed: only the parsed message stays in memory.
Status ParseBody(const grpc::ByteBuffer *body, google::protobuf::Message *out,
                 const std::string &what) {
  auto *raw = const_cast<grpc::ByteBuffer *>(body);
  // No buffer at all (not an empty one): the call ended before one whole message arrived, e.g.
  // a length prefix promising more bytes than came before the client's END_STREAM, or no DATA
  // frame. gRPC drops such a truncated message; parsing "nothing" would pass it off as an empty
  // request and answer about its first unset field instead.
  if (!raw->Valid())
    return Status::InvalidArgument(
        what + ": no complete " + out->GetTypeName() +
        " arrived (the call ended before one whole length-prefixed message: truncated, or none "
        "sent); expected exactly one message");
  const size_t bytes = raw->Length();
  bool ok = false;
  {
    grpc::ProtoBufferReader reader(raw);
    ok = out->ParseFromZeroCopyStream(&reader);
  }
  raw->Clear();
  if (ok) return Status::Ok();
  return Status::InvalidArgument(what + ": the " + std::to_string(bytes) +
                                 "-byte body does not parse as a " + out->GetTypeName() +
                                 " (truncated, or not this message); check that client and "
                                 "server use the same proto/glint/v1/glint.proto");
}

// Serialises a response into the raw reply buffer.
grpc::Status SerializeReply(const google::protobuf::Message &message, grpc::ByteBuffer *out) {
  out->Clear();  // a stream reuses its reply buffer; the writer wants an empty one
  bool own = false;
  grpc::Status s = grpc::GenericSerialize<grpc::ProtoBufferWriter, google::protobuf::Message>(
      message, out, &own);
  return s;
}

}  // namespace glint
