// EncodeChunk and EncodeChunkReferencing (client/lib/chunk_encoding.h) write EvaluateStream
// chunks by hand from the caller's arrays (a copy, or slices viewing them in place). Their bytes
// must parse, with protobuf's own parser, into exactly the EvaluateChunk that protobuf's
// generated code builds from SliceQueries: for every combination of present arrays, first and
// later chunks, a chunk index that needs a multi-byte varint, and a slice at the end of the
// batch.
#include "client/lib/chunk_encoding.h"

#include <google/protobuf/util/message_differencer.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "client/lib/glint_client.h"

namespace glint::client {
namespace {

glint::v1::QueryBatch Batch(uint32_t n, unsigned arrays, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  glint::v1::QueryBatch q;
  q.set_count(n);
  auto fill = [&](google::protobuf::RepeatedField<float> *f, int per) {
    for (uint32_t i = 0; i < n * uint32_t(per); ++i) f->Add(u(rng));
  };
  if (arrays & 1) fill(q.mutable_uv(), 2);
  if (arrays & 2) fill(q.mutable_footprint(), 4);
  fill(q.mutable_wo(), 3);
  if (arrays & 4) fill(q.mutable_wi(), 3);
  if (arrays & 8) {
    fill(q.mutable_position(), 3);
    fill(q.mutable_normal(), 3);
    fill(q.mutable_tangent(), 3);
  }
  return q;
}

std::string Bytes(const grpc::ByteBuffer &buffer) {
  std::vector<grpc::Slice> slices;
  EXPECT_TRUE(buffer.Dump(&slices).ok());
  std::string out;
  for (const grpc::Slice &s : slices)
    out.append(reinterpret_cast<const char *>(s.begin()), s.size());
  return out;
}

TEST(ChunkEncoding, ParsesAsTheChunkProtobufBuilds) {
  glint::v1::EvaluateRequest settings;
  auto *m = settings.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(glint::v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  auto *d = settings.add_lights()->mutable_directional();
  for (float v : {0.0f, 0.6f, 0.8f}) d->add_direction(v);
  for (float v : {1.0f, 2.0f, 3.0f}) d->add_irradiance(v);
  settings.set_precision(glint::v1::FP64);
  settings.set_seed(0x123456789abcull);
  settings.set_area_method(glint::v1::MONTE_CARLO);
  settings.set_area_samples(300);
  const std::string settings_bytes = settings.SerializeAsString();
  const uint32_t n = 1000;
  for (unsigned arrays = 0; arrays < 16; ++arrays) {
    const glint::v1::QueryBatch batch = Batch(n, arrays, 7 + arrays);
    for (uint64_t index : {uint64_t{0}, uint64_t{1}, uint64_t{300}, uint64_t{1} << 40}) {
      for (auto [begin, end] :
           {std::pair{0u, n}, std::pair{0u, 1u}, std::pair{999u, 1000u}, std::pair{128u, 700u}}) {
        const bool first = index == 0;
        glint::v1::EvaluateChunk want;
        want.set_chunk_index(index);
        if (first) *want.mutable_request() = settings;
        *want.mutable_request()->mutable_queries() = SliceQueries(batch, begin, end);
        const std::string bytes =
            Bytes(EncodeChunk(index, first ? settings_bytes : std::string(), batch, begin, end));
        glint::v1::EvaluateChunk got;
        ASSERT_TRUE(got.ParseFromString(bytes)) << arrays << " " << index << " " << begin;
        EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(got, want))
            << "arrays " << arrays << " index " << index << " [" << begin << ", " << end
            << ")\n got: " << got.ShortDebugString().substr(0, 300)
            << "\nwant: " << want.ShortDebugString().substr(0, 300);
        // The same length as protobuf's own serialisation: no field written twice or left out.
        EXPECT_EQ(bytes.size(), want.ByteSizeLong());
        // The referencing form (slices viewing the batch's rows) writes the same bytes.
        EXPECT_EQ(Bytes(EncodeChunkReferencing(index, first ? settings_bytes : std::string(), batch,
                                               begin, end)),
                  bytes)
            << "arrays " << arrays << " index " << index << " [" << begin << ", " << end << ")";
      }
    }
  }
}

}  // namespace
}  // namespace glint::client
