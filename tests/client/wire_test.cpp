// The hand-written wire forms of proto/wire (issue 12) against protobuf's own serialiser and
// parser, which define the wire contract: EncodeChunkResult and EncodeEvaluateResponse must write
// exactly protobuf's bytes;
// DecodeChunkResult must accept exactly what protobuf's parser accepts and decode it to the same
// values, including bad bytes (every truncation, random corruptions), fields out of order,
// unpacked radiance, repeated `result` fields and unknown fields; and never write past its
// output. SlicePool must reuse its buffers and stay bounded.
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/wire_format_lite.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "proto/wire/chunk_result.h"
#include "proto/wire/slice_pool.h"

namespace glint::wire {
namespace {

using glint::v1::EvaluateChunkResult;
using google::protobuf::internal::WireFormatLite;

std::string Bytes(const grpc::ByteBuffer &buffer) {
  std::vector<grpc::Slice> slices;
  EXPECT_TRUE(buffer.Dump(&slices).ok());
  std::string out;
  for (const grpc::Slice &s : slices)
    out.append(reinterpret_cast<const char *>(s.begin()), s.size());
  return out;
}

// `bytes` split into slices of `piece` bytes, as gRPC's receive buffers would hold them.
grpc::ByteBuffer Buffer(const std::string &bytes, size_t piece = 7) {
  std::vector<grpc::Slice> slices;
  for (size_t i = 0; i < bytes.size(); i += piece)
    slices.emplace_back(bytes.data() + i, std::min(piece, bytes.size() - i));
  if (slices.empty()) return grpc::ByteBuffer();
  return grpc::ByteBuffer(slices.data(), slices.size());
}

EvaluateChunkResult Result(uint64_t index, uint64_t first, uint32_t count, uint32_t seed) {
  EvaluateChunkResult r;
  r.set_chunk_index(index);
  r.set_first_query(first);
  r.mutable_result()->set_count(count);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  for (uint32_t i = 0; i < 3 * count; ++i) r.mutable_result()->add_radiance(u(rng));
  auto *stats = r.mutable_result()->mutable_stats();
  stats->set_compute_ms(1.25 * seed);
  stats->set_device(seed % 2 ? "pthread-skylake" : "");
  stats->set_queue_ms(seed % 3 ? 0.5 : 0.0);
  stats->set_batch_requests(seed % 4);
  return r;
}

grpc::ByteBuffer Encode(const EvaluateChunkResult &r) {
  const auto &radiance = r.result().radiance();
  grpc_slice slice = grpc_slice_malloc(size_t(radiance.size()) * sizeof(float));
  if (!radiance.empty())
    std::memcpy(GRPC_SLICE_START_PTR(slice), radiance.data(), GRPC_SLICE_LENGTH(slice));
  return EncodeChunkResult(r.chunk_index(), r.first_query(), r.result().count(), slice,
                           r.result().stats());
}

TEST(WireChunkResult, EncodesExactlyProtobufsBytes) {
  for (uint64_t index : {0ull, 1ull, 300ull, 1ull << 40})
    for (uint64_t first : {0ull, 5ull, 1ull << 33})
      for (uint32_t count : {0u, 1u, 1000u}) {
        const EvaluateChunkResult r = Result(index, first, count, uint32_t(index + count) + 1);
        EXPECT_EQ(Bytes(Encode(r)), r.SerializeAsString())
            << "index " << index << " first " << first << " count " << count;
      }
}

// The unary Evaluate's reply (EncodeEvaluateResponse): exactly protobuf's bytes for the same
// EvaluateResponse (count 0 and an empty radiance left out, as proto3 does; stats with and without
// every field), and protobuf's parser reads back the same radiance bits and stats.
TEST(WireEvaluateResponse, EncodesExactlyProtobufsBytes) {
  for (uint32_t count : {0u, 1u, 5u, 1000u, 70000u}) {
    const glint::v1::EvaluateResponse r = Result(0, 0, count, count + 3).result();
    const auto &radiance = r.radiance();
    grpc_slice slice = grpc_slice_malloc(size_t(radiance.size()) * sizeof(float));
    if (!radiance.empty())
      std::memcpy(GRPC_SLICE_START_PTR(slice), radiance.data(), GRPC_SLICE_LENGTH(slice));
    const std::string bytes = Bytes(EncodeEvaluateResponse(r.count(), slice, r.stats()));
    EXPECT_EQ(bytes, r.SerializeAsString()) << "count " << count;
    glint::v1::EvaluateResponse parsed;
    ASSERT_TRUE(parsed.ParseFromString(bytes)) << "count " << count;
    EXPECT_EQ(parsed.count(), count);
    ASSERT_EQ(parsed.radiance_size(), int(3 * count));
    if (count) {
      EXPECT_EQ(0, std::memcmp(parsed.radiance().data(), radiance.data(),
                               size_t(radiance.size()) * sizeof(float)));
    }
    EXPECT_EQ(parsed.stats().SerializeAsString(), r.stats().SerializeAsString());
  }
}

// What protobuf's parser makes of `bytes`, compared with DecodeChunkResult's result; `capacity`
// floats of room (a canary after them must survive).
void ExpectSameAsProtobuf(const std::string &bytes, const std::string &what,
                          uint64_t capacity = 1u << 16) {
  EvaluateChunkResult expected;
  const bool parses = expected.ParseFromString(bytes);
  std::vector<float> out(capacity + 4, -7.0f);
  DecodedChunkResult got;
  grpc::ByteBuffer buffer = Buffer(bytes);
  const std::string problem = DecodeChunkResult(&buffer, out.data(), capacity, &got);
  for (uint64_t i = capacity; i < capacity + 4; ++i)
    ASSERT_EQ(out[i], -7.0f) << what << ": wrote past the output";
  ASSERT_EQ(problem.empty(), parses) << what << ": " << problem;
  if (!parses) return;
  EXPECT_EQ(got.chunk_index, expected.chunk_index()) << what;
  EXPECT_EQ(got.first_query, expected.first_query()) << what;
  EXPECT_EQ(got.count, expected.result().count()) << what;
  ASSERT_EQ(got.radiance_floats, uint64_t(expected.result().radiance_size())) << what;
  if (got.radiance_floats) {
    EXPECT_EQ(0, std::memcmp(out.data(), expected.result().radiance().data(),
                             got.radiance_floats * sizeof(float)))
        << what;
  }
  EXPECT_EQ(got.stats.SerializeAsString(), expected.result().stats().SerializeAsString()) << what;
}

TEST(WireChunkResult, DecodesWhatProtobufWrites) {
  for (uint32_t count : {0u, 1u, 17u, 5000u})
    ExpectSameAsProtobuf(Result(3, 99, count, count + 2).SerializeAsString(),
                         "count " + std::to_string(count));
}

// Encodings protobuf's own serialiser never writes but its parser accepts.
TEST(WireChunkResult, DecodesOtherValidEncodingsAsProtobufDoes) {
  using google::protobuf::io::CodedOutputStream;
  using google::protobuf::io::StringOutputStream;
  const EvaluateChunkResult r = Result(2, 40, 20, 5);
  const std::string response = r.result().SerializeAsString();
  auto write = [](auto &&body) {
    std::string s;
    {
      StringOutputStream stream(&s);
      CodedOutputStream out(&stream);
      body(&out);
    }
    return s;
  };
  // Fields in reverse order, the response split into two `result` fields (merged: count
  // overwritten, radiance appended, stats merged), an unknown varint, fixed64 and group field.
  const std::string reordered = write([&](CodedOutputStream *o) {
    const EvaluateChunkResult half1 = Result(0, 0, 10, 6), half2 = Result(0, 0, 10, 7);
    for (const auto *h : {&half1, &half2}) {
      const std::string part = h->result().SerializeAsString();
      o->WriteTag(WireFormatLite::MakeTag(3, WireFormatLite::WIRETYPE_LENGTH_DELIMITED));
      o->WriteVarint32(uint32_t(part.size()));
      o->WriteString(part);
    }
    o->WriteTag(WireFormatLite::MakeTag(99, WireFormatLite::WIRETYPE_VARINT));
    o->WriteVarint64(12345);
    o->WriteTag(WireFormatLite::MakeTag(98, WireFormatLite::WIRETYPE_FIXED64));
    o->WriteLittleEndian64(7);
    o->WriteTag(WireFormatLite::MakeTag(97, WireFormatLite::WIRETYPE_START_GROUP));
    o->WriteTag(WireFormatLite::MakeTag(1, WireFormatLite::WIRETYPE_VARINT));
    o->WriteVarint32(1);
    o->WriteTag(WireFormatLite::MakeTag(97, WireFormatLite::WIRETYPE_END_GROUP));
    o->WriteTag(WireFormatLite::MakeTag(2, WireFormatLite::WIRETYPE_VARINT));
    o->WriteVarint64(40);
    o->WriteTag(WireFormatLite::MakeTag(1, WireFormatLite::WIRETYPE_VARINT));
    o->WriteVarint64(2);
  });
  ExpectSameAsProtobuf(reordered, "reordered, split, unknown fields");
  // Radiance unpacked (one fixed32 per float) inside an otherwise normal response.
  const std::string unpacked = write([&](CodedOutputStream *o) {
    std::string inner = write([&](CodedOutputStream *i) {
      i->WriteTag(WireFormatLite::MakeTag(1, WireFormatLite::WIRETYPE_VARINT));
      i->WriteVarint32(20);
      for (float f : r.result().radiance()) {
        i->WriteTag(WireFormatLite::MakeTag(2, WireFormatLite::WIRETYPE_FIXED32));
        uint32_t bits;
        std::memcpy(&bits, &f, 4);
        i->WriteLittleEndian32(bits);
      }
    });
    o->WriteTag(WireFormatLite::MakeTag(3, WireFormatLite::WIRETYPE_LENGTH_DELIMITED));
    o->WriteVarint32(uint32_t(inner.size()));
    o->WriteString(inner);
  });
  ExpectSameAsProtobuf(unpacked, "unpacked radiance");
  ExpectSameAsProtobuf(response.substr(0, 0), "empty message");
}

TEST(WireChunkResult, BadBytesAreRefusedExactlyWhenProtobufRefusesThem) {
  const std::string good = Result(7, 700, 50, 9).SerializeAsString();
  // Every truncation.
  for (size_t n = 0; n < good.size(); ++n)
    ExpectSameAsProtobuf(good.substr(0, n), "truncated to " + std::to_string(n) + " bytes");
  // Random corruptions: 1 to 4 bytes replaced, in the envelope (first 40 bytes) and the stats
  // (last 40) where they change the structure, and anywhere.
  std::mt19937 rng(12);
  for (int trial = 0; trial < 3000; ++trial) {
    std::string bad = good;
    const int edits = 1 + trial % 4;
    for (int e = 0; e < edits; ++e) {
      const size_t span = trial % 3 == 2 ? bad.size() : std::min<size_t>(40, bad.size());
      size_t at = rng() % span;
      if (trial % 3 == 1) at = bad.size() - 1 - at;
      bad[at] = char(rng() & 0xff);
    }
    ExpectSameAsProtobuf(bad, "corruption " + std::to_string(trial));
  }
}

// Where protobuf's parser is stricter than CodedInputStream (found by tests/fuzz/fuzz_request):
// tags and lengths of at most 5 varint bytes, field number 0, group nesting.
TEST(WireChunkResult, OverlongVarintsAndDeepGroupsAsProtobuf) {
  const std::string cases[] = {
      std::string("\xc0\x3e\x01", 3),                          // unknown field 1000, 2-byte tag
      std::string("\xc0\xbe\x80\x80\x00\x01", 6),              // the same tag padded to 5 bytes
      std::string("\xc0\xbe\x80\x80\x80\x00\x01", 7),          // ... to 6 bytes
      std::string("\xf8\xff\xff\xff\x1f\x01", 6),              // 5-byte tag, bit 32 set (cut off)
      std::string("\x80\x80\x80\x80\x10\x01", 6),              // 5-byte tag whose low 32 bits are 0
      std::string("\x02\x00", 2),                              // field 0
      std::string("\x1a\x80\x80\x80\x80\x00", 6),              // result length 0 in 5 bytes
      std::string("\x1a\x80\x80\x80\x80\x80\x00", 7),          // ... in 6 bytes
      std::string("\x1a\x80\x80\x80\x80\x10", 6),              // length 2^32
      std::string("\x1a\x06\x12\x80\x80\x80\x80\x00", 8),      // radiance length in 5 bytes
      std::string("\x1a\x07\x12\x80\x80\x80\x80\x80\x00", 9),  // ... in 6 bytes
      std::string("\x4a\x80\x80\x80\x80\x80\x00", 7),          // unknown field, 6-byte length
      std::string("\x1a\x03\x1a\x01\x0c", 5),                  // stats ended by an end-group tag
      std::string("\x0c", 1),                                  // end-group without a start
  };
  for (const std::string &c : cases)
    ExpectSameAsProtobuf(c, "case of " + std::to_string(c.size()) + " bytes");
  // Unknown groups nested 100 deep parse at the top level, 101 do not; one level less inside
  // `result`.
  for (int depth : {99, 100, 101}) {
    std::string top, inner;
    for (int i = 0; i < depth; ++i) top += "\x4b";  // field 9, start group
    for (int i = 0; i < depth; ++i) top += "\x4c";  // field 9, end group
    ExpectSameAsProtobuf(top, "top-level groups " + std::to_string(depth));
    // result = field 3, length as a 2-byte varint (the groups take 198 to 202 bytes).
    inner = std::string("\x1a") + char(0x80 | (top.size() & 0x7f)) + char(top.size() >> 7) + top;
    ExpectSameAsProtobuf(inner, "groups in result " + std::to_string(depth));
  }
}

TEST(WireChunkResult, MoreRadianceThanRoomIsRefusedWithoutWritingPastIt) {
  const std::string bytes = Result(1, 10, 10, 3).SerializeAsString();  // 30 floats
  std::vector<float> out(29 + 4, -7.0f);
  DecodedChunkResult got;
  grpc::ByteBuffer buffer = Buffer(bytes);
  const std::string problem = DecodeChunkResult(&buffer, out.data(), 29, &got);
  EXPECT_NE(problem.find("more floats than the chunk's queries x 3"), std::string::npos) << problem;
  for (int i = 29; i < 33; ++i) EXPECT_EQ(out[size_t(i)], -7.0f);
}

TEST(SlicePool, ReusesBuffersAndKeepsAtMostItsLimit) {
  auto pool = SlicePool::Create(2);
  uint8_t *first = nullptr, *again = nullptr;
  grpc_slice a = pool->Take(1000, &first);
  EXPECT_EQ(GRPC_SLICE_LENGTH(a), 1000u);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(first) % 128, 0u);
  grpc_slice_unref(a);  // back to the pool
  EXPECT_EQ(pool->idle_buffers(), 1u);
  grpc_slice b = pool->Take(900, &again);
  EXPECT_EQ(again, first) << "an idle buffer that fits is reused";
  EXPECT_EQ(pool->idle_buffers(), 0u);
  // Three outstanding, all returned: the pool keeps the two largest.
  uint8_t *p = nullptr;
  grpc_slice c = pool->Take(5000, &p), d = pool->Take(100, &p);
  grpc_slice_unref(b);
  grpc_slice_unref(c);
  grpc_slice_unref(d);
  EXPECT_EQ(pool->idle_buffers(), 2u);
  EXPECT_GE(pool->idle_bytes(), 5000u + 1000u);
  EXPECT_LT(pool->idle_bytes(), 5000u + 1000u + 2 * 128u);
}

TEST(SlicePool, SlicesOutliveThePoolHandle) {
  uint8_t *p = nullptr;
  grpc_slice s;
  {
    auto pool = SlicePool::Create(1);
    s = pool->Take(64, &p);
  }
  std::memset(p, 1, 64);  // still valid: the slice holds the pool
  grpc_slice_unref(s);
}

}  // namespace
}  // namespace glint::wire
