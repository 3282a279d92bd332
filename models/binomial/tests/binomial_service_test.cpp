// The binomial glint model through the service: a real glintd on a free loopback port, spoken to
// over gRPC (glint.v1, proto/glint/v1/glint.proto). A directional light whose cone grows must
// never make a glint go out: for every footprint the count of reflecting facets
// b = N_P p L / L_smooth (the model returns L = L_smooth b / (N_P p), Kneiphof & Klein 2024
// Eq. 16) is non-decreasing in the cone, in the FP32 and FP64 kernels, while p runs from 6e-5
// across 1/2 to 0.6 and N_P from 0.3 to 1e7 facets (every regime of the draw).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"

namespace {

using glint::v1::EvaluateRequest;
using glint::v1::EvaluateResponse;

struct Vec {
  double x, y, z;
};
Vec Normalize(Vec a) {
  double l = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
  return {a.x / l, a.y / l, a.z / l};
}
double Dot(Vec a, Vec b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

constexpr double kPi = 3.14159265358979323846;
constexpr double kAlpha = 0.02;
constexpr double kDensity = 1e6;

class BinomialServiceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new glint::test::TempDir("glint_binomial_service_test");
    std::string error;
    server_ = glint::test::Glintd::Start(GLINTD_PATH, *dir_, "glintd", {}, &error).release();
    ASSERT_NE(server_, nullptr) << error;
    grpc::ChannelArguments args;
    args.SetMaxReceiveMessageSize(64 << 20);
    stub_ = glint::v1::GlintService::NewStub(
        grpc::CreateCustomChannel(server_->address(), grpc::InsecureChannelCredentials(), args));
  }
  static void TearDownTestSuite() {
    stub_.reset();
    delete server_;
    delete dir_;
  }

  // Red channel of every query's radiance.
  static std::vector<double> Evaluate(const EvaluateRequest &r) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(240));
    EvaluateResponse out;
    grpc::Status s = stub_->Evaluate(&ctx, r, &out);
    EXPECT_TRUE(s.ok()) << s.error_message();
    std::vector<double> red;
    for (int i = 0; i + 2 < out.radiance_size(); i += 3) red.push_back(out.radiance(i));
    return red;
  }

  static glint::test::TempDir *dir_;
  static glint::test::Glintd *server_;
  static std::unique_ptr<glint::v1::GlintService::Stub> stub_;
};
glint::test::TempDir *BinomialServiceTest::dir_ = nullptr;
glint::test::Glintd *BinomialServiceTest::server_ = nullptr;
std::unique_ptr<glint::v1::GlintService::Stub> BinomialServiceTest::stub_;

