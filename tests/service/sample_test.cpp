// The Sample RPC (server/sample.h) against independent references:
//  - chi-square: the histogram of sampled directions against the bin integrals of the pdf
//    (midpoint quadrature of the kernels' pdf function, which the test first checks equals the
//    pdf returned with every sample), with the null samples as one more category; the
//    threshold is the chi-square quantile (boost.math) at p = 1e-4;
//  - the pdf integrates to <= 1 over the sphere (within the quadrature's error);
//  - the mean weight against a brute-force quadrature of the model's probe values f cos_i over
//    the hemisphere (HostEvaluate with queries.wi), within 4.5 standard errors (from the sample
//    variance) plus the quadrature's error (the difference of two resolutions);
//  - determinism: the device's samples bit-identical however the batch is split, and repeated;
//    SMOOTH samples keyed by uv when the queries carry it (no direction shared by two queries
//    differing only in uv; one set for all without uv);
//  - refusals: K = 0 or beyond the limit, too many samples per call, BINOMIAL, wi set, no uv.
#include "server/sample.h"

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
#include "tests/support/device_engine_fixture.h"

namespace kd {
#define GLINT_USE_DOUBLE 1
#include "models/kemppinen/kemppinen_sample.h"
}  // namespace kd

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

// ---------------------------------------------------------------- requests

struct Case {
  std::string name;
  v1::Material material;
  Vec wo;
  float uv[2] = {0.37f, 0.61f};
  float footprint[4] = {1e-3f, 0.0f, 0.0f, 1e-3f};
};

v1::Material Smooth(v1::Ndf ndf, float ax, float ay) {
  v1::Material m;
  m.set_model(v1::SMOOTH);
  m.set_ndf(ndf);
  m.set_alpha_x(ax);
  m.set_alpha_y(ay);
  for (float f : {0.9f, 0.6f, 0.3f}) m.mutable_schlick()->add_f0(f);
  return m;
}

v1::Material Kemppinen(v1::Ndf ndf, float alpha, double density, float micro) {
  v1::Material m = Smooth(ndf, alpha, alpha);
  m.set_model(v1::KEMPPINEN);
  m.mutable_kemppinen()->set_density(density);
  m.mutable_kemppinen()->set_microroughness(micro);
  return m;
}

v1::Material Chermain(float alpha, float log_density) {
  v1::Material m = Smooth(v1::BECKMANN, alpha, alpha);
  m.set_model(v1::CHERMAIN);
  m.mutable_chermain()->set_log_density(log_density);
  return m;
}

