// Every refusal names the field, the first bad query index and what was
// expected; good requests pass.
#include "server/validation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

namespace glint {
namespace {

using glint::v1::EvaluateRequest;

EvaluateRequest GoodProbe(uint32_t n = 4) {
  EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(v1::SMOOTH);
  m->set_ndf(v1::GGX);
  m->set_alpha_x(0.3f);
  m->set_alpha_y(0.1f);
  for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  auto *q = r.mutable_queries();
  q->set_count(n);
  for (uint32_t i = 0; i < n; ++i) {
    for (float v : {0.0f, 0.6f, 0.8f}) q->add_wo(v);
    for (float v : {0.0f, -0.6f, 0.8f}) q->add_wi(v);
  }
  return r;
}

Status Validate(const EvaluateRequest &r, ValidationLimits limits = {}) {
  Status s = ValidateSettings(r, limits);
  if (!s.ok()) return s;
  return ValidateQueries(r.queries(), r.lights_size() > 0, limits);
}

struct Case {
  const char *name;
  std::function<void(EvaluateRequest &)> mutate;
  std::vector<const char *> must_contain;
};

TEST(Validation, GoodRequestsPass) {
  EXPECT_TRUE(Validate(GoodProbe()).ok());
  EvaluateRequest lit = GoodProbe();
  lit.mutable_queries()->clear_wi();
  auto *d = lit.add_lights()->mutable_directional();
  for (float v : {0.0f, 0.0f, 1.0f}) d->add_direction(v);
  for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
  Status s = Validate(lit);
  EXPECT_TRUE(s.ok()) << s.message();
  // The edges of the material ranges: roughness 1e-4 (as the float a client sends) and 1,
  // and any dielectric ior in (0, 1e6), 1e-30 included (issue 8: F_dielectric is exact there).
  for (float alpha : {1e-4f, 1.0f}) {
    EvaluateRequest edge = GoodProbe();
    edge.mutable_material()->set_alpha_x(alpha);
    edge.mutable_material()->set_alpha_y(alpha);
    s = Validate(edge);
    EXPECT_TRUE(s.ok()) << alpha << ": " << s.message();
  }
  for (float ior : {1e-30f, 1.5f, 9.99e5f}) {
    EvaluateRequest edge = GoodProbe();
    edge.mutable_material()->mutable_dielectric()->set_ior(ior);
    s = Validate(edge);
    EXPECT_TRUE(s.ok()) << ior << ": " << s.message();
  }
  // Within the unit tolerance (1e-3): accepted.
  EvaluateRequest slightly_off = GoodProbe();
  slightly_off.mutable_queries()->set_wo(2, 0.8005f);
  EXPECT_TRUE(Validate(slightly_off).ok());
}

TEST(Validation, RefusalsNameFieldIndexAndExpectation) {
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  constexpr float inf = std::numeric_limits<float>::infinity();
  const std::vector<Case> cases = {
      {"no material", [](auto &r) { r.clear_material(); }, {"material"}},
      {"model unset",
       [](auto &r) { r.mutable_material()->set_model(v1::MODEL_UNSPECIFIED); },
       {"material.model", "unset", "SMOOTH"}},
      {"model unknown",
       [](auto &r) { r.mutable_material()->set_model(v1::Model(42)); },
       {"material.model", "42"}},
      {"ndf unknown",
       [](auto &r) { r.mutable_material()->set_ndf(v1::Ndf(7)); },
       {"material.ndf", "GGX or BECKMANN"}},
      {"alpha 0",
       [](auto &r) { r.mutable_material()->set_alpha_x(0.0f); },
       {"material.alpha_x", "[1e-4, 1]"}},
      {"alpha > 1",
       [](auto &r) { r.mutable_material()->set_alpha_y(1.5f); },
       {"material.alpha_y", "[1e-4, 1]"}},
      // Below the roughness floor (issue 8: alpha 1e-20 gave +Inf, 1e-23 NaN).
      {"alpha below 1e-4",
       [](auto &r) { r.mutable_material()->set_alpha_x(1e-5f); },
       {"material.alpha_x: 1e-05; expected a roughness in [1e-4, 1]"}},
      {"alpha 1e-23",
       [](auto &r) { r.mutable_material()->set_alpha_y(1e-23f); },
       {"material.alpha_y: 1e-23;", "[1e-4, 1]"}},
      {"alpha nan", [](auto &r) { r.mutable_material()->set_alpha_y(nan); }, {"material.alpha_y"}},
      {"no fresnel",
       [](auto &r) { r.mutable_material()->clear_schlick(); },
       {"material.fresnel", "schlick, conductor, dielectric"}},
      {"f0 two values",
       [](auto &r) { r.mutable_material()->mutable_schlick()->mutable_f0()->RemoveLast(); },
       {"material.schlick.f0", "expected 3"}},
      {"f0 > 1",
       [](auto &r) { r.mutable_material()->mutable_schlick()->set_f0(1, 1.5f); },
       {"material.schlick.f0", "[0, 1]"}},
      {"conductor k < 0",
       [](auto &r) {
         auto *c = r.mutable_material()->mutable_conductor();
         for (float v : {1.0f, 1.0f, 1.0f}) c->add_eta(v);
         for (float v : {1.0f, -1.0f, 1.0f}) c->add_k(v);
       },
       {"material.conductor.k", "in [0, 1e6]"}},
      {"dielectric ior inf",
       [](auto &r) { r.mutable_material()->mutable_dielectric()->set_ior(inf); },
       {"material.dielectric.ior", "(0, 1e6)"}},
      {"dielectric ior 0",
       [](auto &r) { r.mutable_material()->mutable_dielectric()->set_ior(0.0f); },
       {"material.dielectric.ior: 0;", "(0, 1e6)"}},
      {"count 0",
       [](auto &r) { r.mutable_queries()->set_count(0); },
       {"queries.count", "at least one"}},
      {"wo length mismatch",
       [](auto &r) { r.mutable_queries()->mutable_wo()->RemoveLast(); },
       {"queries.wo", "expected 3 x count = 12"}},
      {"uv wrong size",
       [](auto &r) { r.mutable_queries()->add_uv(0.5f); },
       {"queries.uv", "or none"}},
      {"wo nan at 2",
       [](auto &r) { r.mutable_queries()->set_wo(7, nan); },
       {"queries.wo[2]", "not finite"}},
      {"wi zero at 3",
       [](auto &r) {
         for (int k = 9; k < 12; ++k) r.mutable_queries()->set_wi(k, 0.0f);
       },
       {"queries.wi[3]", "unit vector"}},
      {"wo not unit at 1",
       [](auto &r) { r.mutable_queries()->set_wo(5, 0.9f); },
       {"queries.wo[1]", "length", "unit vector"}},
      {"footprint inf at 1",
       [](auto &r) {
         for (int k = 0; k < 16; ++k) r.mutable_queries()->add_footprint(k == 5 ? inf : 0.0f);
       },
       {"queries.footprint[1]", "not finite"}},
      {"partial frame",
       [](auto &r) {
         for (int k = 0; k < 12; ++k) r.mutable_queries()->add_normal(k % 3 == 2 ? 1.0f : 0.0f);
       },
       {"position/normal/tangent", "all three"}},
      {"tangent parallel at 0",
       [](auto &r) {
         auto *q = r.mutable_queries();
         for (int k = 0; k < 12; ++k) {
           q->add_position(0.0f);
           q->add_normal(k % 3 == 2 ? 1.0f : 0.0f);
           q->add_tangent(k % 3 == 2 ? 1.0f : 0.0f);
         }
       },
       {"queries.tangent[0]", "parallel"}},
      {"probe with lights",
       [](auto &r) {
         auto *d = r.add_lights()->mutable_directional();
         for (float v : {0.0f, 0.0f, 1.0f}) d->add_direction(v);
         for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
       },
       {"lights", "probe"}},
      {"no wi and no lights",
       [](auto &r) { r.mutable_queries()->clear_wi(); },
       {"lights", "at least one light"}},
      {"light without kind",
       [](auto &r) {
         r.mutable_queries()->clear_wi();
         r.add_lights();
       },
       {"lights[0]", "directional, point or polygon"}},
      {"directional not unit",
       [](auto &r) {
         r.mutable_queries()->clear_wi();
         auto *d = r.add_lights()->mutable_directional();
         for (float v : {0.0f, 0.0f, 2.0f}) d->add_direction(v);
         for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
       },
       {"lights[0].directional.direction", "unit"}},
      {"point negative intensity",
       [](auto &r) {
         r.mutable_queries()->clear_wi();
         auto *p = r.add_lights()->mutable_point();
         for (float v : {0.0f, 0.0f, 2.0f}) p->add_position(v);
         for (float v : {1.0f, -1.0f, 1.0f}) p->add_intensity(v);
       },
       {"lights[0].point.intensity", "[0, 3e38]"}},
      // Above the accepted 3e38 but still a float >= 0: the refusal states the upper end
      // (it said "expected 3 values >= 0" of FLT_MAX, contradicting the value).
      {"directional irradiance FLT_MAX",
       [](auto &r) {
         r.mutable_queries()->clear_wi();
         auto *d = r.add_lights()->mutable_directional();
         for (float v : {0.0f, 0.0f, 1.0f}) d->add_direction(v);
         for (float v : {1.0f, std::numeric_limits<float>::max(), 1.0f}) d->add_irradiance(v);
       },
       {"lights[0].directional.irradiance", "expected 3 values in [0, 3e38]"}},
      {"point intensity 3.1e38",
       [](auto &r) {
         r.mutable_queries()->clear_wi();
         auto *p = r.add_lights()->mutable_point();
         for (float v : {0.0f, 0.0f, 2.0f}) p->add_position(v);
         for (float v : {3.1e38f, 1.0f, 1.0f}) p->add_intensity(v);
       },
       {"lights[0].point.intensity", "expected 3 values in [0, 3e38]"}},
      {"polygon radiance FLT_MAX",
       [](auto &r) {
         r.mutable_queries()->clear_wi();
         auto *p = r.add_lights()->mutable_polygon();
         for (float v : {-1.0f, -1.0f, 2.0f, -1.0f, 1.0f, 2.0f, 1.0f, 1.0f, 2.0f}) p->add_vertices(v);
         for (float v : {1.0f, 1.0f, std::numeric_limits<float>::max()}) p->add_radiance(v);
       },
       {"lights[0].polygon.radiance", "expected 3 values in [0, 3e38]"}},
      {"cone angle > 90",
       [](auto &r) {
         r.mutable_queries()->clear_wi();
         auto *d = r.add_lights()->mutable_directional();
         for (float v : {0.0f, 0.0f, 1.0f}) d->add_direction(v);
         for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
         d->set_cone_half_angle_deg(120.0f);
       },
       {"cone_half_angle_deg", "[0, 90]"}},
      {"precision unknown", [](auto &r) { r.set_precision(v1::Precision(9)); }, {"precision"}},
  };
  for (const Case &c : cases) {
    EvaluateRequest r = GoodProbe();
    c.mutate(r);
    Status s = Validate(r);
    ASSERT_FALSE(s.ok()) << c.name;
    EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << c.name;
    for (const char *part : c.must_contain)
      EXPECT_NE(s.message().find(part), std::string::npos)
          << c.name << ": '" << s.message() << "' lacks '" << part << "'";
  }
}

// A lit request with one polygon light (a unit square overhead, facing down).
EvaluateRequest GoodPolygon(std::vector<float> vertices = {-1, -1, 2, -1, 1, 2, 1, 1, 2, 1, -1,
                                                           2}) {
  EvaluateRequest r = GoodProbe();
  r.mutable_queries()->clear_wi();
  auto *p = r.add_lights()->mutable_polygon();
  for (float v : vertices) p->add_vertices(v);
  for (float v : {1.0f, 2.0f, 3.0f}) p->add_radiance(v);
  return r;
}

TEST(Validation, PolygonLights) {
  EXPECT_TRUE(Validate(GoodPolygon()).ok());
  EXPECT_TRUE(Validate(GoodPolygon({0, 0, 1, 1, 0, 1, 0, 1, 1})).ok());  // triangle
  // Collinear corners are allowed (a square with an extra vertex mid-edge).
  EXPECT_TRUE(Validate(GoodPolygon({-1, -1, 2, -1, 0, 2, -1, 1, 2, 1, 1, 2, 1, -1, 2})).ok());
  EvaluateRequest ref = GoodPolygon();
  ref.set_area_method(v1::REFERENCE);
  ref.set_area_samples(32);
  EXPECT_TRUE(Validate(ref).ok());

  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  struct PolyCase {
    const char *name;
    std::vector<float> vertices;
    std::vector<const char *> must_contain;
  };
  std::vector<float> many;
  for (int i = 0; i < 17; ++i) {
    double a = 2 * 3.14159265358979 * i / 17;
    for (double v : {std::cos(a), std::sin(a), 1.0}) many.push_back(float(v));
  }
  const std::vector<PolyCase> cases = {
      {"two vertices", {0, 0, 1, 1, 0, 1}, {"lights[0].polygon.vertices", "3 to 16"}},
      {"not xyz", {0, 0, 1, 1, 0, 1, 0, 1, 1, 5}, {"lights[0].polygon.vertices", "3 to 16"}},
      {"17 vertices", many, {"lights[0].polygon.vertices", "3 to 16"}},
      {"nan", {0, 0, 1, 1, nan, 1, 0, 1, 1}, {"lights[0].polygon.vertices", "not finite"}},
      {"collinear", {0, 0, 1, 1, 0, 1, 2, 0, 1}, {"lights[0].polygon.vertices", "degenerate"}},
      {"zero area", {1, 1, 1, 1, 1, 1, 1, 1, 1}, {"lights[0].polygon.vertices", "degenerate"}},
      {"not planar",
       {-1, -1, 2, -1, 1, 2, 1, 1, 2.5, 1, -1, 2},
       {"lights[0].polygon.vertices", "not planar"}},
      {"concave",
       {-1, -1, 2, 0, -0.2f, 2, 1, -1, 2, 0, 1, 2},
       {"lights[0].polygon.vertices", "concave polygons are refused"}},
      {"star",
       {1, 0, 2, -0.81f, 0.59f, 2, 0.31f, -0.95f, 2, 0.31f, 0.95f, 2, -0.81f, -0.59f, 2},
       {"lights[0].polygon.vertices", "concave polygons are refused"}},
  };
  for (const PolyCase &c : cases) {
    Status s = Validate(GoodPolygon(c.vertices));
    ASSERT_FALSE(s.ok()) << c.name;
    EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << c.name;
    for (const char *part : c.must_contain)
      EXPECT_NE(s.message().find(part), std::string::npos)
          << c.name << ": '" << s.message() << "' lacks '" << part << "'";
  }
  EvaluateRequest neg = GoodPolygon();
  neg.mutable_lights(0)->mutable_polygon()->set_radiance(1, -1.0f);
  Status s = Validate(neg);
  EXPECT_NE(s.message().find("lights[0].polygon.radiance"), std::string::npos) << s.message();
  for (v1::AreaMethod m :
       {v1::LTC, v1::LECOCQ, v1::LECOCQ_PEARSON, v1::MONTE_CARLO, v1::REFERENCE}) {
    EvaluateRequest r = GoodPolygon();
    r.set_area_method(m);
    EXPECT_TRUE(Validate(r).ok()) << v1::AreaMethod_Name(m);
  }
  EvaluateRequest unknown = GoodPolygon();
  unknown.set_area_method(static_cast<v1::AreaMethod>(9));
  s = Validate(unknown);
  EXPECT_NE(s.message().find("area_method: unknown value 9; expected LTC, LECOCQ"),
            std::string::npos)
      << s.message();
}

// Issue 8: these roughnesses reached the kernels and gave +Inf (1e-20) or NaN (1e-23 .. 1e-38).
// Below the floor 1e-4 they are refused, naming the field and the range.
TEST(Validation, RoughnessBelowTheFloorIsRefused) {
  for (float alpha : {9.9e-5f, 1e-20f, 1e-23f, 1e-25f, 1e-38f, 1e-45f}) {
    for (bool y : {false, true}) {
      EvaluateRequest r = GoodProbe();
      if (y) {
        r.mutable_material()->set_alpha_y(alpha);
      } else {
        r.mutable_material()->set_alpha_x(alpha);
      }
      Status s = Validate(r);
      ASSERT_FALSE(s.ok()) << alpha;
      EXPECT_EQ(s.message().find(y ? "material.alpha_y: " : "material.alpha_x: "), 0u)
          << s.message();
      EXPECT_NE(s.message().find("; expected a roughness in [1e-4, 1]"), std::string::npos)
          << s.message();
    }
  }
}

TEST(Validation, BatchOverTheLimitPointsToTheStream) {
  ValidationLimits limits;
  limits.max_batch = 3;
  Status s = Validate(GoodProbe(4), limits);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("EvaluateStream"), std::string::npos) << s.message();
}

TEST(Validation, Fp64RefusedWhenTheDeviceLacksIt) {
  ValidationLimits limits;
  limits.fp64_available = false;
  EvaluateRequest r = GoodProbe();
  r.set_precision(v1::FP64);
  Status s = Validate(r, limits);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("FP64"), std::string::npos);
}

