// Admission cost (server/request_cost.h) against explicit counts: REFERENCE's Gauss-Legendre
// nodes per fan triangle, MONTE_CARLO samples, the per-vertex weights, the model factor; the
// default limits admit every example material x light list at 1M queries by the methods a
// preview uses and refuse the issue's request.
#include "server/request_cost.h"

#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

namespace v1 = glint::v1;

v1::EvaluateRequest Smooth() {
  v1::EvaluateRequest r;
  r.mutable_material()->set_model(v1::SMOOTH);
  return r;
}

void AddPolygon(v1::EvaluateRequest *r, int vertices) {
  auto *p = r->add_lights()->mutable_polygon();
  for (int k = 0; k < 3 * vertices; ++k) p->add_vertices(0.0f);
}

TEST(RequestCost, ReferenceCountsNodesPerFanTriangle) {
  v1::EvaluateRequest r = Smooth();
  AddPolygon(&r, 4);
  r.set_area_method(v1::REFERENCE);
  r.set_area_samples(30);  // rounded up to 8 panels of 4 nodes: 32 x 32 per triangle
  // A quad clipped to the horizon has at most 5 vertices, 3 fan triangles; +1 per query.
  EXPECT_EQ(glint::EstimateRequestCost(r, 10).per_query, 1.0 + 3 * 32 * 32);
  EXPECT_EQ(glint::EstimateRequestCost(r, 10).total, 10 * (1.0 + 3 * 32 * 32));
  r.set_area_samples(0);  // default 64 nodes
  EXPECT_EQ(glint::EstimateRequestCost(r, 1).per_query, 1.0 + 3 * 64 * 64);
}

TEST(RequestCost, MonteCarloCountsSamplesAndPunctualLightsOneEach) {
  v1::EvaluateRequest r = Smooth();
  AddPolygon(&r, 6);
  AddPolygon(&r, 3);
  r.add_lights()->mutable_point();
  r.add_lights()->mutable_directional();
  r.set_area_method(v1::MONTE_CARLO);
  r.set_area_samples(100);
  const double mc = glint::EstimateRequestCost(r, 1).per_query;
  r.set_area_samples(200);
  // Twice the samples on both polygons: the difference is 2 polygons x 100 samples x weight.
  const double mc2 = glint::EstimateRequestCost(r, 1).per_query;
  EXPECT_GT(mc2 - mc, 0);
  EXPECT_DOUBLE_EQ(mc2 - mc, (mc - 3.0) / 1.0 * 1.0);  // 1 per query + 2 punctual lights
}

TEST(RequestCost, ModelFactorMultipliesAndLtcGrowsWithVertices) {
  v1::EvaluateRequest r = Smooth();
  AddPolygon(&r, 4);
  const double quad = glint::EstimateRequestCost(r, 1).per_query;
  v1::EvaluateRequest r16 = Smooth();
  AddPolygon(&r16, 16);
  const double sixteen = glint::EstimateRequestCost(r16, 1).per_query;
  EXPECT_DOUBLE_EQ((sixteen - 1) / (quad - 1), 4.0);  // per vertex
  r.mutable_material()->set_model(v1::KEMPPINEN);
  r.mutable_material()->mutable_kemppinen()->set_neighbors(16);
  const double k16 = glint::EstimateRequestCost(r, 1).per_query;
  r.mutable_material()->mutable_kemppinen()->set_neighbors(4);
  const double k4 = glint::EstimateRequestCost(r, 1).per_query;
  // The Kemppinen factor (1.5 + 1.4 k) multiplies the query's punctual work; a polygon is the
  // smooth integral plus the model's measured polygon cost (1000 units for the paper's
  // neighbourhood), whatever k.
  EXPECT_DOUBLE_EQ(k16, quad + 1000);
  EXPECT_DOUBLE_EQ(k4, quad + 1000);
  r.clear_lights();
  r.add_lights()->mutable_point();
  const double k4_point = glint::EstimateRequestCost(r, 1).per_query;
  r.mutable_material()->mutable_kemppinen()->set_neighbors(16);
  EXPECT_DOUBLE_EQ(glint::EstimateRequestCost(r, 1).per_query, 1 + (1.5 + 1.4 * 16));
  EXPECT_DOUBLE_EQ(k4_point, 1 + (1.5 + 1.4 * 4));
  EXPECT_GT(k4, quad);
}

