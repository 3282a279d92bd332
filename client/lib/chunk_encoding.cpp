#include "client/lib/chunk_encoding.h"

#include <google/protobuf/io/coded_stream.h>
#include <grpc/slice.h>
#include <grpcpp/support/sync_stream.h>

#include <bit>
#include <cstring>
#include <vector>

namespace glint::client {
namespace {

using glint::v1::QueryBatch;
using google::protobuf::io::CodedOutputStream;

static_assert(std::endian::native == std::endian::little,
              "packed floats are written as they lie in memory: little-endian hosts only");

// Protobuf wire types: 0 varint, 2 length-delimited.
constexpr uint32_t Tag(int field, int wire_type) {
  return (uint32_t(field) << 3) | uint32_t(wire_type);
}

// The packed float arrays of QueryBatch with their field numbers and floats per query.
struct Packed {
  int field;
  int components;
  const google::protobuf::RepeatedField<float> &(QueryBatch::*get)() const;
};
constexpr Packed kPacked[] = {
    {QueryBatch::kUvFieldNumber, 2, &QueryBatch::uv},
    {QueryBatch::kFootprintFieldNumber, 4, &QueryBatch::footprint},
    {QueryBatch::kWoFieldNumber, 3, &QueryBatch::wo},
    {QueryBatch::kWiFieldNumber, 3, &QueryBatch::wi},
    {QueryBatch::kPositionFieldNumber, 3, &QueryBatch::position},
    {QueryBatch::kNormalFieldNumber, 3, &QueryBatch::normal},
    {QueryBatch::kTangentFieldNumber, 3, &QueryBatch::tangent},
};

size_t VarintSize(uint64_t v) {
  return CodedOutputStream::VarintSize64(v);
}

uint8_t *Varint(uint64_t v, uint8_t *p) {
  return CodedOutputStream::WriteVarint64ToArray(v, p);
}

// The encoded size of a QueryBatch of `count` queries of `batch`'s arrays; the EvaluateRequest and
// the chunk around it are sized from it inside out. Proto3 leaves out a zero scalar, as the
// generated serialiser does.
size_t QueriesBytes(const QueryBatch &batch, uint32_t count) {
  size_t queries_bytes = count ? 1 + VarintSize(count) : 0;
  for (const Packed &a : kPacked) {
    if ((batch.*a.get)().empty() || count == 0) continue;
    const size_t bytes = size_t(count) * size_t(a.components) * sizeof(float);
    queries_bytes += VarintSize(Tag(a.field, 2)) + VarintSize(bytes) + bytes;
  }
  return queries_bytes;
}

}  // namespace

grpc::ByteBuffer EncodeChunk(uint64_t chunk_index, const std::string &settings,
                             const QueryBatch &batch, uint32_t begin, uint32_t end) {
  const uint32_t count = end - begin;
  const size_t queries_bytes = QueriesBytes(batch, count);
  const size_t request_bytes = settings.size() + 1 + VarintSize(queries_bytes) + queries_bytes;
  const size_t total = (chunk_index ? 1 + VarintSize(chunk_index) : 0) + 1 +
                       VarintSize(request_bytes) + request_bytes;

  grpc_slice slice = grpc_slice_malloc(total);
  uint8_t *p = GRPC_SLICE_START_PTR(slice);
  if (chunk_index) {
    *p++ = uint8_t(Tag(glint::v1::EvaluateChunk::kChunkIndexFieldNumber, 0));
    p = Varint(chunk_index, p);
  }
  *p++ = uint8_t(Tag(glint::v1::EvaluateChunk::kRequestFieldNumber, 2));
  p = Varint(request_bytes, p);
  std::memcpy(p, settings.data(), settings.size());
  p += settings.size();
  *p++ = uint8_t(Tag(glint::v1::EvaluateRequest::kQueriesFieldNumber, 2));
  p = Varint(queries_bytes, p);
  if (count) {
    *p++ = uint8_t(Tag(QueryBatch::kCountFieldNumber, 0));
    p = Varint(count, p);
  }
  for (const Packed &a : kPacked) {
    const auto &field = (batch.*a.get)();
    if (field.empty() || count == 0) continue;
    const size_t bytes = size_t(count) * size_t(a.components) * sizeof(float);
    p = Varint(Tag(a.field, 2), p);
    p = Varint(bytes, p);
    std::memcpy(p, field.data() + size_t(begin) * size_t(a.components), bytes);
    p += bytes;
  }
  grpc::Slice owned(slice, grpc::Slice::STEAL_REF);
  return grpc::ByteBuffer(&owned, 1);
}

namespace {
void NoRelease(void *) {}
}  // namespace

grpc::ByteBuffer EncodeChunkReferencing(uint64_t chunk_index, const std::string &settings,
                                        const QueryBatch &batch, uint32_t begin, uint32_t end) {
  const uint32_t count = end - begin;
  const size_t queries_bytes = QueriesBytes(batch, count);
  const size_t request_bytes = settings.size() + 1 + VarintSize(queries_bytes) + queries_bytes;
  // One slice for everything up to the first array's tag and length, then per array: the rows in
  // place, followed by the next array's tag and length (or nothing after the last).
  std::vector<grpc::Slice> slices;
  std::string head;
  head.reserve(32 + settings.size());
  uint8_t buf[32];
  auto put = [&](uint8_t *e) { head.append(reinterpret_cast<const char *>(buf), size_t(e - buf)); };
  if (chunk_index) {
    buf[0] = uint8_t(Tag(glint::v1::EvaluateChunk::kChunkIndexFieldNumber, 0));
    put(Varint(chunk_index, buf + 1));
  }
  buf[0] = uint8_t(Tag(glint::v1::EvaluateChunk::kRequestFieldNumber, 2));
  put(Varint(request_bytes, buf + 1));
  head += settings;
  buf[0] = uint8_t(Tag(glint::v1::EvaluateRequest::kQueriesFieldNumber, 2));
  put(Varint(queries_bytes, buf + 1));
  if (count) {
    buf[0] = uint8_t(Tag(QueryBatch::kCountFieldNumber, 0));
    put(Varint(count, buf + 1));
  }
  for (const Packed &a : kPacked) {
    const auto &field = (batch.*a.get)();
    if (field.empty() || count == 0) continue;
    const size_t bytes = size_t(count) * size_t(a.components) * sizeof(float);
    put(Varint(bytes, Varint(Tag(a.field, 2), buf)));
    slices.emplace_back(head);
    head.clear();
    // const_cast: gRPC's slice type is mutable, but an outgoing message is only read.
    void *rows = const_cast<float *>(field.data() + size_t(begin) * size_t(a.components));
    slices.emplace_back(grpc_slice_new_with_user_data(rows, bytes, &NoRelease, nullptr),
                        grpc::Slice::STEAL_REF);
  }
  if (!head.empty()) slices.emplace_back(head);
  return grpc::ByteBuffer(slices.data(), slices.size());
}

std::unique_ptr<RawChunkStream> OpenRawChunkStream(grpc::Channel *channel,
                                                   grpc::ClientContext *context) {
  static const char kMethod[] = "/glint.v1.GlintService/EvaluateStream";
  const grpc::internal::RpcMethod method(kMethod, grpc::internal::RpcMethod::BIDI_STREAMING,
                                         channel->shared_from_this());
  return std::unique_ptr<RawChunkStream>(
      grpc::internal::ClientReaderWriterFactory<grpc::ByteBuffer, grpc::ByteBuffer>::Create(
          channel, method, context));
}

}  // namespace glint::client