Vec WoAt(double theta_deg, double phi_deg) {
  const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

void AddQuery(const Case &c, v1::QueryBatch *q, const Vec *wi = nullptr) {
  q->set_count(q->count() + 1);
  for (double v : {c.wo.x, c.wo.y, c.wo.z}) q->add_wo(float(v));
  if (c.material.model() != v1::SMOOTH) {
    for (float v : c.uv) q->add_uv(v);
    for (float v : c.footprint) q->add_footprint(v);
  }
  if (wi)
    for (double v : {wi->x, wi->y, wi->z}) q->add_wi(float(v));
}

SampleRequest MakeRequest(const Case &c, uint32_t k, v1::Precision precision = v1::FP64) {
  SampleRequest r;
  *r.mutable_material() = c.material;
  AddQuery(c, r.mutable_queries());
  r.set_samples_per_query(k);
  r.set_seed(7);
  r.set_precision(precision);
  return r;
}

SampleResponse HostSamples(const SampleRequest &r) {
  SampleResponse out;
  ValidationLimits limits;
  Status s = RunSample(nullptr, 0, r, limits, &out);
  EXPECT_TRUE(s.ok()) << s.message();
  return out;
}

// --------------------------------------------------- the pdf, as a function

// The sampler's pdf at any wi, from the kernel headers (in double): what the sample pass
// returns with each sample (checked below), evaluable where nothing was sampled.
class PdfFunction {
 public:
  explicit PdfFunction(const Case &c) : c_(c) {
    v1::EvaluateRequest settings;
    *settings.mutable_material() = c.material;
    settings.set_seed(7);
    settings.set_precision(v1::FP64);
    v1::QueryBatch q;
    AddQuery(c, &q);
    plan_ = MakeEvalPlan(settings, q);
    m_ = kd::smooth_material_unpack(plan_.material.data(), plan_.spec.ndf, plan_.spec.fresnel);
    p_ = kd::kemppinen_params_unpack(plan_.params.data());
    double fp[4] = {c.footprint[0], c.footprint[1], c.footprint[2], c.footprint[3]};
    fp_ = kd::kemppinen_footprint(p_, c.uv[0], c.uv[1], fp, plan_.seed_lo, plan_.seed_hi);
    wo_ = kd::r3_normalize(kd::make_real3(float(c.wo.x), float(c.wo.y), float(c.wo.z)));
  }

  double operator()(Vec w) const {
    const kd::real3 wi = kd::make_real3(w.x, w.y, w.z);
    const double smooth = kd::smooth_sample_pdf(m_, wo_, wi);
    if (c_.material.model() != v1::KEMPPINEN) return smooth;
    const double q = kd::kemppinen_sample_smooth_fraction(m_, p_, fp_);
    return q * smooth + (1.0 - q) * kd::kemppinen_glint_pdf(m_, p_, fp_, wo_, wi);
  }

 private:
  Case c_;
  EvalPlan plan_;
  kd::SmoothMaterial m_;
  kd::KemppinenParams p_;
  kd::KemppinenFootprint fp_;
  kd::real3 wo_;
};

// ------------------------------------------------- bins of the half-vector

// Every sample is binned by its half-vector h = (wi + wo) / |wi + wo|, a bijection between the
// directions a reflection sampler can produce (wo.h > 0) and the upper hemisphere; the density
// of h is pdf(wi) 4 (wo.h) (Walter et al. 2007 Eq. 14). In wi the pdf has an integrable 1/|wi +
// wo| singularity at wi = -wo (grazing facets) that a midpoint rule underestimates; in h it has
// none. Rings about the normal, s = 1 - h.z in [0, 1] (dh = ds dphi), ring j of
// [(j/M)^3, ((j+1)/M)^3] (fine near the normal, where the lobes are), P azimuth sectors each.
class HalfVectorBins {
 public:
  HalfVectorBins(int rings, int sectors) : rings_(rings), sectors_(sectors) {}
  int count() const { return rings_ * sectors_; }
  int sectors() const { return sectors_; }
  double s_edge(int j) const {
    const double t = double(j) / rings_;
    return t * t * t;
  }
  static Vec Direction(double s, double phi) {
    const double c = 1.0 - s, sn = std::sqrt(std::max(0.0, 1.0 - c * c));
    return {sn * std::cos(phi), sn * std::sin(phi), c};
  }
  // The bin of h (h.z > 0).
  int Bin(Vec h) const {
    const double s = std::clamp(1.0 - h.z, 0.0, 1.0);
    int j = std::clamp(int(std::cbrt(s) * rings_), 0, rings_ - 1);
    while (j > 0 && s < s_edge(j)) --j;
    while (j + 1 < rings_ && s >= s_edge(j + 1)) ++j;
    double phi = std::atan2(h.y, h.x);
    if (phi < 0) phi += 2 * kPi;
    const int p = std::clamp(int(phi / (2 * kPi) * sectors_), 0, sectors_ - 1);
    return j * sectors_ + p;
  }
  // Midpoint rule of g(h) over bin `bin` with n x n nodes (in s and phi).
  template <class F>
  double Integrate(int bin, int n, F g) const {
    const int j = bin / sectors_, p = bin % sectors_;
    const double s0 = s_edge(j), s1 = s_edge(j + 1);
    const double p0 = 2 * kPi * p / sectors_, dp = 2 * kPi / sectors_ / n, ds = (s1 - s0) / n;
    double sum = 0;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) sum += g(Direction(s0 + (a + 0.5) * ds, p0 + (b + 0.5) * dp));
    return sum * ds * dp;
  }

 private:
  int rings_, sectors_;
};

Vec Reflect(Vec wo, Vec h) {
  return Add(Scale(h, 2 * Dot(wo, h)), Scale(wo, -1));
}

// ------------------------------------------------------------- chi-square

