// The Chermain model through the engine (as tests/service/engine_test.cpp does for the other
// models): validation messages, the OpenCL kernel against the host path (the same
// models/chermain/chermain_eval.h compiled as C++), bit-identical results under chunking, and
// the dictionary reaching the device through the model-table buffer.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <string>

#include "client/lib/glint_client.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/validation.h"
#include "tests/support/device_engine_fixture.h"

namespace glint {
namespace {

using glint::v1::EvaluateRequest;

class ChermainEngineTest : public test::DeviceEngineTest {
 protected:
  static void SetUpTestSuite() { CreateEngine(2, /*from_source=*/true); }

  std::vector<float> Device(const EvalPlan &plan, const v1::QueryBatch &q, int lane = 0) {
    std::vector<float> out(3 * q.count(), -1.0f);
    Status s = engine_->Evaluate(lane, plan, q, out.data());
    EXPECT_TRUE(s.ok()) << s.message();
    return out;
  }
  static std::vector<float> Host(const EvalPlan &plan, const v1::QueryBatch &q) {
    std::vector<float> out(3 * q.count(), -1.0f);
    HostEvaluate(plan, q, out.data());
    return out;
  }
};

EvaluateRequest Settings(bool lights, bool fp64, float log_density = 20.0f, bool polygon = false) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::CHERMAIN);
  m->set_ndf(v1::BECKMANN);
  m->set_alpha_x(0.4f);
  m->set_alpha_y(0.25f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  m->mutable_chermain()->set_log_density(log_density);
  m->mutable_chermain()->set_density_randomisation(2.0f);
  for (float c : {1.0f, 0.8f, 0.2f, 0.3f, 0.6f, 1.0f}) m->mutable_chermain()->add_colors(c);
  if (lights) {
    auto *d = r.add_lights()->mutable_directional();
    for (float v : {0.3f, 0.1f, 0.9486833f}) d->add_direction(v);
    for (float v : {1.0f, 2.0f, 3.0f}) d->add_irradiance(v);
    auto *p = r.add_lights()->mutable_point();
    for (float v : {-1.0f, 0.5f, 3.0f}) p->add_position(v);
    for (float v : {5.0f, 5.0f, 4.0f}) p->add_intensity(v);
  }
  if (polygon) {  // a quad above the plane, counter-clockwise seen from below
    auto *g = r.add_lights()->mutable_polygon();
    for (float v : {-1.5f, -0.5f, 2.0f, -1.5f, 0.5f, 2.0f, -0.5f, 0.5f, 2.0f, -0.5f, -0.5f, 2.0f})
      g->add_vertices(v);
    for (float v : {2.0f, 2.0f, 1.5f}) g->add_radiance(v);
  }
  r.set_precision(fp64 ? v1::FP64 : v1::FP32);
  r.set_seed(0xabcdef12345ull);
  return r;
}

// Queries on a pixel grid of a plane seen at an angle, footprints of about one level-0 cell
// (2^-15 uv) up to ~200 cells, so both the glinty and the smoothed regime are covered.
v1::QueryBatch Queries(uint32_t count, bool probe, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  v1::QueryBatch q;
  q.set_count(count);
  for (uint32_t i = 0; i < count; ++i) {
    q.add_uv(4.0f * u(rng));
    q.add_uv(4.0f * u(rng));
    const float scale = std::exp2(-15.0f + 8.0f * u(rng));
    for (float f : {1.0f, 0.3f * u(rng), 0.2f * u(rng), 0.5f + u(rng)}) q.add_footprint(scale * f);
    const float t = 1.4f * u(rng), p = 6.2832f * u(rng);
    for (float c : {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)}) q.add_wo(c);
    if (probe) {
      const float ti = 1.4f * u(rng), pi = 6.2832f * u(rng);
      for (float c : {std::sin(ti) * std::cos(pi), std::sin(ti) * std::sin(pi), std::cos(ti)})
        q.add_wi(c);
    }
  }
  return q;
}

