// One EvaluateStream chunk written straight from the caller's query arrays (issue 12): the
// protobuf wire form of EvaluateChunk{chunk_index, request = settings + queries [begin, end)}
// in one gRPC slice, so the chunk's queries are copied once. Building the chunk message
// (SliceQueries) and then serialising it copied them twice and faulted in a fresh message per
// chunk. The bytes parse as exactly the EvaluateChunk that path builds (same fields, packed
// little-endian floats); the wire contract is unchanged.
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <memory>
#include <string>

#include "glint/v1/glint.grpc.pb.h"

namespace glint::client {

// `settings` is a serialised EvaluateRequest without queries ("" for a chunk that reuses the
// first chunk's settings). Requires begin <= end <= batch.count() and every array of `batch`
// empty or components x count long (GlintClient checks the shapes before streaming).
grpc::ByteBuffer EncodeChunk(uint64_t chunk_index, const std::string &settings,
                             const glint::v1::QueryBatch &batch, uint32_t begin, uint32_t end);

// The same bytes with no copy of the queries (issue 12, "zero-copy views of packed floats"): the
// buffer's slices reference the [begin, end) rows of `batch`'s arrays in place, between small
// slices holding the tags and lengths. `batch` must stay alive and unchanged until gRPC is done
// with the buffer: for a stream, until its Finish() has returned.
grpc::ByteBuffer EncodeChunkReferencing(uint64_t chunk_index, const std::string &settings,
                                        const glint::v1::QueryBatch &batch, uint32_t begin,
                                        uint32_t end);

// A synchronous EvaluateStream whose writes are pre-encoded chunks (EncodeChunk) and whose
// reads are raw results (decoded by glint::wire::DecodeChunkResult straight into the caller's
// array): the generated stub's stream with grpc::ByteBuffer both ways (the same method path and
// wire bytes).
using RawChunkStream = grpc::ClientReaderWriter<grpc::ByteBuffer, grpc::ByteBuffer>;
std::unique_ptr<RawChunkStream> OpenRawChunkStream(grpc::Channel *channel,
                                                   grpc::ClientContext *context);

}  // namespace glint::client
