#include "proto/wire/chunk_result.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/wire_format_lite.h>
#include <grpcpp/support/proto_buffer_reader.h>

#include <bit>
#include <cstring>
#include <vector>

namespace glint::wire {
namespace {

using google::protobuf::internal::WireFormatLite;
using google::protobuf::io::CodedInputStream;
using google::protobuf::io::CodedOutputStream;
using Result = glint::v1::EvaluateChunkResult;
using Response = glint::v1::EvaluateResponse;

static_assert(std::endian::native == std::endian::little,
              "packed floats are read and written as they lie in memory: little-endian only");

constexpr uint32_t Tag(int field, WireFormatLite::WireType type) {
  return WireFormatLite::MakeTag(field, type);
}
constexpr auto kVarint = WireFormatLite::WIRETYPE_VARINT;
constexpr auto kLength = WireFormatLite::WIRETYPE_LENGTH_DELIMITED;
constexpr auto kFixed32 = WireFormatLite::WIRETYPE_FIXED32;

size_t VarintSize(uint64_t v) {
  return CodedOutputStream::VarintSize64(v);
}

uint8_t *Varint(uint64_t v, uint8_t *p) {
  return CodedOutputStream::WriteVarint64ToArray(v, p);
}

// The radiance floats of one EvaluateResponse, appended at out[*written].
struct Sink {
  float *out;
  uint64_t capacity;
  uint64_t *written;
  bool Take(CodedInputStream *in, uint64_t floats) {
    if (floats > capacity - *written) return false;
    if (!in->ReadRaw(out + *written, int(floats * sizeof(float)))) return false;
    *written += floats;
    return true;
  }
};

std::string ParseResponse(CodedInputStream *in, Sink *sink, DecodedChunkResult *r) {
  while (uint32_t tag = in->ReadTag()) {
    const int field = WireFormatLite::GetTagFieldNumber(tag);
    if (tag == Tag(Response::kCountFieldNumber, kVarint)) {
      if (!in->ReadVarint32(&r->count)) return "result.count: truncated varint";
    } else if (tag == Tag(Response::kRadianceFieldNumber, kLength)) {
      uint32_t bytes = 0;
      if (!in->ReadVarint32(&bytes)) return "result.radiance: truncated length";
      if (bytes % sizeof(float)) return "result.radiance: packed length not a multiple of 4";
      if (int64_t(bytes) > in->BytesUntilLimit())
        return "result.radiance: packed length past the end of the result";
      r->radiance_floats += bytes / sizeof(float);
      if (!sink->Take(in, bytes / sizeof(float)))
        return *sink->written + bytes / sizeof(float) > sink->capacity
                   ? "result.radiance: more floats than the chunk's queries x 3"
                   : "result.radiance: truncated";
    } else if (tag == Tag(Response::kRadianceFieldNumber, kFixed32)) {
      // Unpacked (a parser must accept either form of a repeated scalar).
      ++r->radiance_floats;
      if (!sink->Take(in, 1))
        return *sink->written + 1 > sink->capacity
                   ? "result.radiance: more floats than the chunk's queries x 3"
                   : "result.radiance: truncated";
    } else if (tag == Tag(Response::kStatsFieldNumber, kLength)) {
      uint32_t bytes = 0;
      if (!in->ReadVarint32(&bytes) || bytes > INT32_MAX) return "result.stats: bad length";
      // A nested limit is clamped to the enclosing one: check the length against it first.
      if (int64_t(bytes) > in->BytesUntilLimit())
        return "result.stats: length past the end of the result";
      const auto limit = in->PushLimit(int(bytes));
      // Merged, as protobuf merges a repeated occurrence of a message field.
      if (!r->stats.MergePartialFromCodedStream(in) || !in->ConsumedEntireMessage())
        return "result.stats: does not parse";
      in->PopLimit(limit);
    } else if (field == 0) {
      return "result: field number 0";
    } else if (!WireFormatLite::SkipField(in, tag)) {
      // Unknown, or a known field with another wire type: protobuf skips both.
      return "result: unknown field " + std::to_string(field) + " truncated";
    }
  }
  return in->ConsumedEntireMessage() ? "" : "result: invalid tag";
}

}  // namespace

grpc::ByteBuffer EncodeChunkResult(uint64_t chunk_index, uint64_t first_query, uint32_t count,
                                   grpc_slice radiance, const glint::v1::EvaluateStats &stats) {
  const size_t radiance_bytes = GRPC_SLICE_LENGTH(radiance);
  const std::string stats_bytes = stats.SerializeAsString();
  // Proto3 leaves out zero scalars, empty arrays and (here) nothing else: the stats always go.
  const size_t response_bytes =
      (count ? 1 + VarintSize(count) : 0) +
      (radiance_bytes ? 1 + VarintSize(radiance_bytes) + radiance_bytes : 0) + 1 +
      VarintSize(stats_bytes.size()) + stats_bytes.size();
  // Head: everything before the radiance bytes; tail: the stats after them.
  uint8_t head[64];
  uint8_t *p = head;
  if (chunk_index) {
    *p++ = uint8_t(Tag(Result::kChunkIndexFieldNumber, kVarint));
    p = Varint(chunk_index, p);
  }
  if (first_query) {
    *p++ = uint8_t(Tag(Result::kFirstQueryFieldNumber, kVarint));
    p = Varint(first_query, p);
  }
  *p++ = uint8_t(Tag(Result::kResultFieldNumber, kLength));
  p = Varint(response_bytes, p);
  if (count) {
    *p++ = uint8_t(Tag(Response::kCountFieldNumber, kVarint));
    p = Varint(count, p);
  }
  if (radiance_bytes) {
    *p++ = uint8_t(Tag(Response::kRadianceFieldNumber, kLength));
    p = Varint(radiance_bytes, p);
  }
  std::string tail(1 + VarintSize(stats_bytes.size()), '\0');
  uint8_t *t = reinterpret_cast<uint8_t *>(tail.data());
  *t++ = uint8_t(Tag(Response::kStatsFieldNumber, kLength));
  Varint(stats_bytes.size(), t);
  tail += stats_bytes;

  std::vector<grpc::Slice> slices;
  slices.emplace_back(head, size_t(p - head));
  if (radiance_bytes)
    slices.emplace_back(radiance, grpc::Slice::STEAL_REF);
  else
    grpc_slice_unref(radiance);
  slices.emplace_back(tail);
  return grpc::ByteBuffer(slices.data(), slices.size());
}

std::string DecodeChunkResult(grpc::ByteBuffer *body, float *out, uint64_t capacity_floats,
                              DecodedChunkResult *r) {
  *r = DecodedChunkResult();
  uint64_t written = 0;
  Sink sink{out, capacity_floats, &written};
  std::string problem;
  {
    grpc::ProtoBufferReader reader(body);
    CodedInputStream in(&reader);
    while (problem.empty()) {
      const uint32_t tag = in.ReadTag();
      if (tag == 0) {
        if (!in.ConsumedEntireMessage()) problem = "invalid tag";
        break;
      }
      const int field = WireFormatLite::GetTagFieldNumber(tag);
      if (tag == Tag(Result::kChunkIndexFieldNumber, kVarint)) {
        if (!in.ReadVarint64(&r->chunk_index)) problem = "chunk_index: truncated varint";
      } else if (tag == Tag(Result::kFirstQueryFieldNumber, kVarint)) {
        if (!in.ReadVarint64(&r->first_query)) problem = "first_query: truncated varint";
      } else if (tag == Tag(Result::kResultFieldNumber, kLength)) {
        uint32_t bytes = 0;
        if (!in.ReadVarint32(&bytes) || bytes > INT32_MAX) {
          problem = "result: bad length";
          break;
        }
        const auto limit = in.PushLimit(int(bytes));
        problem = ParseResponse(&in, &sink, r);
        if (problem.empty() && in.BytesUntilLimit() != 0) problem = "result: truncated";
        in.PopLimit(limit);
      } else if (field == 0) {
        problem = "field number 0";
      } else if (!WireFormatLite::SkipField(&in, tag)) {
        // Unknown, or a known field with another wire type: protobuf skips both.
        problem = "unknown field " + std::to_string(field) + " truncated";
      }
    }
  }
  body->Clear();
  if (!problem.empty())
    return "a " + std::to_string(r->radiance_floats) +
           "-float chunk result does not parse as an EvaluateChunkResult: " + problem;
  return "";
}

}  // namespace glint::wire
