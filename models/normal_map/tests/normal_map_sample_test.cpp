// The NORMAL_MAP model's Sample RPC (models/normal_map/normal_map_sample.h) against independent
// references:
//  - the pdf returned with every sample is the evaluated P-NDF's, D(s) h.z / (4 wo.h), computed
//    here from the kernel's nm_pndf in double (the closed-form triangle integrals of Eq. 8-11,
//    not the sampler's footprint-point / interpolation / perturbation path);
//  - chi-square: the histogram of the sampled half-vectors' slopes (s, t) against the bin
//    integrals of D (midpoint rule, 8 x 8 nodes per bin of 1.7 sigma_r), with everything
//    outside the grid or null as one more category; threshold the chi-square quantile at
//    p = 1e-4 (boost.math);
//  - the mean weight against a brute-force quadrature of the probe path's f cos_i
//    (HostEvaluate with queries.wi) over the hemisphere, written as an integral over the
//    slope disk (dw_i = 4 (wo.h) / h.z ds dt), within 4.5 standard errors plus the quadrature's
//    error (the difference from the rule at half the resolution);
//  - the device (OpenCL, fp32, with the map's table bound) gives the same mean weight, and its
//    samples are bit-identical however the batch is split.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/normal_map_store.h"
#include "server/sample.h"
#include "tests/support/kernels_both_precisions.h"

namespace glint {
namespace {

using glint::v1::SampleRequest;
using glint::v1::SampleResponse;
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
Vec Normalize(Vec a) {
  return Scale(a, 1.0 / std::sqrt(Dot(a, a)));
}
Vec Reflect(Vec wo, Vec h) {
  return Add(Scale(h, 2 * Dot(wo, h)), Scale(wo, -1));
}

// Bumps with slopes up to ~0.2 (the engine test's map).
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

struct Case {
  std::string name;
  float sigma_r;
  Vec wo;
  float uv[2];
  float footprint[4];
};

class NormalMapSampleTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    v1::NormalMapInfo info;
    ASSERT_TRUE(NormalMaps().Insert("bumps", Bumps(8, 8, 0.2), &info).ok());
    digest_ = info.digest();
    ASSERT_TRUE(NormalMaps().Table(digest_, 1, &table_).ok());
  }

  static v1::Material Material(const Case &c) {
    v1::Material m;
    m.set_model(v1::NORMAL_MAP);
    for (float f : {0.9f, 0.6f, 0.3f}) m.mutable_schlick()->add_f0(f);
    m.mutable_normal_map()->set_digest(digest_);
    m.mutable_normal_map()->set_intrinsic_roughness(c.sigma_r);
    return m;
  }
  static void AddQuery(const Case &c, v1::QueryBatch *q, const Vec *wi = nullptr) {
    q->set_count(q->count() + 1);
    for (double v : {c.wo.x, c.wo.y, c.wo.z}) q->add_wo(float(v));
    for (float v : c.uv) q->add_uv(v);
    for (float v : c.footprint) q->add_footprint(v);
    if (wi)
      for (double v : {wi->x, wi->y, wi->z}) q->add_wi(float(v));
  }
  static SampleRequest Request(const Case &c, uint32_t k, v1::Precision precision = v1::FP64) {
    SampleRequest r;
    *r.mutable_material() = Material(c);
    AddQuery(c, r.mutable_queries());
    r.set_samples_per_query(k);
    r.set_seed(11);
    r.set_precision(precision);
    return r;
  }
  static SampleResponse Run(const SampleRequest &r, DeviceEngine *engine = nullptr) {
    SampleResponse out;
    Status s = RunSample(engine, 0, r, ValidationLimits{}, &out);
    EXPECT_TRUE(s.ok()) << s.message();
    return out;
  }
  // D(s, t) of the case's footprint from the kernel header in double (what the pdf must be).
  static double D(const Case &c, double s, double t) {
    const double fp[4] = {c.footprint[0], c.footprint[1], c.footprint[2], c.footprint[3]};
    k64::NmStats stats{};
    return k64::nm_pndf(table_->data(), c.uv[0], c.uv[1], fp, s, t, c.sigma_r, 5.0, &stats);
  }
  // pdf(wi) = D(h) h.z / (4 wo.h), 0 where no sample lands (wo.h <= 0).
  static double Pdf(const Case &c, Vec wi) {
    const Vec wo = Normalize(c.wo);
    const Vec h = Normalize(Add(wi, wo));
    const double oh = Dot(wo, h);
    if (!(oh > 0) || !(h.z > 0)) return 0.0;
    return D(c, h.x, h.y) * h.z / (4 * oh);
  }

