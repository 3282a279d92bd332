// Polygon lights on the NORMAL_MAP model (models/normal_map/normal_map_polygons.h: multiple
// importance sampling of light and P-NDF sampling) against an independent Monte Carlo
// reference: points uniform on the light's area, each a probe of the model's f cos_i
// (HostEvaluate with queries.wi, fp64), weighted by cos_l / r^2 (dw = cos_l dA / r^2).
// The MIS estimate's standard error comes from 16 independent seeds, the reference's from its
// sample variance; the tolerance is 4.5 standard errors of the difference plus the bias bound
// of the MIS estimate (its P-NDF samples come from the unpruned density, its pdf from D pruned at
// cutoff_sigma: |bias| <= int_P |D - D_pruned| F G / (4 wo.z) dw_i (Eq. 1 with the change of
// variables) <= (4 Phi(-c) + e^{-c^2/2}) / (2 pi sigma_r^2) [the pruning bound of
// normal_map_pndf_test] x Omega / (4 wo.z), Omega the light's solid angle above the horizon).
// The device (OpenCL, fp32) agrees within the same tolerance and is bit-identical however the
// batch is split.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/normal_map_store.h"
#include "server/validation.h"

namespace glint {
namespace {

using glint::v1::EvaluateRequest;
constexpr double kPi = 3.14159265358979323846;

struct Vec {
  double x, y, z;
};
Vec Add(Vec a, Vec b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
Vec Scale(Vec a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
double Dot(Vec a, Vec b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
Vec Cross(Vec a, Vec b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec Normalize(Vec a) {
  return Scale(a, 1.0 / std::sqrt(Dot(a, a)));
}

DecodedNormalMap Bumps(uint32_t w, uint32_t h, double amplitude) {
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

// A rectangle light: centre c, half-edges e1, e2 (two-sided, unit radiance).
struct Rect {
  Vec c, e1, e2;
  Vec Corner(int k) const {
    const double a = (k == 0 || k == 3) ? -1 : 1, b = k < 2 ? -1 : 1;
    return Add(c, Add(Scale(e1, a), Scale(e2, b)));
  }
};

struct Case {
  std::string name;
  float sigma_r;
  Vec wo;  // float-rounded
  float uv[2];
  float footprint[4];
  Rect light;
};

Vec WoAt(double theta_deg, double phi_deg) {
  const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
  return {float(std::sin(t) * std::cos(p)), float(std::sin(t) * std::sin(p)), float(std::cos(t))};
}

// A square of half-size `half` at distance `dist` in the mirror direction of wo, facing it.
Rect MirrorSquare(Vec wo, double dist, double half) {
  const Vec d = Normalize({-wo.x, -wo.y, wo.z});
  const Vec e1 = Normalize(Cross(d, {0, 0, 1}));
  const Vec e2 = Cross(d, e1);
  return {Scale(d, dist), Scale(e1, half), Scale(e2, half)};
}

// A square of half-size `half` at distance `dist` in the mirror direction of wo about the normal
// of vertex (i, j) of Bumps(8, 8, 0.2): where a footprint on that vertex glints.
Rect GlintSquare(Vec wo, int i, int j, double dist, double half) {
  const double sx = 0.2 * std::sin(2 * kPi * (i + 0.3 * j) / 8);
  const double sy = 0.2 * std::cos(2 * kPi * (2.0 * j + 0.5 * i) / 8);
  const Vec n = Normalize({sx, sy, 1.0});
  const Vec d = Add(Scale(n, 2 * Dot(wo, n)), Scale(wo, -1));
  const Vec e1 = Normalize(Cross(d, {0, 0, 1}));
  const Vec e2 = Cross(d, e1);
  return {Scale(d, dist), Scale(e1, half), Scale(e2, half)};
}

class NormalMapPolygonTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    v1::NormalMapInfo info;
    ASSERT_TRUE(NormalMaps().Insert("bumps", Bumps(8, 8, 0.2), &info).ok());
    digest_ = info.digest();
  }

  static EvaluateRequest Request(const Case &c, uint64_t seed, uint32_t samples,
                                 v1::Precision precision) {
    EvaluateRequest r;
    auto *m = r.mutable_material();
    m->set_model(v1::NORMAL_MAP);
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
    m->mutable_normal_map()->set_digest(digest_);
    m->mutable_normal_map()->set_intrinsic_roughness(c.sigma_r);
    auto *p = r.add_lights()->mutable_polygon();
    for (int k = 0; k < 4; ++k) {
      const Vec v = c.light.Corner(k);
      for (double x : {v.x, v.y, v.z}) p->add_vertices(float(x));
    }
    for (float x : {1.0f, 1.0f, 1.0f}) p->add_radiance(x);
    p->set_two_sided(true);
    r.set_area_samples(samples);
    r.set_seed(seed);
    r.set_precision(precision);
    AddQuery(c, r.mutable_queries());
    return r;
  }
  static void AddQuery(const Case &c, v1::QueryBatch *q, const Vec *wi = nullptr) {
    q->set_count(q->count() + 1);
    for (double v : {c.wo.x, c.wo.y, c.wo.z}) q->add_wo(float(v));
    for (float v : c.uv) q->add_uv(v);
    for (float v : c.footprint) q->add_footprint(v);
    if (wi)
      for (double v : {wi->x, wi->y, wi->z}) q->add_wi(float(v));
  }
  static std::vector<float> Eval(const EvaluateRequest &r, DeviceEngine *engine = nullptr) {
    Status s = ValidateSettings(r, {});
    EXPECT_TRUE(s.ok()) << s.message();
    EvalPlan plan = MakeEvalPlan(r, r.queries());
    EXPECT_TRUE(ResolveRequestTable(r.material(), &plan).ok());
    std::vector<float> out(3 * r.queries().count(), -1.0f);
    if (engine) {
      s = engine->Evaluate(0, plan, r.queries(), out.data());
      EXPECT_TRUE(s.ok()) << s.message();
    } else {
      HostEvaluate(plan, r.queries(), out.data());
    }
    return out;
  }

  // Mean and standard error of the MIS estimate over 16 seeds.
  static void Mis(const Case &c, uint32_t samples, v1::Precision precision, DeviceEngine *engine,
                  std::array<double, 3> *mean, std::array<double, 3> *se) {
    const int seeds = 16;
    std::array<double, 3> sum{0, 0, 0}, sum2{0, 0, 0};
    for (int k = 0; k < seeds; ++k) {
      const auto out = Eval(Request(c, 1000 + uint64_t(k), samples, precision), engine);
      for (size_t ch = 0; ch < 3; ++ch) {
        sum[ch] += out[ch];
        sum2[ch] += double(out[ch]) * out[ch];
      }
    }
    for (size_t ch = 0; ch < 3; ++ch) {
      (*mean)[ch] = sum[ch] / seeds;
      (*se)[ch] =
          std::sqrt(std::max(0.0, sum2[ch] / seeds - (*mean)[ch] * (*mean)[ch]) / (seeds - 1));
    }
  }

  // The reference: n points uniform on the light, probes of f cos_i, times A cos_l / r^2.
  // *omega: the light's solid angle above the horizon (the same points: mean of the factor), plus
  // 4.5 of its standard errors (an upper bound for the bias bound).
  static void Reference(const Case &c, int n, std::array<double, 3> *mean,
                        std::array<double, 3> *se, double *omega) {
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    EvaluateRequest settings = Request(c, 0, 0, v1::FP64);
    settings.clear_lights();
    settings.clear_queries();
    const Vec nl = Normalize(Cross(c.light.e1, c.light.e2));
    const double area =
        4 * std::sqrt(Dot(Cross(c.light.e1, c.light.e2), Cross(c.light.e1, c.light.e2)));
    v1::QueryBatch q;
    std::vector<double> factor;
    for (int k = 0; k < n; ++k) {
      const Vec p = Add(c.light.c, Add(Scale(c.light.e1, u(rng)), Scale(c.light.e2, u(rng))));
      const double r2 = Dot(p, p);
      const Vec wi = Scale(p, 1 / std::sqrt(r2));
      factor.push_back(wi.z > 0 ? area * std::fabs(Dot(nl, wi)) / r2 : 0.0);
      const Vec probe = wi.z > 0 ? wi : Vec{0, 0, 1};
      AddQuery(c, &q, &probe);
    }
    const EvalPlan plan = MakeEvalPlan(settings, q);
    std::vector<float> rgb(3 * size_t(q.count()));
    HostEvaluate(plan, q, rgb.data());
    double fs = 0, fs2 = 0;
    for (double f : factor) {
      fs += f;
      fs2 += f * f;
    }
    *omega = fs / n + 4.5 * std::sqrt(std::max(0.0, fs2 / n - (fs / n) * (fs / n)) / (n - 1));
    for (size_t ch = 0; ch < 3; ++ch) {
      double sum = 0, sum2 = 0;
      for (int k = 0; k < n; ++k) {
        const double v = rgb[3 * size_t(k) + ch] * factor[size_t(k)];
        sum += v;
        sum2 += v * v;
      }
      (*mean)[ch] = sum / n;
      (*se)[ch] = std::sqrt(std::max(0.0, sum2 / n - (*mean)[ch] * (*mean)[ch]) / (n - 1));
    }
  }

  // The MIS estimate's bias bound (header comment) for a light of solid angle omega.
  static double BiasBound(const Case &c, double omega) {
    const double cut = 5.0;
    const double phi = 0.5 * std::erfc(cut / std::sqrt(2.0));
    const double d = (4 * phi + std::exp(-cut * cut / 2)) / (2 * kPi * c.sigma_r * c.sigma_r);
    return d * omega / (4 * c.wo.z);
  }

  static void Expect(const Case &c, const std::array<double, 3> &mis,
                     const std::array<double, 3> &mis_se, const std::array<double, 3> &ref,
                     const std::array<double, 3> &ref_se, double omega, const std::string &what) {
    for (size_t ch = 0; ch < 3; ++ch) {
      const double tol = 4.5 * std::hypot(mis_se[ch], ref_se[ch]) + BiasBound(c, omega);
      std::printf("%s %s ch %zu: MIS %.5f +- %.5f, reference %.5f +- %.5f (tolerance %.5f)\n",
                  c.name.c_str(), what.c_str(), ch, mis[ch], mis_se[ch], ref[ch], ref_se[ch], tol);
      EXPECT_NEAR(mis[ch], ref[ch], tol) << c.name << " " << what << " channel " << ch;
    }
  }

  static std::string digest_;
};
std::string NormalMapPolygonTest::digest_;

std::vector<Case> Cases() {
  const Vec wo1 = WoAt(30, 20), wo2 = WoAt(50, 200), wo3 = WoAt(70, 45);
  return {
      // A large square (about 0.7 rad across) over the whole specular lobe.
      {"large light",
       0.03f,
       wo1,
       {0.37f, 0.61f},
       {0.05f, 0.01f, -0.01f, 0.06f},
       MirrorSquare(wo1, 2.0, 0.75)},
      // A small square (0.05 rad) on the glint of a footprint at vertex (1, 6): light sampling
      // carries it.
      {"small light",
       0.03f,
       wo2,
       {1.5f / 8, 6.5f / 8},
       {0.05f, 0.0f, 0.0f, 0.05f},
       GlintSquare(wo2, 1, 6, 2.0, 0.05)},
      // A light straddling the horizon (clipped), grazing view.
      {"clipped light",
       0.05f,
       wo3,
       {0.7f, 0.2f},
       {0.1f, 0.0f, 0.0f, 0.1f},
       {{-1.5, -1.5, 0.2}, {1.0, -1.0, 0.0}, {0.0, 0.0, 0.8}}},
  };
}

TEST_F(NormalMapPolygonTest, MisMatchesUniformLightSamplingOfTheProbe) {
  for (const Case &c : Cases()) {
    std::array<double, 3> mis, mis_se, ref, ref_se;
    double omega = 0;
    Mis(c, 256, v1::FP64, nullptr, &mis, &mis_se);
    Reference(c, 40000, &ref, &ref_se, &omega);
    ASSERT_GT(ref[0], 10 * ref_se[0]) << c.name << ": a case without light tests nothing";
    Expect(c, mis, mis_se, ref, ref_se, omega, "host fp64");
  }
}

TEST_F(NormalMapPolygonTest, DeviceAgreesAndIsSplitInvariant) {
  DeviceEngineOptions o;
  const char *cache = std::getenv("GLINT_CACHE_DIR");
  o.cache_dir = cache ? cache : "";
  o.workers = 1;
  std::unique_ptr<DeviceEngine> engine;
  Status s = DeviceEngine::Create(o, &engine);
  ASSERT_TRUE(s.ok()) << s.message();
  const std::vector<Case> cases = Cases();
  const Case &c = cases[0];
  std::array<double, 3> mis, mis_se, ref, ref_se;
  double omega = 0;
  Mis(c, 256, v1::FP32, engine.get(), &mis, &mis_se);
  Reference(c, 40000, &ref, &ref_se, &omega);
  Expect(c, mis, mis_se, ref, ref_se, omega, "device fp32");
  // Three queries at once (case 0's material and light) against each alone: bit-identical.
  EvaluateRequest all = Request(c, 7, 64, v1::FP32);
  for (int i = 1; i < 3; ++i) AddQuery(cases[size_t(i)], all.mutable_queries());
  const auto together = Eval(all, engine.get());
  for (int i = 0; i < 3; ++i) {
    Case one = cases[size_t(i)];
    one.sigma_r = c.sigma_r;
    one.light = c.light;
    const auto alone = Eval(Request(one, 7, 64, v1::FP32), engine.get());
    for (int ch = 0; ch < 3; ++ch) EXPECT_EQ(alone[size_t(ch)], together[size_t(3 * i + ch)]);
  }
}

}  // namespace
}  // namespace glint
