// Random but reproducible query batches for engine and service tests.
#pragma once

#include <cmath>
#include <random>

#include "glint/v1/glint.pb.h"

namespace glint::test {

inline void AddUnit(google::protobuf::RepeatedField<float> *out, std::mt19937 &rng,
                    bool upper_only) {
  std::normal_distribution<double> g(0.0, 1.0);
  for (;;) {
    double x = g(rng), y = g(rng), z = g(rng);
    if (upper_only) z = std::fabs(z);
    double len = std::sqrt(x * x + y * y + z * z);
    if (len < 1e-3) continue;
    out->Add(float(x / len));
    out->Add(float(y / len));
    out->Add(float(z / len));
    return;
  }
}

// `count` queries; probes carry wi; framed ones carry a random world frame.
// Directions are mostly above the local horizon, some below (those must give 0).
inline glint::v1::QueryBatch RandomQueries(uint32_t count, bool probe, bool framed,
                                           uint32_t seed = 1) {
  std::mt19937 rng(seed);
  glint::v1::QueryBatch q;
  q.set_count(count);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  for (uint32_t i = 0; i < count; ++i) {
    q.add_uv(u(rng));
    q.add_uv(u(rng));
    for (int k = 0; k < 4; ++k) q.add_footprint(0.01f * u(rng));
    AddUnit(q.mutable_wo(), rng, i % 8 != 0);
    if (probe) AddUnit(q.mutable_wi(), rng, i % 8 != 1);
    if (framed) {
      for (int k = 0; k < 3; ++k) q.add_position(u(rng));
      AddUnit(q.mutable_normal(), rng, false);
      // A tangent not parallel to the normal: any unit vector then
      // Gram-Schmidt in double so it is exactly unit in float terms.
      const float *n = q.normal().data() + 3 * i;
      for (;;) {
        google::protobuf::RepeatedField<float> t;
        AddUnit(&t, rng, false);
        double d = double(t[0]) * n[0] + double(t[1]) * n[1] + double(t[2]) * n[2];
        double v[3] = {t[0] - d * n[0], t[1] - d * n[1], t[2] - d * n[2]};
        double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (len < 0.1) continue;
        for (double c : v) q.add_tangent(float(c / len));
        break;
      }
    }
  }
  return q;
}

// The GGX Schlick material of the service tests that need "some cheap material".
inline glint::v1::Material SmoothTestMaterial(float alpha_y) {
  glint::v1::Material m;
  m.set_model(glint::v1::SMOOTH);
  m.set_ndf(glint::v1::GGX);
  m.set_alpha_x(0.3f);
  m.set_alpha_y(alpha_y);
  for (float f : {0.9f, 0.6f, 0.3f}) m.mutable_schlick()->add_f0(f);
  return m;
}

// A request that holds one worker ~50 ms per query on the 2-core PoCL device: 4 two-sided quads
// by REFERENCE with 512 nodes per dimension (~3e6 BRDF evaluations per query).
inline glint::v1::EvaluateRequest FourQuadReferenceRequest(const glint::v1::Material &material,
                                                           uint32_t n) {
  glint::v1::EvaluateRequest r;
  *r.mutable_material() = material;
  for (int k = 0; k < 4; ++k) {
    auto *p = r.add_lights()->mutable_polygon();
    for (int v = 0; v < 4; ++v) {
      const double t = -2.0 * 3.14159265358979 * v / 4;
      for (double c : {0.5 * k + 2.0 * std::cos(t), 2.0 * std::sin(t), 3.0})
        p->add_vertices(float(c));
    }
    for (float v : {1.0f, 1.0f, 1.0f}) p->add_radiance(v);
    p->set_two_sided(true);
  }
  r.set_area_method(glint::v1::REFERENCE);
  r.set_area_samples(512);
  *r.mutable_queries() = RandomQueries(n, false, false, 5);
  return r;
}

}  // namespace glint::test