void ExpectChiSquare(const Case &c) {
  SCOPED_TRACE(c.name);
  constexpr uint32_t kSamples = 65536;
  const SampleResponse resp = HostSamples(MakeRequest(c, kSamples));
  ASSERT_EQ(resp.pdf_size(), int(kSamples));
  const PdfFunction pdf(c);
  const HalfVectorBins bins(32, 16);
  const Vec wo = Normalize(c.wo);
  std::vector<double> observed(bins.count() + 1, 0.0);  // + the null samples
  int checked = 0, pdf_mismatch = 0;
  for (uint32_t k = 0; k < kSamples; ++k) {
    const float p = resp.pdf(int(k));
    const Vec w{resp.wi(3 * int(k)), resp.wi(3 * int(k) + 1), resp.wi(3 * int(k) + 2)};
    if (p == 0.0f) {
      observed.back() += 1;
      continue;
    }
    // The pdf returned is the pdf function's at wi. wi comes back rounded to float, so the
    // function is evaluated over that rounding's neighbourhood, and the returned value (itself
    // rounded to float) must lie within the range it spans there. To first order the rounding
    // (<= 1/2 ulp per component) moves the pdf by at most 3/2 of its largest one-component
    // change per ulp, so each component is moved by +-2 ulp.
    if (checked < 3000) {
      double lo = pdf(Normalize(w)), hi = lo;
      for (int axis = 0; axis < 3; ++axis)
        for (double sign : {-1.0, 1.0}) {
          Vec d = w;
          double *comp = axis == 0 ? &d.x : axis == 1 ? &d.y : &d.z;
          *comp += sign * (std::fabs(*comp) * 2.4e-7 + 1e-30);
          const double v = pdf(Normalize(d));
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
      if (!(p >= lo * (1 - 2.4e-7) &&
            p <= hi * (1 + 2.4e-7))) {  // + 2 ulp: the bracket is first-order
        if (++pdf_mismatch <= 3)
          std::printf(
              "pdf mismatch: wi (%.9g, %.9g, %.9g) returned %.9g, function in [%.9g, %.9g]\n", w.x,
              w.y, w.z, p, lo, hi);
      }
      ++checked;
    }
    observed[size_t(bins.Bin(Normalize(Add(Normalize(w), wo))))] += 1;
  }
  EXPECT_EQ(pdf_mismatch, 0) << "of " << checked << " samples' pdf checked";
  std::vector<double> expected(bins.count() + 1, 0.0);
  // The density of h: pdf(wi(h)) 4 (wo.h), 0 where wo.h <= 0 (no reflection gives such h).
  const auto h_density = [&](Vec h) {
    const double woh = Dot(wo, h);
    return woh > 0 ? pdf(Reflect(wo, h)) * 4.0 * woh : 0.0;
  };
  double total = 0.0, total_coarse = 0.0;
  for (int b = 0; b < bins.count(); ++b) {
    expected[size_t(b)] = bins.Integrate(b, 16, h_density);
    total += expected[size_t(b)];
    total_coarse += bins.Integrate(b, 8, h_density);
  }
  // The pdf integrates to <= 1 over the sphere (= the density of h over the hemisphere), within
  // the quadrature error (estimated by the
  // difference of the 8 x 8 and 16 x 16 rules, times 2 for safety of the estimate).
  const double quad_err = 2.0 * std::fabs(total - total_coarse) + 1e-6;
  EXPECT_LE(total, 1.0 + quad_err) << "integral of the pdf over the sphere";
  std::printf("%s: integral of pdf = %.5f (+- %.1e), null samples %.4f\n", c.name.c_str(), total,
              quad_err, observed.back() / kSamples);
  expected.back() = std::max(0.0, 1.0 - total);
  // Pool categories expecting fewer than 5 samples (Cochran's rule) into one.
  double chi2 = 0.0, pooled_o = 0.0, pooled_e = 0.0;
  int categories = 0;
  for (size_t b = 0; b < expected.size(); ++b) {
    const double e = expected[b] * kSamples;
    if (e < 5.0) {
      pooled_o += observed[b];
      pooled_e += e;
      continue;
    }
    chi2 += (observed[b] - e) * (observed[b] - e) / e;
    if (std::getenv("GLINT_SAMPLE_DEBUG") && (observed[b] - e) * (observed[b] - e) / e > 6)
      std::printf("  bin %zu: observed %.0f expected %.1f\n", b, observed[b], e);
    ++categories;
  }
  if (pooled_e > 0.0) {
    chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / std::max(pooled_e, 1.0);
    ++categories;
  }
  ASSERT_GE(categories, 20) << "too few populated bins for a meaningful test";
  const boost::math::chi_squared dist(categories - 1);
  const double threshold = boost::math::quantile(boost::math::complement(dist, 1e-4));
  std::printf("%s: chi2 = %.1f with %d dof (threshold at p = 1e-4: %.1f)\n", c.name.c_str(), chi2,
              categories - 1, threshold);
  EXPECT_LT(chi2, threshold);
}

TEST(SampleChiSquare, SmoothGgxIsotropic) {
  ExpectChiSquare({"smooth ggx 0.3", Smooth(v1::GGX, 0.3f, 0.3f), WoAt(50, 20)});
}
TEST(SampleChiSquare, SmoothGgxAnisotropic) {
  ExpectChiSquare({"smooth ggx 0.4/0.1", Smooth(v1::GGX, 0.4f, 0.1f), WoAt(65, 70)});
}
TEST(SampleChiSquare, SmoothBeckmann) {
  ExpectChiSquare({"smooth beckmann 0.3", Smooth(v1::BECKMANN, 0.3f, 0.3f), WoAt(40, 0)});
}
TEST(SampleChiSquare, KemppinenGgxGlinty) {
  ExpectChiSquare({"kemppinen ggx 0.3 1e5", Kemppinen(v1::GGX, 0.3f, 1e5, 0.05f), WoAt(30, 10)});
}
TEST(SampleChiSquare, KemppinenBeckmannDense) {
  ExpectChiSquare(
      {"kemppinen beckmann 0.5 1e8", Kemppinen(v1::BECKMANN, 0.5f, 1e8, 0.1f), WoAt(60, 200)});
}
TEST(SampleChiSquare, Chermain) {
  ExpectChiSquare({"chermain 0.4", Chermain(0.4f, 20.0f), WoAt(45, 30)});
}

// ------------------------------------------------ mean weight vs quadrature

// The albedo integral of f cos_i over the hemisphere, as an integral over the half-vector
// (dwi = 4 (wo.h) dh), by the midpoint rule of HalfVectorBins(64, 32) with n x n nodes per
// bin, from the model's probe path (HostEvaluate with queries.wi, fp64): RGB.
std::array<double, 3> ProbeAlbedo(const Case &c, int n) {
  const HalfVectorBins bins(64, 32);
  const Vec wo = Normalize(c.wo);
  v1::EvaluateRequest settings;
  *settings.mutable_material() = c.material;
  settings.set_seed(7);
  settings.set_precision(v1::FP64);
  v1::QueryBatch q;
  std::vector<double> weight;  // node weight ds dphi 4 (wo.h)
  for (int b = 0; b < bins.count(); ++b) {
    const int j = b / bins.sectors();
    const double dsdp = (bins.s_edge(j + 1) - bins.s_edge(j)) / n * (2 * kPi / bins.sectors() / n);
    bins.Integrate(b, n, [&](Vec h) {
      const Vec wi = Normalize(Reflect(wo, h));
      if (Dot(wo, h) > 0 && wi.z > 0) {
        AddQuery(c, &q, &wi);
        weight.push_back(dsdp * 4.0 * Dot(wo, h));
      }
      return 0.0;
    });
  }
  const EvalPlan plan = MakeEvalPlan(settings, q);
  std::vector<float> rgb(3 * size_t(q.count()));
  HostEvaluate(plan, q, rgb.data());
  std::array<double, 3> sum{0, 0, 0};
  for (size_t i = 0; i < weight.size(); ++i)
    for (size_t ch = 0; ch < 3; ++ch) sum[ch] += rgb[3 * i + ch] * weight[i];
  return sum;
}

// `nodes`: the quadrature's nodes per bin and axis, enough to resolve the narrowest lobe (a
// facet's, alpha_star radians wide in h); its error is estimated by the rule with half as many.
void ExpectMeanWeight(const Case &c, int nodes = 4) {
  SCOPED_TRACE(c.name);
  constexpr uint32_t kSamples = 65536;
  const SampleResponse resp = HostSamples(MakeRequest(c, kSamples));
  const std::array<double, 3> fine = ProbeAlbedo(c, nodes), coarse = ProbeAlbedo(c, nodes / 2);
  ASSERT_GT(fine[0], 1e-2) << "a case without reflection tests nothing";
  for (int ch = 0; ch < 3; ++ch) {
    double sum = 0, sum2 = 0;
    for (uint32_t k = 0; k < kSamples; ++k) {
      const double w = resp.weight(3 * int(k) + ch);
      ASSERT_TRUE(std::isfinite(w) && w >= 0.0) << "sample " << k << ": weight " << w;
      if (resp.wi(3 * int(k) + 2) <= 0.0f) {
        ASSERT_EQ(w, 0.0) << "below the horizon";
      }
      sum += w;
      sum2 += w * w;
    }
    const double mean = sum / kSamples;
    const double se = std::sqrt(std::max(0.0, sum2 / kSamples - mean * mean) / (kSamples - 1));
    const double quad_err = std::fabs(fine[size_t(ch)] - coarse[size_t(ch)]);
    std::printf("%s ch %d: mean weight %.5f +- %.5f (SE), quadrature %.5f (+- %.1e)\n",
                c.name.c_str(), ch, mean, se, fine[size_t(ch)], quad_err);
    EXPECT_NEAR(mean, fine[size_t(ch)], 4.5 * se + quad_err) << "channel " << ch;
  }
}

TEST(SampleMeanWeight, SmoothGgx) {
  ExpectMeanWeight({"smooth ggx 0.1", Smooth(v1::GGX, 0.1f, 0.1f), WoAt(30, 0)});
  ExpectMeanWeight({"smooth ggx 0.5/0.2", Smooth(v1::GGX, 0.5f, 0.2f), WoAt(70, 45)});
}
TEST(SampleMeanWeight, SmoothBeckmann) {
  ExpectMeanWeight({"smooth beckmann 0.3", Smooth(v1::BECKMANN, 0.3f, 0.3f), WoAt(50, 100)});
}
// Footprint 1e-3 uv: about 1, 10 and 1000 facets in the pixel at densities 1e6, 1e7, 1e9.
TEST(SampleMeanWeight, KemppinenGgx) {
  for (double density : {1e6, 1e7, 1e9})
    for (float micro : {0.02f, 0.1f})
      ExpectMeanWeight({"kemppinen ggx 0.3 density " + std::to_string(density) + " micro " +
                            std::to_string(micro),
                        Kemppinen(v1::GGX, 0.3f, density, micro), WoAt(40, 15)},
                       micro < 0.05f ? 16 : 4);
}
TEST(SampleMeanWeight, KemppinenBeckmann) {
  for (float alpha : {0.15f, 0.6f})
    ExpectMeanWeight({"kemppinen beckmann " + std::to_string(alpha),
                      Kemppinen(v1::BECKMANN, alpha, 1e6, 0.05f), WoAt(55, 300)});
}
TEST(SampleMeanWeight, Chermain) {
  for (float log_density : {12.0f, 25.0f})
    for (float alpha : {0.3f, 0.6f})
      ExpectMeanWeight(
          {"chermain " + std::to_string(alpha) + " ln rho " + std::to_string(log_density),
           Chermain(alpha, log_density), WoAt(35, 60)},
          16);
}

// A query with a world frame: wo is taken to the local frame and wi comes back in world
// space. The mean weight equals the albedo of the same view without a frame (probe quadrature
// in the local frame), and every sample with a weight lies above the frame's surface.
TEST(SampleFrame, WorldSpaceInAndOut) {
  const Case local{"framed smooth ggx 0.4/0.1", Smooth(v1::GGX, 0.4f, 0.1f), WoAt(50, 30)};
  const Vec n = Normalize({1, 2, 3});
  const Vec t = Normalize(Add(Vec{1, 0, 0}, Scale(n, -Dot(n, {1, 0, 0}))));
  const Vec b{n.y * t.z - n.z * t.y, n.z * t.x - n.x * t.z, n.x * t.y - n.y * t.x};
  const Vec wo = Add(Add(Scale(t, local.wo.x), Scale(b, local.wo.y)), Scale(n, local.wo.z));
  SampleRequest r = MakeRequest({local.name, local.material, wo}, 65536);
  v1::QueryBatch *q = r.mutable_queries();
  for (double v : {0.0, 0.0, 0.0}) q->add_position(float(v));
  for (double v : {n.x, n.y, n.z}) q->add_normal(float(v));
  for (double v : {t.x, t.y, t.z}) q->add_tangent(float(v));
  const SampleResponse resp = HostSamples(r);
  double sum = 0, sum2 = 0;
  const int count = resp.pdf_size();
  for (int k = 0; k < count; ++k) {
    const double w = resp.weight(3 * k);
    const Vec wi{resp.wi(3 * k), resp.wi(3 * k + 1), resp.wi(3 * k + 2)};
    if (w > 0) {
      ASSERT_GT(Dot(wi, n), 0.0) << "sample " << k << " has a weight but lies below the surface";
      ASSERT_NEAR(Dot(wi, wi), 1.0, 1e-6);
    }
    sum += w;
    sum2 += w * w;
  }
  const double mean = sum / count;
  const double se = std::sqrt(std::max(0.0, sum2 / count - mean * mean) / (count - 1));
  const std::array<double, 3> fine = ProbeAlbedo(local, 4), coarse = ProbeAlbedo(local, 2);
  EXPECT_NEAR(mean, fine[0], 4.5 * se + std::fabs(fine[0] - coarse[0]));
}

// The pitfalls of the models' own stability tests, through the sample pass (fp32 and fp64 host
// path): grazing and normal views, alpha 1e-4 and 1, microroughness 1e-5 and 1, density 1e-3
// and 1e15, uv 1e7, zero and huge footprints. Every output is finite, pdf and weights are
// non-negative, a sample without a direction is all zeros, and directions are unit vectors.
TEST(SampleStability, ExtremesFiniteAndNonNegative) {
  std::vector<Case> cases;
  for (float alpha : {1e-4f, 1.0f}) {
    cases.push_back({"smooth ggx", Smooth(v1::GGX, alpha, alpha), {}});
    cases.push_back({"smooth beckmann", Smooth(v1::BECKMANN, alpha, 1.0f), {}});
    cases.push_back({"chermain", Chermain(alpha, 20.0f), {}});
    for (double density : {1e-3, 1e15})
      for (float micro : {1e-5f, 1.0f})
        cases.push_back({"kemppinen", Kemppinen(v1::GGX, alpha, density, micro), {}});
    cases.push_back({"kemppinen beckmann", Kemppinen(v1::BECKMANN, alpha, 1e6, 0.02f), {}});
  }
  for (const Case &base : cases) {
    for (double theta : {0.0, 60.0, 89.99}) {
      for (int shape = 0; shape < 3; ++shape) {
        Case c = base;
        c.wo = WoAt(theta, 33);
        const float f = shape == 0 ? 0.0f : shape == 1 ? 1e-3f : 1e3f;
        c.footprint[0] = f;
        c.footprint[3] = f;
        if (shape == 2) c.uv[0] = c.uv[1] = 1e7f;
        for (v1::Precision precision : {v1::FP32, v1::FP64}) {
          SCOPED_TRACE(c.name + " alpha " + std::to_string(c.material.alpha_x()) + " theta " +
                       std::to_string(theta) + " shape " + std::to_string(shape));
          const SampleResponse r = HostSamples(MakeRequest(c, 64, precision));
          ASSERT_EQ(r.pdf_size(), 64);
          for (int k = 0; k < 64; ++k) {
            const float p = r.pdf(k);
            ASSERT_TRUE(std::isfinite(p) && p >= 0.0f) << "pdf " << p;
            double len2 = 0;
            for (int ch = 0; ch < 3; ++ch) {
              const float w = r.weight(3 * k + ch), d = r.wi(3 * k + ch);
              ASSERT_TRUE(std::isfinite(w) && w >= 0.0f) << "weight " << w;
              ASSERT_TRUE(std::isfinite(d));
              len2 += double(d) * d;
              if (p == 0.0f) {
                ASSERT_EQ(w, 0.0f);
              }
            }
            if (p > 0.0f) {
              ASSERT_NEAR(len2, 1.0, 1e-5);
            }
          }
        }
      }
    }
  }
}

// ------------------------------------------------------------- refusals

void ExpectRefused(const SampleRequest &r, const std::string &needle) {
  SampleResponse out;
  ValidationLimits limits;
  Status s = RunSample(nullptr, 0, r, limits, &out);
  ASSERT_FALSE(s.ok()) << "expected a refusal mentioning " << needle;
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument);
  EXPECT_NE(s.message().find(needle), std::string::npos) << s.message();
}

