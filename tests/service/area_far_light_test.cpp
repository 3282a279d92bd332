// Polygon lights far from (or very near to) the shading point, for every area method (LTC,
// LECOCQ, LECOCQ_PEARSON, MONTE_CARLO, REFERENCE, AUTO) and every model that shades polygon
// lights through them (SMOOTH; BINOMIAL, KEMPPINEN and CHERMAIN per light, polygon_lights.h and
// binomial_eval.h), on the fp32 device and the fp32 and fp64 host path (issue 13). Before the
// loader's power-of-two rescale (kernels/area/polygon_scale.h, area_polygon_load_n in area_ltc.h)
// all of these but the smooth model's LTC pass gave 0 in fp32 at >= 1e20 and below ~1e-19.
//
// The identity checked is scale invariance, independent of any method's formula: each method's
// result depends only on the directions of the vertices relative to the shading point (its
// integrand lives on the sphere of directions), so a light F at distance d and its copy
// N = 2^-k F at distance ~1 (k = round(log2 d); the multiplication by 2^-k is exact) subtend the
// same solid angle, direction for direction. The rescale multiplies F's vertices by a power of
// two, again exactly, after which every step of every method is homogeneous (products, ratios,
// comparisons with 0) or normalises: the radiance of F must equal that of N bit for bit, up to
// no rounding at all. MONTE_CARLO and AUTO included: the queries carry no position (the shading
// point is the origin), so the random-number key (the seed and the query's wo,
// area_query_key) is the same for F and N, the same samples are drawn and, the vertices being
// the same up to a power of two, they are the same directions. d in {1e-25, 1e-20, 1e20, 1e30}
// (F's vertices are d times a quad's, rounded to float: the light at d). Every output is also
// finite and non-negative, and the comparison must see light (some lit values: glints are sparse).
//
// Second identity, the fp32 overflow of q - p: a shading point at -2^127 and a light beyond
// +2^127 (world coordinates of opposite sign whose difference exceeds FLT_MAX) with world
// frames: the loader reloads such vertices from coordinates times 2^-32 (exact), so the light
// gives what the same configuration scaled by 2^-127 gives, bit for bit (deterministic methods:
// MONTE_CARLO's key absorbs the position, which differs between the two; its scale invariance
// with one key is checked in tests/area/polygon_scale_test.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "model_test_settings.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/model_table.h"
#include "server/validation.h"
#include "test_queries.h"
#include "tests/support/device_engine_fixture.h"

