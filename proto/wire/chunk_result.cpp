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

// Protobuf's parser (ParseContext) is stricter than CodedInputStream's readers in three places,
// and the decoder follows the parser: a tag is a varint of at most 5 bytes (its value cut to 32
// bits) whose field number is not 0; a length is a varint of at most 5 bytes below
// INT_MAX - 16; unknown groups nest at most 100 deep (counted from the top-level message, one
// level used by each enclosing message).
constexpr int kRecursionLimit = 100;

// False for a malformed tag; *tag = 0 at the legitimate end of the message (or of a limit).
bool ReadTag(CodedInputStream *in, uint32_t *tag) {
  const int before = in->CurrentPosition();
  *tag = in->ReadTag();
  if (*tag == 0) return in->ConsumedEntireMessage();
  return in->CurrentPosition() - before <= 5 && WireFormatLite::GetTagFieldNumber(*tag) != 0;
}

bool ReadLength(CodedInputStream *in, int *bytes) {
  const int before = in->CurrentPosition();
  uint64_t v = 0;
  if (!in->ReadVarint64(&v) || in->CurrentPosition() - before > 5 || v > uint64_t(INT32_MAX - 16))
    return false;
  *bytes = int(v);
  return true;
}

// Skips an unknown field (or a known one with another wire type) as protobuf's parser does.
bool SkipField(CodedInputStream *in, uint32_t tag, int depth) {
  switch (WireFormatLite::GetTagWireType(tag)) {
    case WireFormatLite::WIRETYPE_VARINT: {
      uint64_t v = 0;
      return in->ReadVarint64(&v);
    }
    case WireFormatLite::WIRETYPE_FIXED64:
      return in->Skip(8);
    case WireFormatLite::WIRETYPE_LENGTH_DELIMITED: {
      int bytes = 0;
      return ReadLength(in, &bytes) && in->Skip(bytes);
    }
    case WireFormatLite::WIRETYPE_START_GROUP: {
      if (--depth < 0) return false;
      const uint32_t end = WireFormatLite::MakeTag(WireFormatLite::GetTagFieldNumber(tag),
                                                   WireFormatLite::WIRETYPE_END_GROUP);
      for (;;) {
        uint32_t inner = 0;
        if (!ReadTag(in, &inner) || inner == 0) return false;
        if (inner == end) return true;
        if (!SkipField(in, inner, depth)) return false;
      }
    }
    case WireFormatLite::WIRETYPE_FIXED32:
      return in->Skip(4);
    default:  // END_GROUP without its START_GROUP, or wire types 6 and 7
      return false;
  }
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

// The fields of an EvaluateResponse up to the current limit (the enclosing `result` field).
std::string ParseResponse(CodedInputStream *in, Sink *sink, DecodedChunkResult *r) {
  const int depth = kRecursionLimit - 1;  // inside the top-level message
  for (;;) {
    uint32_t tag = 0;
    if (!ReadTag(in, &tag)) return "result: invalid tag";
    if (tag == 0) return "";
    if (tag == Tag(Response::kCountFieldNumber, kVarint)) {
      if (!in->ReadVarint32(&r->count)) return "result.count: truncated varint";
    } else if (tag == Tag(Response::kRadianceFieldNumber, kLength)) {
      int bytes = 0;
      if (!ReadLength(in, &bytes)) return "result.radiance: bad length";
      if (bytes % int(sizeof(float))) return "result.radiance: packed length not a multiple of 4";
      if (bytes > in->BytesUntilLimit())
        return "result.radiance: packed length past the end of the result";
      r->radiance_floats += uint64_t(bytes) / sizeof(float);
      if (!sink->Take(in, uint64_t(bytes) / sizeof(float)))
        return "result.radiance: more floats than the chunk's queries x 3";
    } else if (tag == Tag(Response::kRadianceFieldNumber, kFixed32)) {
      // Unpacked (a parser must accept either form of a repeated scalar).
      ++r->radiance_floats;
      if (*sink->written + 1 > sink->capacity)
        return "result.radiance: more floats than the chunk's queries x 3";
      if (!sink->Take(in, 1)) return "result.radiance: truncated";
    } else if (tag == Tag(Response::kStatsFieldNumber, kLength)) {
      int bytes = 0;
      if (!ReadLength(in, &bytes)) return "result.stats: bad length";
      // A nested limit is clamped to the enclosing one: check the length against it first.
      if (bytes > in->BytesUntilLimit()) return "result.stats: length past the end of the result";
      const auto limit = in->PushLimit(bytes);
      // Merged, as protobuf merges a repeated occurrence of a message field; at the nesting
      // depth protobuf's parser would be at (top level, result, stats).
      in->SetRecursionLimit(kRecursionLimit - 2);
      // It may also stop at an end-group tag, which it leaves as the last tag: refused.
      in->SetLastTag(0);
      if (!r->stats.MergePartialFromCodedStream(in) || !in->LastTagWas(0) ||
          !in->ConsumedEntireMessage())
        return "result.stats: does not parse";
      in->PopLimit(limit);
    } else if (!SkipField(in, tag, depth)) {
      return "result: unknown field " + std::to_string(WireFormatLite::GetTagFieldNumber(tag)) +
             " malformed";
    }
  }
}

}  // namespace