TEST(SampleRefusals, BadRequests) {
  const Case smooth{"smooth", Smooth(v1::GGX, 0.3f, 0.3f), WoAt(30, 0)};
  ExpectRefused(MakeRequest(smooth, 0), "samples_per_query: 0");
  ExpectRefused(MakeRequest(smooth, kMaxSamplesPerQuery + 1), "samples_per_query");
  ExpectRefused(MakeRequest(smooth, 4000000000u), "samples_per_query");
  // count * K beyond max_batch (2^20): 17 queries x 65536 samples.
  SampleRequest many = MakeRequest(smooth, 65536);
  for (int i = 0; i < 16; ++i) AddQuery(smooth, many.mutable_queries());
  ExpectRefused(many, "expected at most 1048576");
  // BINOMIAL: a count per light, not an NDF.
  Case binomial = smooth;
  binomial.material.set_model(v1::BINOMIAL);
  binomial.material.mutable_binomial()->set_density(1e6);
  ExpectRefused(MakeRequest(binomial, 4), "BINOMIAL cannot be sampled: its glints are a count");
  // wi is the output.
  SampleRequest with_wi = MakeRequest(smooth, 4);
  for (float v : {0.0f, 0.0f, 1.0f}) with_wi.mutable_queries()->add_wi(v);
  ExpectRefused(with_wi, "queries.wi");
  // The glint models still need uv.
  SampleRequest no_uv = MakeRequest({"k", Kemppinen(v1::GGX, 0.3f, 1e6, 0.02f), WoAt(30, 0)}, 4);
  no_uv.mutable_queries()->clear_uv();
  ExpectRefused(no_uv, "queries.uv");
}

