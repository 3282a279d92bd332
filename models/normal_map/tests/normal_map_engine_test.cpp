// The NORMAL_MAP model through the engine: validation (names the field; NOT_FOUND names the
// digest), the BRDF of Eq. 1 against its closed form on a flat map, the OpenCL kernel against
// the host path (the same normal_map_eval.h compiled as C++), bit-identical results under
// chunking, and the per-request table reaching the device (re-uploaded after eviction).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/normal_map_store.h"
#include "server/validation.h"
#include "tests/support/device_engine_fixture.h"

namespace glint {
namespace {

using glint::v1::EvaluateRequest;
constexpr double kPi = 3.14159265358979323846;

DecodedNormalMap Map(uint32_t w, uint32_t h, double amplitude) {
  DecodedNormalMap m;
  m.width = w;
  m.height = h;
  for (uint32_t j = 0; j < h; ++j)
    for (uint32_t i = 0; i < w; ++i) {
      const double sx = amplitude * std::sin(2 * kPi * (i + 0.3 * j) / w);
      const double sy = amplitude * std::cos(2 * kPi * (2.0 * j + 0.5 * i) / h);
      const double len = std::sqrt(sx * sx + sy * sy + 1.0);
      for (double c : {sx / len, sy / len, 1.0 / len}) m.xyz.push_back(float(c));
    }
  return m;
}

std::string Put(const DecodedNormalMap &m) {
  v1::NormalMapInfo info;
  EXPECT_TRUE(NormalMaps().Insert("test", m, &info).ok());
  return info.digest();
}

class NormalMapEngineTest : public test::DeviceEngineTest {
 protected:
  static void SetUpTestSuite() { CreateEngine(2); }

  static Status Plan(const EvaluateRequest &r, EvalPlan *plan) {
    Status s = ValidateSettings(r, {});
    if (s.ok()) s = ValidateQueries(r.queries(), r.lights_size() > 0, {});
    if (s.ok()) s = ValidateQueriesForModel(r.queries(), r);
    if (!s.ok()) return s;
    *plan = MakeEvalPlan(r, r.queries());
    return ResolveRequestTable(r.material(), plan);
  }
  std::vector<float> Device(const EvalPlan &plan, const v1::QueryBatch &q, int worker = 0) {
    std::vector<float> out(3 * q.count(), -1.0f);
    Status s = engine_->Evaluate(worker, plan, q, out.data());
    EXPECT_TRUE(s.ok()) << s.message();
    return out;
  }
  static std::vector<float> Host(const EvalPlan &plan, const v1::QueryBatch &q) {
    std::vector<float> out(3 * q.count(), -1.0f);
    HostEvaluate(plan, q, out.data());
    return out;
  }
};

EvaluateRequest Request(const std::string &digest, float sigma_r, int n, bool probe) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::NORMAL_MAP);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  m->mutable_normal_map()->set_digest(digest);
  m->mutable_normal_map()->set_intrinsic_roughness(sigma_r);
  auto *q = r.mutable_queries();
  q->set_count(uint32_t(n));
  for (int i = 0; i < n; ++i) {
    const double a = 0.37 * i, b = 0.11 * i;
    const double wo[3] = {0.3 * std::sin(a), 0.3 * std::cos(a), 0.0};
    const double wi[3] = {0.25 * std::cos(b), -0.2 * std::sin(b), 0.0};
    auto add_unit = [](const double v[3], google::protobuf::RepeatedField<float> *f) {
      const double z = std::sqrt(1 - v[0] * v[0] - v[1] * v[1]);
      for (double c : {v[0], v[1], z}) f->Add(float(c));
    };
    add_unit(wo, q->mutable_wo());
    if (probe) add_unit(wi, q->mutable_wi());
    q->add_uv(float(0.013 * i));
    q->add_uv(float(0.029 * i));
    for (float f : {0.004f * float(i % 5), 0.001f, -0.002f, 0.003f * float(i % 3) + 0.001f})
      q->add_footprint(f);
  }
  if (!probe) {
    auto *d = r.add_lights()->mutable_directional();
    for (float c : {0.1f, -0.2f, 0.97f}) d->add_direction(c / std::sqrt(0.01f + 0.04f + 0.9409f));
    for (float c : {1.0f, 2.0f, 3.0f}) d->add_irradiance(c);
    auto *p = r.add_lights()->mutable_point();
    for (float c : {-0.5f, 0.3f, 2.0f}) p->add_position(c);
    for (float c : {4.0f, 4.0f, 4.0f}) p->add_intensity(c);
  }
  return r;
}

