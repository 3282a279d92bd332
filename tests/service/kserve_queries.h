// KServe v2 requests of the service tests (docs/kserve.md).
#pragma once

#include <cstdint>
#include <utility>

#include "inference/grpc_service.pb.h"
#include "test_queries.h"

namespace glint::test {

// `queries` BRDF probes of the "probe" preset as FP32 tensors wo and wi (12 bytes per query in
// the reply).
inline inference::ModelInferRequest KServeProbeRequest(uint32_t queries, uint32_t seed) {
  const glint::v1::QueryBatch q = RandomQueries(queries, true, false, seed);
  inference::ModelInferRequest r;
  r.set_model_name("probe");
  for (auto [name, values] : {std::pair{"wo", &q.wo()}, std::pair{"wi", &q.wi()}}) {
    auto *in = r.add_inputs();
    in->set_name(name);
    in->set_datatype("FP32");
    in->add_shape(queries);
    in->add_shape(3);
    r.add_raw_input_contents()->assign(reinterpret_cast<const char *>(values->data()),
                                       size_t(values->size()) * sizeof(float));
  }
  return r;
}

}  // namespace glint::test