namespace glint {
namespace {

using glint::v1::EvaluateRequest;

class AreaFarLight : public test::DeviceEngineTest {
 protected:
  // The radiance of `r` for `q` on the device or the host path, after the server's validation.
  static std::vector<float> Run(const EvaluateRequest &r, const v1::QueryBatch &q, bool device) {
    Status s = ValidateSettings(r, {});
    EXPECT_TRUE(s.ok()) << s.message();
    s = ValidateQueries(q, true, {});
    EXPECT_TRUE(s.ok()) << s.message();
    const EvalPlan plan = MakeEvalPlan(r, q);
    std::vector<float> out(3 * q.count(), -1.0f);
    if (device) {
      s = engine_->Evaluate(0, plan, q, out.data());
      EXPECT_TRUE(s.ok()) << s.message();
    } else {
      HostEvaluate(plan, q, out.data());
    }
    return out;
  }
};

struct Method {
  v1::AreaMethod method;
  int samples;  // area_samples (AUTO: 0, with max_relative_error)
  const char *name;
};
const Method kMethods[] = {{v1::LTC, 0, "LTC"},
                           {v1::LECOCQ, 0, "LECOCQ"},
                           {v1::LECOCQ_PEARSON, 0, "LECOCQ_PEARSON"},
                           {v1::MONTE_CARLO, 16, "MONTE_CARLO"},
                           {v1::REFERENCE, 8, "REFERENCE"},
                           {v1::AUTO, 0, "AUTO"}};

// The models that shade polygon lights through the request's area method. NORMAL_MAP (its own
// estimator over an uploaded map, Model::request_table) receives the polygon through the same
// loader (normal_map_polygons.h); its map needs a store, so it is left to the loader's own test.
std::vector<const Model *> AreaModels() {
  std::vector<const Model *> out;
  for (const Model *m : Models())
    if (!m->request_table) out.push_back(m);
  return out;
}

// The model's test settings (its example parameters) with only `polygons` as lights.
EvaluateRequest Settings(const Model *model, const Method &method, bool fp64,
                         const std::vector<std::vector<double>> &polygons) {
  EvaluateRequest r = test::ModelTestSettings(model->id, false);
  r.clear_lights();
  for (size_t l = 0; l < polygons.size(); ++l) {
    auto *p = r.add_lights()->mutable_polygon();
    for (double v : polygons[l]) p->add_vertices(float(v));
    for (float v : {1.0f, 0.7f, 0.4f}) p->add_radiance(v);
    p->set_two_sided(l == 1);
  }
  r.set_area_method(method.method);
  r.set_area_samples(method.samples);
  if (method.method == v1::AUTO) r.set_max_relative_error(0.05f);
  r.set_precision(fp64 ? v1::FP64 : v1::FP32);
  return r;
}

// Every value finite and >= 0; returns how many are > 0.
int CheckFiniteNonNegative(const std::vector<float> &out, const std::string &what) {
  int lit = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    EXPECT_TRUE(std::isfinite(out[i]) && out[i] >= 0.0f)
        << what << " query " << i / 3 << " channel " << i % 3 << ": " << out[i];
    lit += out[i] > 0.0f;
  }
  return lit;
}

// A one-sided quad overhead (the facing test's cube overflowed first) and a two-sided quad
// standing across the horizon (the clip paths), at distance ~3 from the origin.
const std::vector<double> kOverhead = {-1, -1, 3, 1, -1, 3, 1, 1, 3, -1, 1, 3};
const std::vector<double> kAcross = {2.5, -1, -0.5, 2.5, 1, -0.5, 2.5, 1, 1.5, 2.5, -1, 1.5};

TEST_F(AreaFarLight, FarAndNearLightsGiveTheRadianceOfTheSameLightAtDistanceOne) {
  // The lights in the local frame and the shading point at the origin, in two forms. Unframed
  // queries on the host path, in fp32 and fp64. On the device (fp32) the same queries with an
  // identity world frame at the origin (normal +z, tangent +x, position 0: world coordinates
  // are local ones, exactly): that is the kernel variant the test below builds (framed, fp32,
  // the same materials and polygon lights only), so each model's variant is built once for both
  // tests (the kernel cache; RESOURCE_LOCK in CMakeLists.txt keeps the two tests from building
  // it at the same time) instead of an unframed variant here and a framed one below, about
  // half of this binary's time with a cold cache. What the unframed device variant ran differs
  // from the framed one only in the frame transform (absent): the polygon loader and every
  // area method are the same code in both, and the unframed form still runs on the host path,
  // the same kernel headers compiled as C++.
  const v1::QueryBatch unframed = test::RandomQueries(64, false, false, 17);
  v1::QueryBatch identity_frame = unframed;
  for (uint32_t i = 0; i < unframed.count(); ++i) {
    for (float v : {0.0f, 0.0f, 0.0f}) identity_frame.add_position(v);
    for (float v : {0.0f, 0.0f, 1.0f}) identity_frame.add_normal(v);
    for (float v : {1.0f, 0.0f, 0.0f}) identity_frame.add_tangent(v);
  }
  struct Engine {
    bool fp64, device;
  };
  for (const Model *model : AreaModels()) {
    for (const Method &method : kMethods) {
      for (const Engine e : {Engine{false, true}, Engine{false, false}, Engine{true, false}}) {
        const bool fp64 = e.fp64, device = e.device;
        const v1::QueryBatch &q = device ? identity_frame : unframed;
        for (double d : {1e-25, 1e-20, 1e20, 1e30}) {
          // F: the quads at distance ~3 d, rounded to float (the light at d). N = 2^-k F.
          const int k = int(std::lround(std::log2(d)));
          std::vector<std::vector<double>> far, near;
          for (const auto *base : {&kOverhead, &kAcross}) {
            std::vector<double> f, n;
            for (double v : *base) {
              f.push_back(double(float(v * d)));
              n.push_back(std::ldexp(f.back(), -k));
            }
            far.push_back(f);
            near.push_back(n);
          }
          const std::string what = std::string(model->name) + " " + method.name + " fp" +
                                   (fp64 ? "64" : "32") + (device ? " device" : " host") + " d " +
                                   std::to_string(d);
          const std::vector<float> at_one = Run(Settings(model, method, fp64, near), q, device);
          const std::vector<float> at_d = Run(Settings(model, method, fp64, far), q, device);
          const int lit = CheckFiniteNonNegative(at_one, what + " (at distance 1)");
          CheckFiniteNonNegative(at_d, what);
          ASSERT_GE(lit, 12) << what << ": the comparison must see light";
          for (size_t i = 0; i < at_d.size(); ++i)
            ASSERT_EQ(at_d[i], at_one[i]) << what << " query " << i / 3 << " channel " << i % 3;
        }
      }
    }
  }
}

TEST_F(AreaFarLight, Fp32DifferencesBeyondFloatMaxAreRescaledNotLost) {
  // World frames at the origin scaled by 2^e: the shading point at -(1, 0.5, 0.75) 2^e and the
  // quads around +(1.5, 0.5, 1.25) 2^e (dyadic, below 2: exact floats at every e <= 127). At
  // e = 127 the world differences reach ~2.9 2^127 > FLT_MAX in x; e = 0 is the same
  // configuration at distance ~3.
  const v1::QueryBatch base = test::RandomQueries(64, false, true, 23);
  auto queries = [&](int e) {
    v1::QueryBatch q = base;
    const double p[3] = {-1, -0.5, -0.75};
    for (int i = 0; i < int(q.count()); ++i)
      for (int c = 0; c < 3; ++c) q.set_position(3 * i + c, float(std::ldexp(p[c], e)));
    return q;
  };
  const std::vector<double> quad = {1.125, 0.125, 1.25, 1.875, 0.125, 1.25,
                                    1.875, 0.875, 1.25, 1.125, 0.875, 1.25};
  const std::vector<double> side = {1.5, 0.125, 0.5,  1.5, 0.875, 0.5,
                                    1.5, 0.875, 1.75, 1.5, 0.125, 1.75};
  auto lights = [&](int e) {
    std::vector<std::vector<double>> out;
    for (const auto *b : {&quad, &side}) {
      std::vector<double> v;
      for (double x : *b) v.push_back(std::ldexp(x, e));
      out.push_back(v);
    }
    return out;
  };
  const v1::QueryBatch q0 = queries(0), q127 = queries(127);
  for (const Model *model : AreaModels()) {
    for (const Method &method : kMethods) {
      // MONTE_CARLO's key absorbs the position (AUTO may pick MONTE_CARLO): another stream.
      if (method.method == v1::MONTE_CARLO || method.method == v1::AUTO) continue;
      for (bool fp64 : {false, true}) {
        for (bool device : {true, false}) {
          if (fp64 && device) continue;  // fp64 never overflowed; its host path suffices
          const std::string what = std::string(model->name) + " " + method.name +
                                   (fp64 ? " fp64" : " fp32") + (device ? " device" : " host");
          const std::vector<float> at_one =
              Run(Settings(model, method, fp64, lights(0)), q0, device);
          const std::vector<float> at_max =
              Run(Settings(model, method, fp64, lights(127)), q127, device);
          const int lit = CheckFiniteNonNegative(at_one, what + " (at distance ~3)");
          CheckFiniteNonNegative(at_max, what);
          ASSERT_GE(lit, 12) << what << ": the comparison must see light";
          for (size_t i = 0; i < at_max.size(); ++i)
            ASSERT_EQ(at_max[i], at_one[i]) << what << " query " << i / 3 << " channel " << i % 3;
        }
      }
    }
  }
}

}  // namespace
}  // namespace glint