  static std::string digest_;
  static NormalMapTable table_;
};
std::string NormalMapSampleTest::digest_;
NormalMapTable NormalMapSampleTest::table_;

// Rounded to float, as the queries carry it.
Vec WoAt(double theta_deg, double phi_deg) {
  const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
  return {float(std::sin(t) * std::cos(p)), float(std::sin(t) * std::sin(p)), float(std::cos(t))};
}

const Case kCases[] = {
    // sigma_p about 1.2 texels: a few bumps, several lobes.
    {"footprint 1 texel", 0.03f, WoAt(30, 20), {0.37f, 0.61f}, {0.3f, 0.05f, -0.04f, 0.25f}},
    // A sub-texel footprint and a sharp G_r: one glint.
    {"sharp", 0.02f, WoAt(50, 200), {0.12f, 0.83f}, {0.02f, 0.0f, 0.0f, 0.03f}},
    // Beyond one period: the global NDF (large-footprint limit, uniform footprint points).
    {"whole map", 0.03f, WoAt(10, 90), {0.5f, 0.5f}, {3.0f, 0.0f, 0.0f, 3.0f}},
};

TEST_F(NormalMapSampleTest, ReturnedPdfIsTheEvaluatedPndfAndChiSquareMatches) {
  for (const Case &c : kCases) {
    SCOPED_TRACE(c.name);
    constexpr uint32_t kSamples = 16384;
    const SampleResponse resp = Run(Request(c, kSamples));
    ASSERT_EQ(resp.pdf_size(), int(kSamples));
    const Vec wo = Normalize(c.wo);
    // Bins of the slope (s, t) over [-L, L]^2, n x n.
    const double L = 0.45;
    const int n = 18;
    const double bw = 2 * L / n;
    std::vector<double> observed(size_t(n * n) + 1, 0.0);
    int mismatch = 0, checked = 0;
    for (uint32_t k = 0; k < kSamples; ++k) {
      const float p = resp.pdf(int(k));
      const Vec w{resp.wi(3 * int(k)), resp.wi(3 * int(k) + 1), resp.wi(3 * int(k) + 2)};
      if (p == 0.0f) {
        observed.back() += 1;
        continue;
      }
      // wi comes back rounded to float: the pdf function over that rounding's neighbourhood
      // (+-2 ulp per component, first order) must bracket the returned value (itself rounded).
      if (checked < 300) {
        double lo = Pdf(c, Normalize(w)), hi = lo;
        for (int axis = 0; axis < 3; ++axis)
          for (double sign : {-1.0, 1.0}) {
            Vec d = w;
            double *comp = axis == 0 ? &d.x : axis == 1 ? &d.y : &d.z;
            *comp += sign * (std::fabs(*comp) * 2.4e-7 + 1e-30);
            const double v = Pdf(c, Normalize(d));
            lo = std::min(lo, v);
            hi = std::max(hi, v);
          }
        if (!(p >= lo * (1 - 2.4e-7) && p <= hi * (1 + 2.4e-7)) && ++mismatch <= 3)
          std::printf("pdf mismatch: returned %.9g, function in [%.9g, %.9g]\n", p, lo, hi);
        ++checked;
      }
      const Vec h = Normalize(Add(Normalize(w), wo));
      const int bx = int(std::floor((h.x + L) / bw)), by = int(std::floor((h.y + L) / bw));
      if (bx < 0 || by < 0 || bx >= n || by >= n) {
        observed.back() += 1;
      } else {
        observed[size_t(by * n + bx)] += 1;
      }
    }
    EXPECT_EQ(mismatch, 0) << "of " << checked;
    // Expected: int_bin D(s) [wo.h(s) > 0] ds by the midpoint rule, 6 x 6 nodes per bin
    // (spacing <= sigma_r / 3: relative error ~ (1/3)^2 / 24 = 0.5%, far below the counts'
    // statistical error sqrt(e) / e at these sample sizes).
    std::vector<double> expected(observed.size(), 0.0);
    double inside = 0;
    const int m = 6;
    for (int by = 0; by < n; ++by)
      for (int bx = 0; bx < n; ++bx) {
        double sum = 0;
        for (int a = 0; a < m; ++a)
          for (int b = 0; b < m; ++b) {
            const double s = -L + (bx + (a + 0.5) / m) * bw, t = -L + (by + (b + 0.5) / m) * bw;
            const double hz = std::sqrt(std::max(0.0, 1 - s * s - t * t));
            if (Dot(wo, {s, t, hz}) > 0) sum += D(c, s, t);
          }
        expected[size_t(by * n + bx)] = sum * (bw / m) * (bw / m);
        inside += expected[size_t(by * n + bx)];
      }
    expected.back() = std::max(0.0, 1.0 - inside);
    double chi2 = 0, pooled_o = 0, pooled_e = 0;
    int categories = 0;
    for (size_t b = 0; b < expected.size(); ++b) {
      const double e = expected[b] * kSamples;
      if (e < 5.0) {
        pooled_o += observed[b];
        pooled_e += e;
        continue;
      }
      chi2 += (observed[b] - e) * (observed[b] - e) / e;
      ++categories;
    }
    if (pooled_e > 0) {
      chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / std::max(pooled_e, 1.0);
      ++categories;
    }
    ASSERT_GE(categories, 10) << "too few populated bins";
    const boost::math::chi_squared dist(categories - 1);
    const double threshold = boost::math::quantile(boost::math::complement(dist, 1e-4));
    std::printf("%s: chi2 %.1f, %d dof (threshold %.1f), mass in grid %.5f, null %.5f\n",
                c.name.c_str(), chi2, categories - 1, threshold, inside,
                observed.back() / kSamples);
    EXPECT_LT(chi2, threshold);
  }
}