TEST_F(ChermainEngineTest, ValidationNamesTheField) {
  EvaluateRequest r = Settings(true, false);
  r.mutable_material()->set_ndf(v1::GGX);
  Status s = ValidateSettings(r, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("material.ndf: GGX"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("expected BECKMANN"), std::string::npos) << s.message();

  r = Settings(true, false);
  r.mutable_material()->mutable_chermain()->set_max_anisotropy(40.0f);
  s = ValidateSettings(r, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("material.chermain.max_anisotropy: 40"), std::string::npos)
      << s.message();

  r = Settings(true, false);
  r.mutable_material()->mutable_chermain()->set_dictionary_size(100);
  s = ValidateSettings(r, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("material.chermain.dictionary_size: 100"), std::string::npos)
      << s.message();

  r = Settings(true, false);
  r.mutable_material()->mutable_chermain()->set_log_density(-1.0f);
  s = ValidateSettings(r, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("material.chermain.log_density: -1"), std::string::npos)
      << s.message();

  r = Settings(true, false);
  r.mutable_material()->mutable_chermain()->set_colors(4, 1.5f);
  s = ValidateSettings(r, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("material.chermain.colors[4]: 1.5"), std::string::npos) << s.message();
  r.mutable_material()->mutable_chermain()->add_colors(0.5f);
  s = ValidateSettings(r, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("material.chermain.colors: 7 values"), std::string::npos)
      << s.message();

  // Polygon lights are accepted (models/chermain/chermain_polygons.h).
  r = Settings(false, false);
  auto *poly = r.add_lights()->mutable_polygon();
  for (float v : {-1.0f, -1.0f, 2.0f, 1.0f, -1.0f, 2.0f, 0.0f, 1.0f, 2.0f}) poly->add_vertices(v);
  for (float v : {1.0f, 1.0f, 1.0f}) poly->add_radiance(v);
  s = ValidateSettings(r, {});
  EXPECT_TRUE(s.ok()) << s.message();

  r = Settings(true, false);
  v1::QueryBatch q = Queries(4, false, 1);
  q.clear_footprint();
  s = ValidateSettings(r, {});
  ASSERT_TRUE(s.ok()) << s.message();
  s = ValidateQueriesForModel(q, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("queries.footprint: empty"), std::string::npos) << s.message();
}

// Device and host run the same code; PoCL's libm and contraction can differ from the host's by
// ulps, and a glint is a discrete event (an ulp moves a cell centre across the footprint's
// edge, or a rounded distribution level), so most queries agree to float noise and the rest
// only in the mean (as for the binomial model in tests/service/engine_test.cpp).
TEST_F(ChermainEngineTest, DeviceMatchesHostPath) {
  for (int kind : {0, 1, 2})  // lights, probes, lights with a polygon
    for (bool fp64 : {false, true}) {
      const bool probe = kind == 1;
      EvaluateRequest settings = Settings(!probe, fp64, 20.0f, kind == 2);
      v1::QueryBatch q = Queries(3000, probe, 23);
      ASSERT_TRUE(ValidateSettings(settings, {}).ok());
      ASSERT_TRUE(ValidateQueriesForModel(q, settings).ok());
      EvalPlan plan = MakeEvalPlan(settings, q);
      auto dev = Device(plan, q);
      auto host = Host(plan, q);
      int agree = 0, lit = 0;
      double sum_dev = 0, sum_host = 0;
      for (size_t i = 0; i < dev.size(); ++i) {
        ASSERT_TRUE(std::isfinite(dev[i]) && dev[i] >= 0.0f) << plan.spec.Describe();
        agree += std::fabs(dev[i] - host[i]) <= (fp64 ? 1e-6 : 1e-3) * std::fabs(host[i]) + 1e-7;
        lit += dev[i] > 0.0f;
        sum_dev += dev[i];
        sum_host += host[i];
      }
      EXPECT_GT(agree, int(dev.size()) * 99 / 100) << plan.spec.Describe();
      EXPECT_NEAR(sum_dev / sum_host, 1.0, 0.02) << plan.spec.Describe();
      EXPECT_GT(lit, int(dev.size()) / 20) << plan.spec.Describe();
    }
}

// Bit-identical however the batch is split (random numbers depend on the seed and the cells,
// never on the query's index), and a new seed is a new pattern.
TEST_F(ChermainEngineTest, BitIdenticalUnderChunkingAndFollowsTheSeed) {
  EvaluateRequest settings = Settings(true, false, 20.0f, true);  // with a polygon
  v1::QueryBatch q = Queries(1000, false, 31);
  EvalPlan plan = MakeEvalPlan(settings, q);
  auto whole = Device(plan, q);
  for (uint32_t chunk : {1u, 7u, 333u}) {
    std::vector<float> pieces;
    for (uint32_t first = 0; first < q.count(); first += chunk) {
      v1::QueryBatch part =
          client::SliceQueries(q, first, first + std::min(chunk, q.count() - first));
      auto out = Device(MakeEvalPlan(settings, part), part, int(first / chunk) % 2);
      pieces.insert(pieces.end(), out.begin(), out.end());
    }
    ASSERT_EQ(pieces.size(), whole.size());
    EXPECT_EQ(0, std::memcmp(pieces.data(), whole.data(), whole.size() * sizeof(float)))
        << "chunks of " << chunk;
  }
  settings.set_seed(6);
  auto reseeded = Device(MakeEvalPlan(settings, q), q);
  int differ = 0, lit = 0;
  for (size_t i = 0; i < whole.size(); ++i) {
    differ += whole[i] != reseeded[i];
    lit += whole[i] > 0.0f || reseeded[i] > 0.0f;
  }
  EXPECT_GT(lit, 20);
  EXPECT_GT(differ, lit / 2);
}

// The device kernel at the extremes (fp32 and fp64): footprints 0, 1e-30, 1e30, NaN and a line;
// uv 0 and 1e7; grazing and normal directions; ln(rho) 0 and 60; alpha 0.01 and 1; zeta 0 and 10;
// gamma 1 and 16. Every output finite and non-negative.
TEST_F(ChermainEngineTest, FiniteAndNonNegativeAtTheExtremesOnTheDevice) {
  v1::QueryBatch q;
  const float fps[][4] = {{0, 0, 0, 0},         {1e-30f, 0, 0, 1e-30f},
                          {1e30f, 0, 0, 1e30f}, {NAN, 0, 0, 1e-4f},
                          {1e-3f, 0, 0, 0},     {3e-5f, 1e-5f, -2e-6f, 4e-6f}};
  const float uvs[] = {0.0f, -3.7f, 1e7f};
  const float dirs[][3] = {{0, 0, 1}, {1, 0, 0}, {0.9999999f, 0, 0.0004472f}, {0.6f, 0, 0.8f}};
  uint32_t n = 0;
  for (const auto &fp : fps)
    for (float uv : uvs)
      for (const auto &wo : dirs)
        for (const auto &wi : dirs) {
          q.add_uv(uv);
          q.add_uv(-uv);
          for (float f : fp) q.add_footprint(f);
          for (float c : wo) q.add_wo(c);
          for (float c : wi) q.add_wi(c);
          ++n;
        }
  q.set_count(n);
  int lit = 0;
  for (bool fp64 : {false, true})
    for (float ld : {0.0f, 60.0f})
      for (float alpha : {0.01f, 1.0f})
        for (float zeta : {0.0f, 10.0f})
          for (float gamma : {1.0f, 16.0f}) {
            EvaluateRequest settings = Settings(false, fp64, ld);
            auto *m = settings.mutable_material();
            m->set_alpha_x(alpha);
            m->set_alpha_y(alpha);
            m->mutable_chermain()->set_density_randomisation(zeta);
            m->mutable_chermain()->set_max_anisotropy(gamma);
            ASSERT_TRUE(ValidateSettings(settings, {}).ok());
            EvalPlan plan = MakeEvalPlan(settings, q);
            auto dev = Device(plan, q);
            for (size_t i = 0; i < dev.size(); ++i) {
              ASSERT_TRUE(std::isfinite(dev[i]) && dev[i] >= 0.0f)
                  << plan.spec.Describe() << " ld " << ld << " alpha " << alpha << " query "
                  << i / 3;
              lit += dev[i] > 0.0f;
            }
          }
  EXPECT_GT(lit, 100);
}

// The dictionary sizes pick different marginals (a smaller one is a prefix): the pattern
// changes with the size, the device still matches the host.
TEST_F(ChermainEngineTest, DictionarySizeChangesThePattern) {
  v1::QueryBatch q = Queries(1000, true, 5);
  std::vector<std::vector<float>> outs;
  for (uint32_t n : {16u, 64u, 192u, 512u}) {
    EvaluateRequest settings = Settings(false, false);
    settings.mutable_material()->mutable_chermain()->set_dictionary_size(n);
    ASSERT_TRUE(ValidateSettings(settings, {}).ok());
    EvalPlan plan = MakeEvalPlan(settings, q);
    outs.push_back(Device(plan, q));
    auto host = Host(plan, q);
    int agree = 0;
    for (size_t i = 0; i < host.size(); ++i)
      agree += std::fabs(outs.back()[i] - host[i]) <= 1e-3 * std::fabs(host[i]) + 1e-7;
    EXPECT_GT(agree, int(host.size()) * 99 / 100) << n;
  }
  EXPECT_NE(0, std::memcmp(outs[0].data(), outs[2].data(), outs[0].size() * sizeof(float)));
  EXPECT_NE(0, std::memcmp(outs[2].data(), outs[3].data(), outs[2].size() * sizeof(float)));
}

}  // namespace
}  // namespace glint
