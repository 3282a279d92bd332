// The settings the sliced and batched evaluation tests run every model with: the model's own
// example parameters, a sphere light, and optionally a two-sided quad by Monte Carlo (the one
// area method whose random numbers depend on the query, so slicing and batching must keep them).
#pragma once

#include "glint/v1/glint.pb.h"
#include "server/model_table.h"

namespace glint::test {

inline glint::v1::EvaluateRequest ModelTestSettings(glint::v1::Model model, bool polygon_mc) {
  namespace v1 = glint::v1;
  v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(model);
  m->set_ndf(model == v1::CHERMAIN ? v1::BECKMANN : v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.2f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  v1::QueryBatch unused;
  if (const glint::Model *spec = glint::FindModel(model); spec->example) spec->example(m, &unused);
  auto *p = r.add_lights()->mutable_point();
  for (float v : {0.5f, -1.0f, 2.0f}) p->add_position(v);
  for (float v : {4.0f, 4.0f, 4.0f}) p->add_intensity(v);
  p->set_radius(0.2f);
  if (polygon_mc) {
    auto *q = r.add_lights()->mutable_polygon();
    for (float v : {-1.0f, -1.0f, 2.0f, 1.0f, -1.0f, 2.0f, 1.0f, 1.0f, 2.0f, -1.0f, 1.0f, 2.0f})
      q->add_vertices(v);
    for (float v : {1.0f, 1.0f, 1.0f}) q->add_radiance(v);
    q->set_two_sided(true);
    r.set_area_method(v1::MONTE_CARLO);
    r.set_area_samples(16);
  }
  r.set_seed(12345);
  return r;
}

}  // namespace glint::test