TEST_F(BinomialServiceTest, GlintCountNeverFallsAsADirectionalLightGrows) {
  // Geometry: the light at 30 degrees, the view its mirror about a half vector tilted 0.03 from
  // the normal, GGX alpha 0.02, so that D(h) is large and p = Omega D(h) / (4 D_H h.wi)
  // (Eq. 20) sweeps 6e-5 .. 0.6 as the cone half-angle grows from 0.05 to 5 degrees.
  const Vec wi = Normalize({0.5, 0.0, 0.866});
  const Vec h = Normalize({0.0, 0.03, 1.0});
  const Vec wo = {2 * Dot(h, wi) * h.x - wi.x, 2 * Dot(h, wi) * h.y - wi.y,
                  2 * Dot(h, wi) * h.z - wi.z};
  // Eq. 20's factor K = p / Omega = D(h) / (4 D_H h.wi), independent of the cone, with GGX's
  // closed forms: D = 1 / (pi a^2 cos^4 (1 + tan^2 / a^2)^2) and D_H = cos_o (1 + Lambda(wo)),
  // Lambda = (sqrt(1 + a^2 tan_o^2) - 1) / 2 (Heitz 2014). The service's D_H comes from its LTC
  // table, so its p differs from this one by a constant factor near 1: for monotonicity in the
  // cone the factor is irrelevant; it only shows how far p goes.
  const double tan2_h = (1 - h.z * h.z) / (h.z * h.z);
  const double d =
      1 / (kPi * kAlpha * kAlpha * std::pow(h.z, 4) * std::pow(1 + tan2_h / (kAlpha * kAlpha), 2));
  const double tan2_o = (1 - wo.z * wo.z) / (wo.z * wo.z);
  const double d_h = wo.z * (1 + 0.5 * (std::sqrt(1 + kAlpha * kAlpha * tan2_o) - 1));
  const double k_factor = d / (4 * d_h * Dot(h, wi));
  auto omega = [](double cone_deg) {
    const double half = 0.5 * cone_deg * kPi / 180;
    return 4 * kPi * std::sin(half) * std::sin(half);
  };
  std::vector<double> cones;
  for (int i = 0; i < 60; ++i) cones.push_back(0.05 * std::pow(100.0, i / 59.0));
  const double p_min = k_factor * omega(cones.front()), p_max = k_factor * omega(cones.back());
  std::printf("p (Eq. 20, closed-form D_H) from %.3g to %.3g\n", p_min, p_max);
  ASSERT_LT(p_min, 1e-3);
  ASSERT_GT(p_max, 0.5);  // across 1/2, where the draw searches from the other end
  ASSERT_LT(p_max, 0.8);  // below the clamp at 1 even if the table's D_H differed by 20%

  // Footprints holding N_P = 0.3 .. 1e7 facets (log-uniform), random Jacobians.
  const int kQueries = 2000;
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  glint::v1::QueryBatch q;
  q.set_count(kQueries);
  std::vector<double> n_facets;
  for (int i = 0; i < kQueries; ++i) {
    const double target = 0.3 * std::pow(1e7 / 0.3, 0.5 * (1 + uni(rng)));
    double j[4] = {uni(rng), uni(rng), uni(rng), uni(rng)};
    const double scale = std::sqrt(target / (kDensity * std::fabs(j[0] * j[3] - j[2] * j[1])));
    for (double &x : j) x = double(float(x * scale));
    n_facets.push_back(kDensity * std::fabs(j[0] * j[3] - j[2] * j[1]));
    q.add_uv(float(50 * (1 + uni(rng))));
    q.add_uv(float(50 * (1 + uni(rng))));
    for (double x : j) q.add_footprint(float(x));
    q.add_wo(float(wo.x));
    q.add_wo(float(wo.y));
    q.add_wo(float(wo.z));
  }

  for (auto precision : {glint::v1::FP32, glint::v1::FP64}) {
    auto request = [&](glint::v1::Model model, double cone_deg) {
      EvaluateRequest r;
      auto *m = r.mutable_material();
      m->set_model(model);
      m->set_ndf(glint::v1::GGX);
      m->set_alpha_x(float(kAlpha));
      m->set_alpha_y(float(kAlpha));
      for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(1.0f);
      if (model == glint::v1::BINOMIAL) {
        m->mutable_binomial()->set_density(kDensity);
        m->mutable_binomial()->set_p_mode(glint::v1::AREA);
      }
      auto *l = r.add_lights()->mutable_directional();
      for (double x : {wi.x, wi.y, wi.z}) l->add_direction(float(x));
      for (int c = 0; c < 3; ++c) l->add_irradiance(1.0f);
      l->set_cone_half_angle_deg(float(cone_deg));
      *r.mutable_queries() = q;
      r.set_precision(precision);
      r.set_seed(0x5eed);
      return r;
    };
    // The smooth model ignores the cone (a delta light): one reference for all cones.
    const std::vector<double> smooth = Evaluate(request(glint::v1::SMOOTH, 1.0));
    ASSERT_EQ(smooth.size(), size_t(kQueries));
    // Tolerance: b is reconstructed from fp32 outputs (L, L_smooth) and the fp32 solid angle
    // the server packs: a few roundings of 2^-24, far below 1e-5 relative.
    const double tol = 1e-5;
    std::vector<double> last(kQueries, 0.0);
    long falls = 0, lit = 0, grew = 0;
    for (double cone : cones) {
      const std::vector<double> glint = Evaluate(request(glint::v1::BINOMIAL, cone));
      ASSERT_EQ(glint.size(), size_t(kQueries));
      const double p = k_factor * omega(float(cone));
      for (int i = 0; i < kQueries; ++i) {
        ASSERT_GT(smooth[size_t(i)], 0.0);
        const double count = n_facets[size_t(i)] * p * glint[size_t(i)] / smooth[size_t(i)];
        if (count < last[size_t(i)] * (1 - tol) && falls++ < 5)
          ADD_FAILURE() << glint::v1::Precision_Name(precision) << " query " << i << " (N_P "
                        << n_facets[size_t(i)] << "): count " << last[size_t(i)] << " -> " << count
                        << " at cone " << cone << " deg";
        lit += count > 0;
        grew += count > last[size_t(i)] * (1 + tol);
        last[size_t(i)] = count;
      }
    }
    std::printf("%s: %zu cones x %d footprints, %ld lit, %ld increases, %ld falls\n",
                glint::v1::Precision_Name(precision).c_str(), cones.size(), kQueries, lit, grew,
                falls);
    EXPECT_EQ(falls, 0) << glint::v1::Precision_Name(precision);
    EXPECT_GT(grew, kQueries) << "the counts must actually grow with the cone";
  }
  EXPECT_TRUE(server_->Alive());
}

}  // namespace