TEST_F(NormalMapEngineTest, ValidationNamesTheFieldAndNotFoundNamesTheDigest) {
  const std::string digest = Put(Map(8, 8, 0.2));
  EvalPlan plan;
  EvaluateRequest r = Request(digest, 0.01f, 2, true);
  ASSERT_TRUE(Plan(r, &plan).ok());
  r.mutable_material()->clear_normal_map();
  EXPECT_NE(Plan(r, &plan).message().find("material.normal_map: unset"), std::string::npos);
  r = Request("sha256:1234", 0.01f, 2, true);
  EXPECT_NE(Plan(r, &plan).message().find("material.normal_map.digest"), std::string::npos);
  const std::string missing = "sha256:" + std::string(64, 'a');
  Status s = Plan(Request(missing, 0.01f, 2, true), &plan);
  EXPECT_EQ(s.code(), Status::Code::kNotFound);
  EXPECT_NE(s.message().find(missing), std::string::npos) << s.message();
  r = Request(digest, 0.6f, 2, true);
  EXPECT_NE(Plan(r, &plan).message().find("intrinsic_roughness"), std::string::npos);
  r = Request(digest, 0.01f, 2, true);
  r.mutable_material()->mutable_normal_map()->set_subdivision(2);
  EXPECT_NE(Plan(r, &plan).message().find("subdivision"), std::string::npos);
  r = Request(digest, 0.01f, 2, false);
  auto *poly = r.add_lights()->mutable_polygon();
  for (float v : {-1.0f, -1.0f, 2.0f, 1.0f, -1.0f, 2.0f, 0.0f, 1.0f, 2.0f}) poly->add_vertices(v);
  for (float c : {1.0f, 1.0f, 1.0f}) poly->add_radiance(c);
  // Polygon lights are accepted (normal_map_polygons.h; tested in normal_map_polygon_test).
  EXPECT_TRUE(Plan(r, &plan).ok()) << Plan(r, &plan).message();
  EXPECT_EQ(plan.n_polygon, 1u);
  r = Request(digest, 0.01f, 2, true);
  r.mutable_queries()->clear_footprint();
  EXPECT_NE(Plan(r, &plan).message().find("queries.footprint"), std::string::npos);
}

// A flat map: D(h) = N((h.x, h.y); 0, sigma_r^2 I) (the P-NDF is exactly G_r), so a probe returns
// F(o.h) G D(h) / (4 cos_o) with the V-cavity G, written out here independently.
TEST_F(NormalMapEngineTest, FlatMapProbeIsEquationOneWithTheGaussianNdf) {
  DecodedNormalMap flat;
  flat.width = flat.height = 4;
  for (int k = 0; k < 16; ++k)
    for (float c : {0.0f, 0.0f, 1.0f}) flat.xyz.push_back(c);
  const float sigma_r = 0.2f;
  EvaluateRequest r = Request(Put(flat), sigma_r, 64, true);
  r.set_precision(v1::FP64);
  EvalPlan plan;
  ASSERT_TRUE(Plan(r, &plan).ok());
  const std::vector<float> host = Host(plan, r.queries());
  const auto &q = r.queries();
  for (int i = 0; i < 64; ++i) {
    double o[3], in[3], h[3];
    for (int c = 0; c < 3; ++c) {
      o[c] = q.wo(3 * i + c);
      in[c] = q.wi(3 * i + c);
      h[c] = o[c] + in[c];
    }
    const double hl = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    for (double &c : h) c /= hl;
    const double oh = o[0] * h[0] + o[1] * h[1] + o[2] * h[2];
    const double D = std::exp(-(h[0] * h[0] + h[1] * h[1]) / (2 * sigma_r * sigma_r)) /
                     (2 * kPi * sigma_r * sigma_r);
    const double G = std::min({1.0, 2 * h[2] * o[2] / oh, 2 * h[2] * in[2] / oh});
    const double f0[3] = {0.9, 0.6, 0.3};
    for (int c = 0; c < 3; ++c) {
      const double F = f0[c] + (1 - f0[c]) * std::pow(1 - oh, 5);
      const double expect = F * G * D / (4 * o[2]);
      EXPECT_NEAR(host[3 * i + c], expect, 1e-5 * expect + 1e-6) << "query " << i;
    }
  }
}