namespace {

// An EvaluateResponse{count, radiance, stats} whose radiance bytes are `radiance` (referenced),
// after `prefix` (the enclosing message's bytes before it, when nested): the head (prefix, count,
// the radiance's tag and length), the radiance slice, then the stats as the tail. `prefix` gets
// the response's length in bytes to write its length-delimited header, if any.
template <class Prefix>
grpc::ByteBuffer EncodeResponse(uint32_t count, grpc_slice radiance,
                                const glint::v1::EvaluateStats &stats, Prefix &&prefix) {
  const size_t radiance_bytes = GRPC_SLICE_LENGTH(radiance);
  const std::string stats_bytes = stats.SerializeAsString();
  // Proto3 leaves out zero scalars, empty arrays and (here) nothing else: the stats always go.
  const size_t response_bytes =
      (count ? 1 + VarintSize(count) : 0) +
      (radiance_bytes ? 1 + VarintSize(radiance_bytes) + radiance_bytes : 0) + 1 +
      VarintSize(stats_bytes.size()) + stats_bytes.size();
  // Head: everything before the radiance bytes; tail: the stats after them.
  uint8_t head[64];
  uint8_t *p = prefix(head, response_bytes);
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

}  // namespace

grpc::ByteBuffer EncodeChunkResult(uint64_t chunk_index, uint64_t first_query, uint32_t count,
                                   grpc_slice radiance, const glint::v1::EvaluateStats &stats) {
  return EncodeResponse(count, radiance, stats, [&](uint8_t *p, size_t response_bytes) {
    if (chunk_index) {
      *p++ = uint8_t(Tag(Result::kChunkIndexFieldNumber, kVarint));
      p = Varint(chunk_index, p);
    }
    if (first_query) {
      *p++ = uint8_t(Tag(Result::kFirstQueryFieldNumber, kVarint));
      p = Varint(first_query, p);
    }
    *p++ = uint8_t(Tag(Result::kResultFieldNumber, kLength));
    return Varint(response_bytes, p);
  });
}

grpc::ByteBuffer EncodeEvaluateResponse(uint32_t count, grpc_slice radiance,
                                        const glint::v1::EvaluateStats &stats) {
  return EncodeResponse(count, radiance, stats, [](uint8_t *p, size_t) { return p; });
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
      uint32_t tag = 0;
      if (!ReadTag(&in, &tag)) {
        problem = "invalid tag";
        break;
      }
      if (tag == 0) break;
      if (tag == Tag(Result::kChunkIndexFieldNumber, kVarint)) {
        if (!in.ReadVarint64(&r->chunk_index)) problem = "chunk_index: truncated varint";
      } else if (tag == Tag(Result::kFirstQueryFieldNumber, kVarint)) {
        if (!in.ReadVarint64(&r->first_query)) problem = "first_query: truncated varint";
      } else if (tag == Tag(Result::kResultFieldNumber, kLength)) {
        int bytes = 0;
        if (!ReadLength(&in, &bytes)) {
          problem = "result: bad length";
          break;
        }
        const auto limit = in.PushLimit(bytes);
        problem = ParseResponse(&in, &sink, r);
        if (problem.empty() && in.BytesUntilLimit() != 0) problem = "result: truncated";
        in.PopLimit(limit);
      } else if (!SkipField(&in, tag, kRecursionLimit)) {
        problem = "unknown field " + std::to_string(WireFormatLite::GetTagFieldNumber(tag)) +
                  " malformed";
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