// int f cos_i dw_i over the hemisphere as int over the slope square [-L, L]^2 of
// f cos_i(wi(s)) 4 (wo.h) / h.z ds dt (D vanishes beyond |s| ~ 0.2 + 5 sigma_r for this map),
// midpoint rule with spacing `step`, from the probe path in double: RGB.
std::array<double, 3> ProbeAlbedo(const Case &c, const v1::Material &material, double step) {
  const Vec wo = Normalize(c.wo);
  const double L = 0.45;
  const int n = int(std::lround(2 * L / step));
  v1::EvaluateRequest settings;
  *settings.mutable_material() = material;
  settings.set_precision(v1::FP64);
  v1::QueryBatch q;
  std::vector<double> weight;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const double s = -L + (a + 0.5) * step, t = -L + (b + 0.5) * step;
      const double r2 = s * s + t * t;
      if (r2 >= 1) continue;
      const Vec h{s, t, std::sqrt(1 - r2)};
      if (!(Dot(wo, h) > 0)) continue;
      const Vec wi = Reflect(wo, h);
      if (!(wi.z > 0)) continue;
      q.set_count(q.count() + 1);
      for (double v : {wo.x, wo.y, wo.z}) q.add_wo(float(v));
      for (float v : c.uv) q.add_uv(v);
      for (float v : c.footprint) q.add_footprint(v);
      for (double v : {wi.x, wi.y, wi.z}) q.add_wi(float(v));
      weight.push_back(step * step * 4 * Dot(wo, h) / h.z);
    }
  const EvalPlan plan = MakeEvalPlan(settings, q);  // the host path resolves the table itself
  std::vector<float> rgb(3 * size_t(q.count()));
  HostEvaluate(plan, q, rgb.data());
  std::array<double, 3> sum{0, 0, 0};
  for (size_t i = 0; i < weight.size(); ++i)
    for (size_t ch = 0; ch < 3; ++ch) sum[ch] += rgb[3 * i + ch] * weight[i];
  return sum;
}