TEST(RequestCost, DefaultsRefuseTheIssueRequestNamingCostAndLimit) {
  v1::EvaluateRequest r = Smooth();
  for (int k = 0; k < 64; ++k) AddPolygon(&r, 16);
  r.set_area_method(v1::REFERENCE);
  r.set_area_samples(1024);
  const glint::RequestCost one = glint::EstimateRequestCost(r, 1);
  EXPECT_EQ(one.per_query, 1.0 + 64.0 * 15 * 1024 * 1024);
  glint::Status s = glint::CheckRequestCost(one, 1, glint::CostLimits());
  EXPECT_EQ(s.code(), glint::Status::Code::kResourceExhausted);
  EXPECT_NE(s.message().find("1.01e+09"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("--max-query-cost 1e+07"), std::string::npos) << s.message();
  // The total limit on its own: cheap queries, too many of them.
  glint::CostLimits tight;
  tight.max_request_cost = 1000;
  v1::EvaluateRequest probe = Smooth();
  s = glint::CheckRequestCost(glint::EstimateRequestCost(probe, 1000), 1000, tight);
  EXPECT_EQ(s.code(), glint::Status::Code::kResourceExhausted);
  EXPECT_NE(s.message().find("--max-request-cost 1e+03"), std::string::npos) << s.message();
  EXPECT_TRUE(glint::CheckRequestCost(glint::EstimateRequestCost(probe, 499), 499, tight).ok());
}

// A refused cost is printed with the digits that tell it from the limit: 502 probes of 2 units
// (1004) over --max-request-cost 1000 read "request cost: 1e+03 ... exceeds --max-request-cost
// 1e+03" at the 3 digits used before. The limit keeps the fewest digits that read back as itself.
TEST(RequestCost, RefusalPrintsTheCostWithDigitsThatTellItFromTheLimit) {
  glint::CostLimits tight;
  tight.max_request_cost = 1000;
  const v1::EvaluateRequest probe = Smooth();
  const glint::RequestCost c = glint::EstimateRequestCost(probe, 502);
  ASSERT_EQ(c.total, 1004.0);  // 502 x (1 per query + 1 probe evaluation)
  glint::Status s = glint::CheckRequestCost(c, 502, tight);
  EXPECT_EQ(s.code(), glint::Status::Code::kResourceExhausted);
  EXPECT_NE(s.message().find("request cost: 1004 BRDF evaluations ("), std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find("exceeds --max-request-cost 1e+03;"), std::string::npos)
      << s.message();
  // Per query, in the headline and the parts alike: 10000001 over 1e7; 1000.6 over 1000.5 (a
  // limit that needs 5 digits) reads 1001, the fewest digits that read back as more than it.
  struct Case {
    double cost, limit;
    const char *cost_text, *limit_text;
  };
  for (const Case &k :
       {Case{10000001.0, 1e7,
             "request cost: 10000001 BRDF evaluations per query (1 queries x "
             "10000001 per query",
             "exceeds --max-query-cost 1e+07 "},
        Case{1000.6, 1000.5, "request cost: 1001 BRDF evaluations per query (1 queries x 1001 per",
             "exceeds --max-query-cost 1000.5 "}}) {
    glint::RequestCost one;
    one.per_query = one.total = k.cost;
    one.parts = "probe";
    glint::CostLimits limits;
    limits.max_query_cost = k.limit;
    s = glint::CheckRequestCost(one, 1, limits);
    EXPECT_EQ(s.code(), glint::Status::Code::kResourceExhausted);
    EXPECT_NE(s.message().find(k.cost_text), std::string::npos) << s.message();
    EXPECT_NE(s.message().find(k.limit_text), std::string::npos) << s.message();
  }
}

// Every example material under every example light list as a 512x512 preview by LTC, LECOCQ
// and REFERENCE at the default 64 nodes, and as 1M queries by LTC: admitted by the default
// limits (the previews and demos).
TEST(RequestCost, DefaultsAdmitEveryExampleAsAPreview) {
  namespace fs = std::filesystem;
  auto read = [](const fs::path &p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  int checked = 0;
  for (const auto &mat : fs::directory_iterator(GLINT_EXAMPLES_DIR "/materials")) {
    for (const auto &lights : fs::directory_iterator(GLINT_EXAMPLES_DIR "/lights")) {
      v1::EvaluateRequest r;
      ASSERT_TRUE(
          google::protobuf::util::JsonStringToMessage(read(mat.path()), r.mutable_material()).ok());
      v1::LightList list;
      ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(read(lights.path()), &list).ok());
      *r.mutable_lights() = list.lights();
      for (auto [m, n] : {std::pair{v1::LTC, 1u << 20},
                          {v1::LTC, 512u * 512u},
                          {v1::LECOCQ, 512u * 512u},
                          {v1::REFERENCE, 512u * 512u}}) {
        r.set_area_method(m);
        const glint::RequestCost c = glint::EstimateRequestCost(r, n);
        glint::Status s = glint::CheckRequestCost(c, n, glint::CostLimits());
        EXPECT_TRUE(s.ok()) << mat.path() << " x " << lights.path() << ": " << s.message();
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 4 * 8 * 5);
}

}  // namespace

// Sample admission (issue 12): one sample is one evaluation of the model (its sampler weights
// by f cos_i / pdf, or its pdf is the model's NDF), so a query costs K x (1 per-query unit + the
// model's factor). Explicit numbers: SMOOTH factor 1; NORMAL_MAP factor 2000 x 7 (subdivision
// 4) x cutoff^2 / 25 (models/normal_map/normal_map_model.cpp), 56000 at cutoff_sigma 10.
TEST(SampleCost, KSamplesEachOneEvaluationOfTheModel) {
  v1::EvaluateRequest smooth = Smooth();
  const glint::RequestCost s = glint::EstimateSampleCost(smooth, 65536, 3);
  EXPECT_EQ(s.per_query, 65536.0 * 2.0);
  EXPECT_EQ(s.total, 3 * 65536.0 * 2.0);
  EXPECT_TRUE(glint::CheckRequestCost(s, 3, glint::CostLimits()).ok()) << "a smooth query";

  // The probe's request: one NORMAL_MAP query, 65536 samples, cutoff 10, subdivision 4 (it held
  // a worker 38 s): 65536 x 56001 = 3.67e9 units per query, refused by the default
  // --max-query-cost with the advice that fits a sample request.
  v1::EvaluateRequest bumpy;
  bumpy.mutable_material()->set_model(v1::NORMAL_MAP);
  bumpy.mutable_material()->mutable_normal_map()->set_cutoff_sigma(10.0f);
  bumpy.mutable_material()->mutable_normal_map()->set_subdivision(4);
  const glint::RequestCost b = glint::EstimateSampleCost(bumpy, 65536, 1);
  EXPECT_EQ(b.per_query, 65536.0 * (1.0 + 56000.0));
  glint::Status st = glint::CheckRequestCost(b, 1, glint::CostLimits());
  EXPECT_EQ(st.code(), glint::Status::Code::kResourceExhausted);
  EXPECT_NE(st.message().find("3.67e+09"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("--max-query-cost 1e+07"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("65536 samples_per_query"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("NORMAL_MAP factor 5.6e+04"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("fewer samples_per_query"), std::string::npos) << st.message();
  // 178 samples fit under 1e7 (178 x 56001 = 9.97e6), 179 do not.
  EXPECT_TRUE(
      glint::CheckRequestCost(glint::EstimateSampleCost(bumpy, 178, 1), 1, glint::CostLimits())
          .ok());
  EXPECT_FALSE(
      glint::CheckRequestCost(glint::EstimateSampleCost(bumpy, 179, 1), 1, glint::CostLimits())
          .ok());

  // The total limit: 512 queries x 1024 smooth samples = 1.05e6 units.
  glint::CostLimits tight;
  tight.max_request_cost = 1e6;
  st = glint::CheckRequestCost(glint::EstimateSampleCost(smooth, 1024, 512), 512, tight);
  EXPECT_EQ(st.code(), glint::Status::Code::kResourceExhausted);
  EXPECT_NE(st.message().find("1.05e+06"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("--max-request-cost 1e+06"), std::string::npos) << st.message();
  EXPECT_TRUE(
      glint::CheckRequestCost(glint::EstimateSampleCost(smooth, 1024, 488), 488, tight).ok());
}

// KEMPPINEN's sampler runs the paper's neighbourhood for its pdf whatever
// material.kemppinen.neighborhood says, and measured only 1.3x (ONE_LEVEL) and 1.5-1.7x
// (ONE_CELL) the paper's samples per second (bench_sample, k = 4), where their evaluation factors
// are 2x and 4.4x below the paper's: a sample is charged as one paper evaluation, 1 + 1.5 + 1.4 k
// units at k = 4, for every neighbourhood; Evaluate keeps the cheaper factors.
TEST(SampleCost, KemppinenSamplesCostAPaperEvaluationWhateverTheNeighbourhood) {
  v1::EvaluateRequest paper;
  paper.mutable_material()->set_model(v1::KEMPPINEN);
  paper.mutable_material()->mutable_kemppinen()->set_density(1e5);
  const double per_sample = 1.0 + 1.5 + 1.4 * 4;
  EXPECT_DOUBLE_EQ(glint::EstimateSampleCost(paper, 64, 1).per_query, 64 * per_sample);
  for (auto hood : {v1::KEMPPINEN_PAPER, v1::KEMPPINEN_ONE_LEVEL, v1::KEMPPINEN_ONE_CELL}) {
    v1::EvaluateRequest r = paper;
    r.mutable_material()->mutable_kemppinen()->set_neighborhood(hood);
    EXPECT_DOUBLE_EQ(glint::EstimateSampleCost(r, 64, 1).per_query, 64 * per_sample)
        << v1::KemppinenNeighborhood_Name(hood);
    if (hood != v1::KEMPPINEN_PAPER) {
      EXPECT_LT(glint::EstimateRequestCost(r, 1).per_query,
                glint::EstimateRequestCost(paper, 1).per_query)
          << v1::KemppinenNeighborhood_Name(hood);
    }
  }
}
