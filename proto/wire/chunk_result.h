// The wire form of EvaluateChunkResult written and read without a protobuf message holding the
// radiance (issue 12, "avoid copies"). Server: the device writes a chunk's radiance straight
// into a pooled reply slice (SlicePool), and EncodeChunkResult wraps it in the message's other
// bytes: no response array to zero-fill, no serialisation copy, no fresh pages. Client:
// DecodeChunkResult copies the packed radiance once, from gRPC's receive slices into the
// caller's output array; parsing into an EvaluateChunkResult and copying out took two copies and
// a freshly allocated array per chunk. The bytes are those protobuf writes for the same message
// (same fields, field-number order, packed little-endian floats): the wire contract, the Python
// client and reflection are unaffected.
#pragma once

#include <grpcpp/support/byte_buffer.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "glint/v1/glint.pb.h"

namespace glint::wire {

// EvaluateChunkResult{chunk_index, first_query, result = {count, radiance, stats}} as a byte
// buffer whose radiance bytes are `radiance` (3 x count floats, referenced, not copied; the
// slice's owner keeps the memory alive until gRPC drops it).
grpc::ByteBuffer EncodeChunkResult(uint64_t chunk_index, uint64_t first_query, uint32_t count,
                                   grpc_slice radiance, const glint::v1::EvaluateStats &stats);

// The unary Evaluate's reply written the same way: EvaluateResponse{count, radiance, stats} as a
// byte buffer referencing `radiance` (the bytes protobuf writes for that message).
grpc::ByteBuffer EncodeEvaluateResponse(uint32_t count, grpc_slice radiance,
                                        const glint::v1::EvaluateStats &stats);

// A decoded EvaluateChunkResult: every field but the radiance, which went to the output array.
struct DecodedChunkResult {
  uint64_t chunk_index = 0;
  uint64_t first_query = 0;
  uint32_t count = 0;
  uint64_t radiance_floats = 0;  // floats found (and written, when they fitted)
  glint::v1::EvaluateStats stats;
};

// Parses `body` as an EvaluateChunkResult with the semantics of protobuf's parser (fields in any
// order, unknown fields skipped, a repeated `result` merged, radiance packed or not), writing the
// radiance to out[0 .. capacity_floats). Returns "" on success, else what is wrong: bytes that do
// not parse, or more radiance than `capacity_floats` (nothing is written past it). The caller
// checks indices and the float count (ChunkResultProblem). `body` is consumed.
std::string DecodeChunkResult(grpc::ByteBuffer *body, float *out, uint64_t capacity_floats,
                              DecodedChunkResult *result);

}  // namespace glint::wire
