// A batch of queries as raw float arrays (the SoA layout of glint.proto QueryBatch): pointers into
// a QueryBatch's repeated fields, or into a client's shared-memory region (server/shm_io.cpp),
// which the device engine and the validation then read in place. A null array is absent.
#pragma once

#include <cstdint>

#include "glint/v1/glint.pb.h"

namespace glint {

struct QueryView {
  uint32_t count = 0;
  // Floats per query: uv 2, footprint 4, the others 3.
  const float *uv = nullptr;
  const float *footprint = nullptr;
  const float *wo = nullptr;
  const float *wi = nullptr;
  const float *position = nullptr;
  const float *normal = nullptr;
  const float *tangent = nullptr;

  // The arrays of `q` (an empty repeated field is absent). Valid while `q` is unchanged.
  static QueryView Of(const glint::v1::QueryBatch &q) {
    auto at = [](const google::protobuf::RepeatedField<float> &f) {
      return f.empty() ? nullptr : f.data();
    };
    QueryView v;
    v.count = q.count();
    v.uv = at(q.uv());
    v.footprint = at(q.footprint());
    v.wo = at(q.wo());
    v.wi = at(q.wi());
    v.position = at(q.position());
    v.normal = at(q.normal());
    v.tangent = at(q.tangent());
    return v;
  }

  // Queries [begin, begin + size) of this view: the same arrays, offset.
  QueryView Slice(uint32_t begin, uint32_t size) const {
    auto at = [begin](const float *a, uint32_t per) {
      return a ? a + uint64_t(begin) * per : nullptr;
    };
    QueryView v;
    v.count = size;
    v.uv = at(uv, 2);
    v.footprint = at(footprint, 4);
    v.wo = at(wo, 3);
    v.wi = at(wi, 3);
    v.position = at(position, 3);
    v.normal = at(normal, 3);
    v.tangent = at(tangent, 3);
    return v;
  }
};

}  // namespace glint