// The device kernel runs the same header as the host; they differ only by erf / exp
// implementations and rounding (fp32: ~1e-6 relative per operation, summed over triangles whose
// count is at most a few hundred here): 1e-4 of the largest value.
TEST_F(NormalMapEngineTest, DeviceMatchesHostAndIsChunkingInvariant) {
  const std::string digest = Put(Map(32, 32, 0.3));
  for (bool probe : {true, false}) {
    EvaluateRequest r = Request(digest, 0.02f, 96, probe);
    EvalPlan plan;
    ASSERT_TRUE(Plan(r, &plan).ok());
    const std::vector<float> device = Device(plan, r.queries()), host = Host(plan, r.queries());
    const float peak = *std::max_element(host.begin(), host.end());
    ASSERT_GT(peak, 0.0f);
    int nonzero = 0;
    for (size_t k = 0; k < host.size(); ++k) {
      EXPECT_NEAR(device[k], host[k], 1e-4f * peak) << k;
      nonzero += host[k] > 0.0f;
    }
    EXPECT_GT(nonzero, 20);
    // Two chunks on the other worker: bit-identical.
    v1::QueryBatch a, b;
    const auto &q = r.queries();
    for (auto [part, lo, hi] : {std::tuple{&a, 0, 40}, std::tuple{&b, 40, 96}}) {
      part->set_count(uint32_t(hi - lo));
      for (int i = lo; i < hi; ++i) {
        for (int c = 0; c < 3; ++c) part->add_wo(q.wo(3 * i + c));
        if (probe)
          for (int c = 0; c < 3; ++c) part->add_wi(q.wi(3 * i + c));
        for (int c = 0; c < 2; ++c) part->add_uv(q.uv(2 * i + c));
        for (int c = 0; c < 4; ++c) part->add_footprint(q.footprint(4 * i + c));
      }
    }
    std::vector<float> chunked = Device(plan, a, 1), tail = Device(plan, b, 1);
    chunked.insert(chunked.end(), tail.begin(), tail.end());
    EXPECT_EQ(chunked, device);
  }
}

// Delete and re-upload: the device's buffer for the old table is not reused after the table
// died, and the new one gives the same result.
TEST_F(NormalMapEngineTest, ReuploadedMapAfterDeleteGivesTheSameResult) {
  const DecodedNormalMap m = Map(16, 16, 0.25);
  const std::string digest = Put(m);
  EvaluateRequest r = Request(digest, 0.03f, 32, true);
  EvalPlan plan;
  ASSERT_TRUE(Plan(r, &plan).ok());
  const std::vector<float> first = Device(plan, r.queries());
  plan = EvalPlan();
  ASSERT_TRUE(NormalMaps().Delete(digest).ok());
  EXPECT_EQ(Plan(r, &plan).code(), Status::Code::kNotFound);
  EXPECT_EQ(Put(m), digest);
  ASSERT_TRUE(Plan(r, &plan).ok());
  EXPECT_EQ(Device(plan, r.queries()), first);
}

// Validation runs on the gRPC handler's thread: it must not build a subdivision-4 table (seconds
// for a large map), only check that it may. The table appears in the store when the request's
// worker resolves it (ResolveRequestTable), and the host path resolves it itself from a plan
// whose table was never resolved.
TEST_F(NormalMapEngineTest, ValidationLeavesTheSubdivisionFourBuildToTheWorker) {
  const std::string digest = Put(Map(24, 20, 0.2));
  EvaluateRequest r = Request(digest, 0.03f, 4, true);
  r.mutable_material()->mutable_normal_map()->set_subdivision(4);
  const uint64_t before = NormalMaps().bytes();
  ASSERT_TRUE(ValidateSettings(r, {}).ok());
  EXPECT_EQ(NormalMaps().bytes(), before) << "validation built the subdivision-4 table";
  // The host path without ResolveRequestTable: resolves (and builds) it from the plan's material.
  const EvalPlan unresolved = MakeEvalPlan(r, r.queries());
  ASSERT_FALSE(unresolved.request_table);
  const std::vector<float> host = Host(unresolved, r.queries());
  EXPECT_GT(NormalMaps().bytes(), before) << "the host path did not build the table";
  EvalPlan plan;
  ASSERT_TRUE(Plan(r, &plan).ok());
  ASSERT_TRUE(plan.request_table);
  EXPECT_EQ(
      plan.request_table->size(),
      size_t(8 + 96 * 80 * 2 + 4 * (48 * 40 + 24 * 20 + 12 * 10 + 6 * 5 + 3 * 3 + 2 * 2 + 1)));
  EXPECT_EQ(Host(plan, r.queries()), host);
  EXPECT_GT(*std::max_element(host.begin(), host.end()), 0.0f) << "nothing reflected";
}

}  // namespace
}  // namespace glint