// A reply is kSampleReplyBytesPerSample per sample whatever the request's size, so a Sample call
// whose reply would exceed the server's message limit is refused before any work, saying how
// many samples fit. Before, 10 queries x 65536 samples at --max-message-mb 1 were computed and
// then failed in gRPC's send ("Sent message larger than max (18350140 vs. 1048576)"). The bound
// is checked against protobuf's own serialisation of the largest reply it accepts.
TEST(SampleRefusals, ReplyOverTheMessageLimitIsRefusedBeforeTheWork) {
  const Case smooth{"smooth", Smooth(v1::GGX, 0.3f, 0.3f), WoAt(30, 0)};
  ValidationLimits limits;
  limits.max_message_bytes = 1u << 20;
  v1::EvaluateRequest settings;
  SampleRequest big = MakeRequest(smooth, 65536);
  for (int i = 0; i < 9; ++i) AddQuery(smooth, big.mutable_queries());
  Status s = ValidateSampleRequest(big, limits, &settings);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument);
  for (const char *part : {"samples_per_query: 10 queries x 65536 samples = 655360 samples",
                           "exceeds the server's message limit of 1048576 bytes"})
    EXPECT_NE(s.message().find(part), std::string::npos) << s.message();
  // The most samples a 1 MiB reply holds by the stated bound, as the refusal says.
  const uint64_t fit = ((1u << 20) - kSampleReplyOverheadBytes) / kSampleReplyBytesPerSample;
  EXPECT_NE(s.message().find("expected at most " + std::to_string(fit) + " samples per call"),
            std::string::npos)
      << s.message();
  // fit samples in one call are accepted, one more is refused.
  SampleRequest edge = MakeRequest(smooth, uint32_t(fit), v1::FP32);
  ASSERT_TRUE(ValidateSampleRequest(edge, limits, &settings).ok());
  edge.set_samples_per_query(uint32_t(fit + 1));
  EXPECT_EQ(ValidateSampleRequest(edge, limits, &settings).code(), Status::Code::kInvalidArgument);
  // Without a limit (0), only max_batch bounds the call.
  EXPECT_TRUE(ValidateSampleRequest(big, ValidationLimits{}, &settings).ok());
  // The accepted reply, sampled on the host path, with the largest stats a server adds (both
  // times, the largest batch count, a device name longer than OpenCL implementations report),
  // serialises within the limit.
  edge.set_samples_per_query(uint32_t(fit));
  SampleResponse out;
  ASSERT_TRUE(RunSample(nullptr, 0, edge, limits, &out).ok());
  ASSERT_EQ(out.pdf_size(), int(fit));
  out.set_count(0xffffffffu);
  out.set_samples_per_query(0xffffffffu);
  out.mutable_stats()->set_queue_ms(1e300);
  out.mutable_stats()->set_compute_ms(1e300);
  out.mutable_stats()->set_batch_requests(0xffffffffu);
  out.mutable_stats()->set_device(std::string(512, 'd'));
  EXPECT_LE(out.ByteSizeLong(), uint64_t(1u << 20));
}