TEST(Validation, StreamIndicesAreGlobal) {
  EvaluateRequest r = GoodProbe();
  r.mutable_queries()->set_wo(4, 0.0f);  // query 1 of this chunk
  Status s = ValidateQueries(r.queries(), false, {}, 1000, true);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("queries.wo[1001]"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace glint

namespace glint {
namespace {

// A valid BINOMIAL request: uv, footprint, a sun-like directional light and a sphere light.
EvaluateRequest GoodBinomial() {
  EvaluateRequest r = GoodProbe(3);
  auto *m = r.mutable_material();
  m->set_model(v1::BINOMIAL);
  m->mutable_binomial()->set_density(1e6);
  auto *q = r.mutable_queries();
  q->clear_wi();
  for (int i = 0; i < 3; ++i) {
    for (float v : {0.5f, 0.25f}) q->add_uv(v);
    for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) q->add_footprint(v);
  }
  auto *d = r.add_lights()->mutable_directional();
  for (float v : {0.0f, 0.0f, 1.0f}) d->add_direction(v);
  for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
  d->set_cone_half_angle_deg(0.26f);
  auto *p = r.add_lights()->mutable_point();
  for (float v : {0.0f, 1.0f, 2.0f}) p->add_position(v);
  for (float v : {1.0f, 1.0f, 1.0f}) p->add_intensity(v);
  p->set_radius(0.1f);
  return r;
}

Status ValidateBinomial(const EvaluateRequest &r) {
  Status s = Validate(r);
  return s.ok() ? ValidateQueriesForModel(r.queries(), r) : s;
}

TEST(Validation, BinomialRefusalsNameTheFieldAndWhatIsNeeded) {
  Status ok = ValidateBinomial(GoodBinomial());
  EXPECT_TRUE(ok.ok()) << ok.message();
  const Case cases[] = {
      {"no binomial block",
       [](EvaluateRequest &r) { r.mutable_material()->clear_binomial(); },
       {"material.binomial: unset"}},
      {"zero density",
       [](EvaluateRequest &r) { r.mutable_material()->mutable_binomial()->set_density(0); },
       {"material.binomial.density: 0", "(0, 1e30]"}},
      {"nan density",
       [](EvaluateRequest &r) {
         r.mutable_material()->mutable_binomial()->set_density(std::nan(""));
       },
       {"material.binomial.density"}},
      {"unknown p_mode",
       [](EvaluateRequest &r) {
         r.mutable_material()->mutable_binomial()->set_p_mode(
             static_cast<v1::ReflectionProbability>(7));
       },
       {"material.binomial.p_mode: unknown value 7"}},
      {"negative r",
       [](EvaluateRequest &r) { r.mutable_material()->mutable_binomial()->set_r(-1); },
       {"material.binomial.r: -1"}},
      {"threshold out of range",
       [](EvaluateRequest &r) {
         r.mutable_material()->mutable_binomial()->set_normal_threshold(100);
       },
       {"material.binomial.normal_threshold: 100", "[1, 40]"}},
      {"unknown footprint_interpolation",
       [](EvaluateRequest &r) {
         r.mutable_material()->mutable_binomial()->set_footprint_interpolation(
             static_cast<v1::FootprintInterpolation>(9));
       },
       {"material.binomial.footprint_interpolation: unknown value 9", "TETRAHEDRAL"}},
      {"binomial block on a smooth material",
       [](EvaluateRequest &r) { r.mutable_material()->set_model(v1::SMOOTH); },
       {"material.binomial: set, but material.model is SMOOTH"}},
      {"directional light of zero size",
       [](EvaluateRequest &r) {
         r.mutable_lights(0)->mutable_directional()->set_cone_half_angle_deg(0);
       },
       {"lights[0].directional.cone_half_angle_deg: 0", "finite size"}},
      {"point light of zero radius",
       [](EvaluateRequest &r) { r.mutable_lights(1)->mutable_point()->set_radius(0); },
       {"lights[1].point.radius: 0", "finite"}},
      {"no uv",
       [](EvaluateRequest &r) { r.mutable_queries()->clear_uv(); },
       {"queries.uv: empty", "BINOMIAL"}},
      {"no footprint",
       [](EvaluateRequest &r) { r.mutable_queries()->clear_footprint(); },
       {"queries.footprint: empty", "BINOMIAL"}},
      {"probe",
       [](EvaluateRequest &r) {
         r.clear_lights();
         for (int i = 0; i < 3; ++i)
           for (float v : {0.0f, -0.6f, 0.8f}) r.mutable_queries()->add_wi(v);
       },
       {"queries.wi", "delta light"}},
  };
  for (const Case &c : cases) {
    EvaluateRequest r = GoodBinomial();
    c.mutate(r);
    Status s = ValidateBinomial(r);
    ASSERT_FALSE(s.ok()) << c.name;
    EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << c.name;
    for (const char *part : c.must_contain)
      EXPECT_NE(s.message().find(part), std::string::npos)
          << c.name << ": '" << s.message() << "' lacks '" << part << "'";
  }
  // HEURISTIC_R does not use the light's size: a zero cone is accepted.
  EvaluateRequest heuristic = GoodBinomial();
  heuristic.mutable_material()->mutable_binomial()->set_p_mode(v1::HEURISTIC_R);
  heuristic.mutable_lights(0)->mutable_directional()->set_cone_half_angle_deg(0);
  EXPECT_TRUE(ValidateBinomial(heuristic).ok());
}

// Issue 13: AUTO's budget max_relative_error is required with AUTO (finite, > 0), refused
// without AUTO and in a later stream chunk; AUTO picks its own sample counts.
TEST(Validation, AutoAreaMethodNeedsAFinitePositiveBudget) {
  EvaluateRequest good = GoodPolygon();
  good.set_area_method(v1::AUTO);
  good.set_max_relative_error(0.05f);
  EXPECT_TRUE(Validate(good).ok()) << Validate(good).message();

  const float inf = std::numeric_limits<float>::infinity();
  for (float bad : {0.0f, -0.05f, std::nanf(""), inf, -inf}) {
    EvaluateRequest r = good;
    r.set_max_relative_error(bad);
    Status s = Validate(r);
    EXPECT_FALSE(s.ok()) << bad;
    EXPECT_EQ(s.message().rfind("max_relative_error: ", 0), 0u) << s.message();
    EXPECT_NE(s.message().find("area_method AUTO needs the relative error allowed per query and "
                               "light, a finite number > 0"),
              std::string::npos)
        << s.message();
  }
  EvaluateRequest unset = good;
  unset.clear_max_relative_error();
  EXPECT_NE(Validate(unset).message().find("max_relative_error: 0.000000 (unset)"),
            std::string::npos)
      << Validate(unset).message();

  EvaluateRequest without_auto = good;
  without_auto.set_area_method(v1::LTC);
  EXPECT_NE(Validate(without_auto).message().find("only read with area_method AUTO"),
            std::string::npos)
      << Validate(without_auto).message();

  EvaluateRequest samples = good;
  samples.set_area_samples(64);
  EXPECT_NE(Validate(samples).message().find(
                "area_samples: 64 with area_method AUTO; AUTO picks its own sample counts"),
            std::string::npos)
      << Validate(samples).message();

  EvaluateRequest later;
  later.set_max_relative_error(0.05f);
  EXPECT_NE(ValidateLaterChunkSettings(later).message().find(
                "request.max_relative_error: max_relative_error 0.050000 in a chunk without a "
                "material"),
            std::string::npos)
      << ValidateLaterChunkSettings(later).message();
}

}  // namespace
}  // namespace glint

namespace glint {
namespace {

// The batch-wide fast acceptance of ValidateQueries (issue 12) never accepts what the documented
// per-query rule refuses: a length with |length - 1| > unit_tolerance, or a value that is not
// finite, anywhere in a large batch. The rule is evaluated here on its own (in double) for every
// float z within 40 ulps of the band's edges 1 +- tol, as query 700 of 1000 with wo = (0, 0, z).
TEST(Validation, FastAcceptanceAgreesWithThePerQueryRuleAtTheToleranceEdges) {
  const ValidationLimits limits;
  const double tol = limits.unit_tolerance;
  for (double edge : {1.0 + tol, 1.0 - tol}) {
    float z = std::nextafter(float(edge), 0.0f);
    for (int k = 0; k < 40; ++k) z = std::nextafter(z, 0.0f);
    for (int k = 0; k < 80; ++k, z = std::nextafter(z, 2.0f)) {
      EvaluateRequest r = GoodProbe(1000);
      auto *wo = r.mutable_queries()->mutable_wo();
      wo->Set(3 * 700 + 0, 0.0f);
      wo->Set(3 * 700 + 1, 0.0f);
      wo->Set(3 * 700 + 2, z);
      const bool rule = std::fabs(double(z) - 1.0) <= tol;
      const Status s = Validate(r, limits);
      EXPECT_EQ(s.ok(), rule) << "z = " << z << ": " << s.message();
      if (!rule) {
        EXPECT_NE(s.message().find("queries.wo[700]"), std::string::npos) << s.message();
      }
    }
  }
  const float inf = std::numeric_limits<float>::infinity();
  for (float bad : {std::nanf(""), inf, -inf}) {
    EvaluateRequest r = GoodProbe(1000);
    auto *q = r.mutable_queries();
    for (uint32_t i = 0; i < 1000; ++i) q->add_uv(0.5f), q->add_uv(0.5f);
    q->set_uv(2 * 999 + 1, bad);
    Status s = Validate(r, limits);
    EXPECT_FALSE(s.ok()) << bad;
    EXPECT_NE(s.message().find("queries.uv[999]"), std::string::npos) << s.message();
    r = GoodProbe(1000);
    r.mutable_queries()->mutable_wi()->Set(3 * 10 + 1, bad);
    s = Validate(r, limits);
    EXPECT_NE(s.message().find("queries.wi[10]"), std::string::npos) << s.message();
  }
}

}  // namespace
}  // namespace glint

namespace glint {
namespace {

// The fast acceptance scan of unit arrays works on four vectors at a time (SSE) and a scalar
// tail: a bad vector at any position (each lane of each block of four, and the tail) in wo or
// wi, too long, too short, NaN or infinite in any component, is refused naming that query; so is
// a NaN or an infinity anywhere in uv or footprint.
TEST(Validation, FastScanFindsABadVectorAtEveryPosition) {
  const uint32_t n = 23;  // five blocks of four vectors and a tail of three
  ASSERT_TRUE(Validate(GoodProbe(n)).ok());
  const float inf = std::numeric_limits<float>::infinity();
  for (bool wi : {false, true}) {
    for (uint32_t i = 0; i < n; ++i) {
      for (float scale : {1.01f, 0.99f, std::nanf(""), inf}) {
        EvaluateRequest r = GoodProbe(n);
        auto *a = wi ? r.mutable_queries()->mutable_wi() : r.mutable_queries()->mutable_wo();
        const int c = int(i % 3);
        a->Set(int(3 * i) + c, a->Get(int(3 * i) + c) * scale);
        if (a->Get(int(3 * i) + c) == 0.0f) a->Set(int(3 * i) + c, scale);  // 0 * scale
        const Status s = Validate(r);
        const std::string want =
            std::string(wi ? "queries.wi[" : "queries.wo[") + std::to_string(i) + "]";
        EXPECT_FALSE(s.ok()) << want << " x " << scale;
        EXPECT_EQ(s.message().rfind(want, 0), 0u) << s.message();
      }
    }
  }
  // The finiteness scan of the other arrays (four floats at a time and a tail): uv has 46
  // floats, footprint 92; a NaN or an infinity in any of them is refused naming its query.
  for (bool footprint : {false, true}) {
    const int per = footprint ? 4 : 2;
    for (int k = 0; k < int(n) * per; ++k) {
      for (float bad : {std::nanf(""), inf, -inf}) {
        EvaluateRequest r = GoodProbe(n);
        auto *a = footprint ? r.mutable_queries()->mutable_footprint()
                            : r.mutable_queries()->mutable_uv();
        for (int j = 0; j < int(n) * per; ++j) a->Add(0.25f);
        a->Set(k, bad);
        const Status s = Validate(r);
        const std::string want = std::string(footprint ? "queries.footprint[" : "queries.uv[") +
                                 std::to_string(k / per) + "]";
        EXPECT_EQ(s.message().rfind(want, 0), 0u) << s.message();
      }
    }
  }
}

}  // namespace
}  // namespace glint