void ExpectMeanWeight(const SampleResponse &resp, const std::array<double, 3> &fine,
                      const std::array<double, 3> &coarse, const std::string &what) {
  const int count = resp.pdf_size();
  ASSERT_GT(fine[0], 1e-2) << "a case without reflection tests nothing";
  for (int ch = 0; ch < 3; ++ch) {
    double sum = 0, sum2 = 0;
    for (int k = 0; k < count; ++k) {
      const double w = resp.weight(3 * k + ch);
      ASSERT_TRUE(std::isfinite(w) && w >= 0.0) << "sample " << k << ": weight " << w;
      if (resp.wi(3 * k + 2) <= 0.0f) {
        ASSERT_EQ(w, 0.0) << "below the horizon";
      }
      sum += w;
      sum2 += w * w;
    }
    const double mean = sum / count;
    const double se = std::sqrt(std::max(0.0, sum2 / count - mean * mean) / (count - 1));
    const double quad_err = std::fabs(fine[size_t(ch)] - coarse[size_t(ch)]);
    std::printf("%s ch %d: mean weight %.5f +- %.5f (SE), quadrature %.5f (+- %.1e)\n",
                what.c_str(), ch, mean, se, fine[size_t(ch)], quad_err);
    EXPECT_NEAR(mean, fine[size_t(ch)], 4.5 * se + quad_err) << what << " channel " << ch;
  }
}

TEST_F(NormalMapSampleTest, MeanWeightIsTheProbeAlbedo) {
  for (const Case &c : kCases) {
    SCOPED_TRACE(c.name);
    const double step = c.sigma_r / 3;
    const auto fine = ProbeAlbedo(c, Material(c), step);
    const auto coarse = ProbeAlbedo(c, Material(c), 2 * step);
    ExpectMeanWeight(Run(Request(c, 16384)), fine, coarse, c.name + " host fp64");
  }
}

// The sample pass on the device: the map's table reaches the kernel (DeviceEngine::Sample binds
// the request table), the mean weight is the probe albedo, and samples do not depend on how the
// batch is split.
TEST_F(NormalMapSampleTest, DeviceSamplesMatchTheAlbedoAndAreSplitInvariant) {
  DeviceEngineOptions o;
  const char *cache = std::getenv("GLINT_CACHE_DIR");
  o.cache_dir = cache ? cache : "";
  o.workers = 1;
  std::unique_ptr<DeviceEngine> engine;
  Status s = DeviceEngine::Create(o, &engine);
  ASSERT_TRUE(s.ok()) << s.message();
  const Case &c = kCases[0];
  const auto fine = ProbeAlbedo(c, Material(c), c.sigma_r / 3);
  const auto coarse = ProbeAlbedo(c, Material(c), 2 * c.sigma_r / 3);
  ExpectMeanWeight(Run(Request(c, 65536, v1::FP32), engine.get()), fine, coarse, "device fp32");
  // Split invariance: three queries (case 0's material) at once against each alone.
  SampleRequest all = Request(kCases[0], 64, v1::FP32);
  for (int i = 1; i < 3; ++i) AddQuery(kCases[i], all.mutable_queries());
  const SampleResponse together = Run(all, engine.get());
  for (int i = 0; i < 3; ++i) {
    Case alone_case = kCases[i];
    alone_case.sigma_r = kCases[0].sigma_r;
    const SampleResponse alone = Run(Request(alone_case, 64, v1::FP32), engine.get());
    ASSERT_EQ(alone.pdf_size(), 64);
    for (int k = 0; k < 64; ++k) {
      EXPECT_EQ(alone.pdf(k), together.pdf(64 * i + k)) << "query " << i << " sample " << k;
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_EQ(alone.wi(3 * k + ch), together.wi(3 * (64 * i + k) + ch));
        EXPECT_EQ(alone.weight(3 * k + ch), together.weight(3 * (64 * i + k) + ch));
      }
    }
  }
}

}  // namespace
}  // namespace glint