// ------------------------------------------------------------ the device

class SampleDeviceTest : public test::DeviceEngineTest {
 protected:
  static SampleResponse Device(const SampleRequest &r) {
    SampleResponse out;
    ValidationLimits limits;
    Status s = RunSample(engine_.get(), 0, r, limits, &out);
    EXPECT_TRUE(s.ok()) << s.message();
    return out;
  }
};

// 37 different queries (views and uv) of one material.
SampleRequest Batch(const v1::Material &m, uint32_t k) {
  SampleRequest r;
  *r.mutable_material() = m;
  r.set_samples_per_query(k);
  r.set_seed(11);
  for (int i = 0; i < 37; ++i) {
    Case c{"", m, WoAt(3.0 + 2.3 * i, 37.0 * i)};
    c.uv[0] = 0.013f * float(i);
    c.uv[1] = 0.5f - 0.007f * float(i);
    AddQuery(c, r.mutable_queries());
  }
  return r;
}

// Queries [first, first + n) of r as a request of their own.
SampleRequest Slice(const SampleRequest &r, int first, int n) {
  SampleRequest s = r;
  v1::QueryBatch *q = s.mutable_queries();
  q->Clear();
  q->set_count(uint32_t(n));
  const v1::QueryBatch &all = r.queries();
  for (int i = first; i < first + n; ++i) {
    for (int c = 0; c < 3; ++c) q->add_wo(all.wo(3 * i + c));
    if (!all.uv().empty()) {
      for (int c = 0; c < 2; ++c) q->add_uv(all.uv(2 * i + c));
      for (int c = 0; c < 4; ++c) q->add_footprint(all.footprint(4 * i + c));
    }
  }
  return s;
}

