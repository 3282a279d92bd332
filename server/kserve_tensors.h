// Open Inference Protocol tensors <-> glint.v1 query batches: the one translation between
// ModelInfer's FP32 tensors (typed fp32_contents or little-endian raw_input_contents) and the
// structure-of-arrays QueryBatch that glint.v1's validation, scheduler and kernels take, so
// that ModelInfer is Evaluate with another envelope. Every refusal names the input (or
// parameter) and what was expected; the values inside a well-formed tensor are checked later
// by glint.v1's ValidateQueries, whose messages name the field and first bad row
// ("queries.wo[17]: (nan, 0, 1) is not finite": row 17 of input wo).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "glint/v1/glint.pb.h"
#include "inference/grpc_service.pb.h"
#include "server/status.h"

namespace glint {

// An input tensor a model takes: FP32 [-1, width].
struct KServeInput {
  const char *name;
  int width;
  bool required;
};

// The inputs of a model with or without lights: wo (required); wi (BRDF probes: required
// without lights, absent with lights); uv, footprint, position, normal, tangent (optional).
std::vector<KServeInput> KServeInputs(bool has_lights);

// Fills `queries` from the request's input tensors: one query per row, as many rows as wo.
// wo itself is checked by InferQueryCount (the same refusal, word for word, as at admission).
Status DecodeInferInputs(const inference::ModelInferRequest &request, bool has_lights,
                         glint::v1::QueryBatch *queries);

// The query count of the request, read before the tensors are decoded, for admission by cost:
// the rows N of its 'wo' input, which must be FP32 shaped [N, 3] with 1 <= N < 2^32 and carry
// exactly 3 N floats (raw or typed). Otherwise INVALID_ARGUMENT naming 'wo', its shape and what
// was expected, before admission: such a request used to be admitted as 0 queries and refused
// only by the decoder on a worker, or answered "server busy, retry" when the queue was full
// (a retry that could never succeed). A request that runs has exactly *rows queries.
Status InferQueryCount(const inference::ModelInferRequest &request, uint64_t *rows);

// Applies the request parameters seed, precision, area_method and area_samples to
// `settings`; ignores the ones Triton's clients set for their own features and refuses others.
Status ApplyInferParameters(const inference::ModelInferRequest &request,
                            glint::v1::EvaluateRequest *settings);

// Checks the requested outputs: none (= all) or "radiance" once.
Status CheckRequestedOutputs(const inference::ModelInferRequest &request);

// Input and requested-output tensors carry no parameters: glintd reads none, and ignoring them
// answered a client that asked for its output in a shared-memory region (tritonclient's
// InferRequestedOutput.set_shared_memory) with raw_output_contents and an untouched region.
// INVALID_ARGUMENT naming the tensor and the parameter (the shared-memory ones as such).
Status CheckTensorParameters(const inference::ModelInferRequest &request);

// glint.v1's messages in the protocol's words: "queries.wo[17]: ..." becomes
// "input 'wo' row 17: ..." and "queries.uv: ..." becomes "input 'uv': ..."; others stay as
// they are.
std::string InferMessage(const std::string &glint_message);

// Appends output "radiance" FP32 [count, 3] with its data as raw_output_contents.
void EncodeRadiance(const float *rgb, uint32_t count, inference::ModelInferResponse *response);

}  // namespace glint