TEST_F(SampleDeviceTest, BitIdenticalUnderChunkingAndRepeated) {
  for (const v1::Material &m : {Smooth(v1::GGX, 0.3f, 0.2f), Smooth(v1::BECKMANN, 0.4f, 0.4f),
                                Kemppinen(v1::GGX, 0.3f, 1e5, 0.02f), Chermain(0.4f, 20.0f)}) {
    SCOPED_TRACE(v1::Model_Name(m.model()));
    const SampleRequest all = Batch(m, 16);
    const SampleResponse whole = Device(all);
    const SampleResponse again = Device(all);
    ASSERT_EQ(whole.pdf_size(), 37 * 16);
    EXPECT_EQ(whole.SerializeAsString(), again.SerializeAsString());
    int first = 0, nonzero = 0;
    for (int size : {1, 7, 29}) {
      const SampleResponse part = Device(Slice(all, first, size));
      for (int j = 0; j < part.pdf_size(); ++j) {
        const int g = first * 16 + j;
        ASSERT_EQ(part.pdf(j), whole.pdf(g)) << "sample " << g;
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(part.wi(3 * j + c), whole.wi(3 * g + c));
          ASSERT_EQ(part.weight(3 * j + c), whole.weight(3 * g + c));
        }
      }
      first += size;
    }
    for (float p : whole.pdf()) nonzero += p > 0.0f;
    EXPECT_GT(nonzero, 37 * 16 / 2);  // a broken kernel writing nothing would pass the rest
  }
}

// The device kernel samples the same distribution as the host: its mean weight against the
// probe quadrature, as ExpectMeanWeight does for the host path.
TEST_F(SampleDeviceTest, DeviceMeanWeightMatchesQuadrature) {
  const Case c{"device kemppinen", Kemppinen(v1::GGX, 0.3f, 1e7, 0.1f), WoAt(40, 15)};
  constexpr uint32_t kSamples = 65536;
  const SampleResponse resp = Device(MakeRequest(c, kSamples, v1::FP32));
  const std::array<double, 3> fine = ProbeAlbedo(c, 4), coarse = ProbeAlbedo(c, 2);
  double sum = 0, sum2 = 0;
  for (uint32_t k = 0; k < kSamples; ++k) {
    const double w = resp.weight(3 * int(k));
    sum += w;
    sum2 += w * w;
  }
  const double mean = sum / kSamples;
  const double se = std::sqrt(std::max(0.0, sum2 / kSamples - mean * mean) / (kSamples - 1));
  std::printf("device: mean weight %.5f +- %.5f, quadrature %.5f\n", mean, se, fine[0]);
  EXPECT_NEAR(mean, fine[0], 4.5 * se + std::fabs(fine[0] - coarse[0]));
}

// SMOOTH samples are keyed by uv when the queries carry it (README "Determinism"), though the
// smooth BRDF does not read uv: 12 queries with one wo and 12 different uv get 12 independent
// sample sets (no wi shared between any two, on the device and on the host), while the same
// queries without uv get one set 12 times (the key is then wo alone, as before); and the uv-keyed
// samples stay bit-identical however the batch is split.
TEST_F(SampleDeviceTest, SmoothSamplesAreKeyedByUvAndUnchangedByChunking) {
  constexpr int kQueries = 12, kK = 16;
  SampleRequest with_uv;
  *with_uv.mutable_material() = Smooth(v1::GGX, 0.3f, 0.2f);
  with_uv.set_samples_per_query(kK);
  with_uv.set_seed(5);
  v1::QueryBatch *q = with_uv.mutable_queries();
  q->set_count(kQueries);
  const Vec wo = WoAt(35, 20);
  for (int i = 0; i < kQueries; ++i) {
    for (double v : {wo.x, wo.y, wo.z}) q->add_wo(float(v));
    for (float v : {0.1f + 0.05f * float(i), 0.7f}) q->add_uv(v);
    for (float v : {1e-3f, 0.0f, 0.0f, 1e-3f}) q->add_footprint(v);
  }
  SampleRequest without_uv = with_uv;
  without_uv.mutable_queries()->clear_uv();
  without_uv.mutable_queries()->clear_footprint();
  auto wi_of = [](const SampleResponse &r, int query, int k) {
    const int g = 3 * (query * kK + k);
    return std::array<float, 3>{r.wi(g), r.wi(g + 1), r.wi(g + 2)};
  };
  auto host = [](const SampleRequest &r) {
    SampleResponse out;
    ValidationLimits limits;
    Status s = RunSample(nullptr, 0, r, limits, &out);
    EXPECT_TRUE(s.ok()) << s.message();
    return out;
  };
  for (bool device : {true, false}) {
    SCOPED_TRACE(device ? "device" : "host");
    const SampleResponse keyed = device ? Device(with_uv) : host(with_uv);
    const SampleResponse plain = device ? Device(without_uv) : host(without_uv);
    ASSERT_EQ(keyed.wi_size(), kQueries * kK * 3);
    ASSERT_EQ(plain.wi_size(), kQueries * kK * 3);
    int shared = 0, live = 0;
    for (int i = 0; i < kQueries; ++i) {
      for (int k = 0; k < kK; ++k) {
        live += keyed.pdf(i * kK + k) > 0.0f;
        EXPECT_EQ(wi_of(plain, i, k), wi_of(plain, 0, k)) << "query " << i << " sample " << k;
        for (int j = 0; j < i; ++j)
          for (int l = 0; l < kK; ++l)
            shared += keyed.pdf(i * kK + k) > 0.0f && wi_of(keyed, i, k) == wi_of(keyed, j, l);
      }
    }
    EXPECT_EQ(shared, 0) << "queries differing only in uv share sampled directions";
    EXPECT_GT(live, kQueries * kK / 2);  // a kernel writing only null samples would pass the rest
  }
  const SampleResponse whole = Device(with_uv);
  int first = 0;
  for (int size : {5, 1, 6}) {
    const SampleResponse part = Device(Slice(with_uv, first, size));
    ASSERT_EQ(part.pdf_size(), size * kK);
    for (int j = 0; j < part.pdf_size(); ++j) {
      const int g = first * kK + j;
      ASSERT_EQ(part.pdf(j), whole.pdf(g)) << "sample " << g;
      for (int c = 0; c < 3; ++c) {
        ASSERT_EQ(part.wi(3 * j + c), whole.wi(3 * g + c)) << "sample " << g;
        ASSERT_EQ(part.weight(3 * j + c), whole.weight(3 * g + c)) << "sample " << g;
      }
    }
    first += size;
  }
}

}  // namespace
}  // namespace glint
