// Speed and accuracy of the polygon-light integration methods (EvaluateRequest.area_method) on
// the smooth model, one row per method and sample count:
//   evals/s   polygon-light evaluations per second on the OpenCL device in fp32 (DeviceEngine,
//             one worker (command queue), in process; includes buffer set-up and the result copy
//             like bench_smooth), summed over the sweep's requests: sum of queries / sum of
//             per-request median times, each request's batch tiled until one run takes >= ~50 ms
//             (capped at max_batch) so kernel launch is amortised;
//   error     relative error against the truth over the sweep: mean, 95th percentile and max,
//             overall and per roughness band (alpha < 0.1, 0.1 <= alpha <= 0.4, alpha > 0.4).
//
// Sweep (one polygon light per request, one request per roughness x light shape): GGX (and,
// with --beckmann, a second table for Beckmann), isotropic alpha in {0.01, 0.03, 0.1, 0.2, 0.4,
// 0.7, 1.0}, grey Schlick f0 = 1, radiance 1, one-sided lights facing the shading point. The
// light is one fixed polygon in world space (a unit square, a triangle or a hexagon in the plane
// z = 0); every query carries its own world frame (position, normal, tangent) chosen so that
// the light appears in the query's local frame at a given distance, elevation and tilt: solid
// angles from 1e-3 sr to 6.06 sr (a hemisphere is 6.28), centres from the zenith down to 5 deg,
// some partly below the horizon. Each light placement is seen from views theta_o in {0, 20, 40,
// 60, 75, 85, 89} deg at azimuths 180 (mirror direction towards the light), 90 and 0 deg. So a
// request packs ~100-400 light configurations into one batch, like a renderer's G-buffer.
//
// Truth: an independent nested adaptive Gauss-Kronrod integration over the light's plane in
// double (PlaneAdaptive below; the same scheme is verified in tests/area/area_lights_test.cpp
// against a brute-force hemisphere integration and against REFERENCE, ~1e-7). Not REFERENCE at
// a high sample count, as first planned: REFERENCE fp64 at 1024/512/256 nodes per dimension
// (alpha < 0.02 / < 0.06 / else; 256 alone is off by 9e-2 at alpha 0.01) is within 3e-4 on
// the test's small, medium and large lights but off by up to 10% for the hemisphere-filling
// light (6 sr) at 89 deg views (the lobe at the horizon, in a corner of a huge spherical triangle;
// it even breaks the x -> -x symmetry of the square by 4%). `--truth reference` uses it anyway, for
// comparison.
//
// Relative error of a query: |x - truth| / max(truth, 1e-3 * T), T = the largest truth over the
// table (about 1 here: radiance 1 times an albedo <= 1), so that queries whose truth is ~0 (the
// lobe misses the light) are measured against 1/1000 of the table's scale, not against 0.
//
// Methods the server refuses (ValidateSettings + ValidateQueries) are reported as "not
// available: <message>" and skipped, so a method is measured as soon as validation accepts it
// (LECOCQ, LECOCQ_PEARSON and MONTE_CARLO were refused as "not implemented yet" when this was
// written). An engine failure is reported as "failed: <message>". MONTE_CARLO runs at
// area_samples 4, 16, 64, 256 (seed 1), REFERENCE at 8 and 32 (bench/lib AreaMethodChoices, the
// list bench_models uses too).
//
//   build/bench/bench_area                       # GGX, full sweep (~3-4 min on 2 cores)
//   build/bench/bench_area --beckmann --csv docs/area_speed_accuracy.csv   # + Beckmann (~8 min)
//   build/bench/bench_area --quick               # small sweep, smoke run (~20 s)
//   python3 bench/plot_area.py docs/area_speed_accuracy.csv
//       # -> docs/area_speed_accuracy.{svg,png}
//
// Flags: --quick, --csv FILE, --beckmann, --repeat R (default 5; 3 with --quick), --worst N
// (list the N worst queries of each method), --truth adaptive|reference (default adaptive).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bench/lib/bench_case.h"
#include "bench/lib/bench_lib.h"
#include "client/lib/glint_client.h"
#include "glint/v1/glint.pb.h"
#include "server/device_engine.h"
#include "server/eval_plan.h"
#include "server/host_path.h"
#include "server/validation.h"
#include "tests/support/plane_adaptive.h"

// The kernels' BRDF in double for the adaptive truth (the same single source as the device).
namespace kd {
#define GLINT_USE_DOUBLE 1
#include "kernels/smooth_brdf.h"
}  // namespace kd

namespace {

using glint::bench::Clock;
constexpr double kPi = 3.14159265358979323846;

struct D3 {
  double x, y, z;
};
D3 operator+(D3 a, D3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
D3 operator-(D3 a, D3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
D3 operator*(D3 a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
double Dot(D3 a, D3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
D3 Cross(D3 a, D3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
D3 Normalize(D3 a) {
  return a * (1.0 / std::sqrt(Dot(a, a)));
}
double Rad(double deg) {
  return deg * kPi / 180.0;
}

// Light outlines in their own plane (z = 0 in world space), counter-clockwise seen from +z.
struct Shape {
  const char *name;
  std::vector<std::pair<double, double>> xy;
};
const std::vector<Shape> &Shapes() {
  static const std::vector<Shape> shapes = [] {
    std::vector<Shape> s = {{"quad", {{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}}},
                            {"triangle", {{-0.6, -0.4}, {0.7, -0.3}, {-0.1, 0.6}}},
                            {"hexagon", {}}};
    for (int k = 0; k < 6; ++k)
      s[2].xy.push_back({0.6 * std::cos(kPi * k / 3), 0.6 * std::sin(kPi * k / 3)});
    return s;
  }();
  return shapes;
}

// A placement of a shape in the shading point's local frame: centre at `distance` along
// elevation `elevation_deg` (azimuth 0), plane normal turned from facing the point by `tilt_deg`
// about the local y axis.
struct Placement {
  int shape;
  double distance, elevation_deg, tilt_deg;
};

// Rows of the local -> light-plane rotation (p1 and p2 span the light's plane, p3 is its
// emitting normal, towards the shading point) and the light's centre in the local frame.
struct Pose {
  D3 p1, p2, p3, centre;
};
Pose PoseOf(const Placement &pl) {
  Pose p;
  const double e = Rad(pl.elevation_deg), t = Rad(pl.tilt_deg);
  p.centre = D3{std::cos(e), 0, std::sin(e)} * pl.distance;
  // -centre direction, rotated by t about y (perpendicular to it).
  const D3 n = {-std::cos(e), 0, -std::sin(e)};
  p.p3 = {n.x * std::cos(t) + n.z * std::sin(t), 0, -n.x * std::sin(t) + n.z * std::cos(t)};
  p.p2 = {0, 1, 0};
  p.p1 = Cross(p.p2, p.p3);
  return p;
}

std::vector<D3> LocalPolygon(const Placement &pl) {
  const Pose p = PoseOf(pl);
  std::vector<D3> v;
  for (auto [sx, sy] : Shapes()[size_t(pl.shape)].xy) v.push_back(p.centre + p.p1 * sx + p.p2 * sy);
  return v;
}

// Solid angle of the (unclipped) polygon seen from the origin: fan of Van Oosterom-Strackee
// triangles.
double SolidAngle(const std::vector<D3> &v) {
  double sum = 0;
  const D3 a = Normalize(v[0]);
  for (size_t i = 1; i + 1 < v.size(); ++i) {
    const D3 b = Normalize(v[i]), c = Normalize(v[i + 1]);
    sum += 2 * std::atan2(std::fabs(Dot(a, Cross(b, c))), 1 + Dot(a, b) + Dot(b, c) + Dot(c, a));
  }
  return sum;
}

// Fraction of the polygon's solid angle below the local horizon (for the placement listing):
// midpoint rule over each fan triangle's area, (s, t) -> v0 + s (1 - t) e1 + s t e2 with
// Jacobian s, weighted by dw / dA = |n . p| / r^3.
double BelowFraction(const std::vector<D3> &v) {
  double below = 0, total = 0;
  const D3 n = Normalize(Cross(v[1] - v[0], v[2] - v[0]));
  for (size_t k = 1; k + 1 < v.size(); ++k) {
    const double area = 0.5 * std::sqrt(Dot(Cross(v[k] - v[0], v[k + 1] - v[0]),
                                            Cross(v[k] - v[0], v[k + 1] - v[0])));
    for (int i = 0; i < 128; ++i)
      for (int j = 0; j < 128; ++j) {
        const double s = (i + 0.5) / 128, t = (j + 0.5) / 128;
        const D3 p = v[0] + (v[k] - v[0]) * (s * (1 - t)) + (v[k + 1] - v[0]) * (s * t);
        const double w = area * s * std::fabs(Dot(n, p)) / std::pow(Dot(p, p), 1.5);
        total += w;
        if (p.z < 0) below += w;
      }
  }
  return below / total;
}

struct Sweep {
  std::vector<double> alphas;
  std::vector<Placement> placements;
  std::vector<double> views_deg, azimuths_deg;
};

Sweep MakeSweep(bool quick) {
  Sweep s;
  // Unit-square distances giving solid angles ~1e-3, 1e-2, 0.1, 0.5, 2 and 6.06 sr on axis.
  const double d_square[] = {31.6, 10.0, 3.12, 1.325, 0.521, 0.02};
  if (quick) {
    s.alphas = {0.03, 0.2, 0.7};
    for (double d : {10.0, 1.325, 0.02})
      for (double el : {90.0, 20.0}) s.placements.push_back({0, d, el, 0});
    s.placements.push_back({0, 1.0, 5, 0});
    s.placements.push_back({1, 3.12, 60, 0});
    s.placements.push_back({2, 0.521, 30, 0});
    s.views_deg = {0, 40, 75, 89};
    s.azimuths_deg = {180, 0};
    return s;
  }
  s.alphas = {0.01, 0.03, 0.1, 0.2, 0.4, 0.7, 1.0};
  for (double d : d_square)
    for (double el : {90.0, 50.0, 20.0}) s.placements.push_back({0, d, el, 0});
  s.placements.push_back({0, 1.0, 5, 0});    // centre near the horizon: half below
  s.placements.push_back({0, 0.7, 10, 40});  // tilted, partly below
  for (int shape : {1, 2}) {
    for (double d : {3.12, 0.521})
      for (double el : {70.0, 30.0}) s.placements.push_back({shape, d, el, 0});
    s.placements.push_back({shape, 10.0, 45, 25});
  }
  s.views_deg = {0, 20, 40, 60, 75, 85, 89};
  s.azimuths_deg = {180, 90, 0};
  return s;
}

void Add3(google::protobuf::RepeatedField<float> *f, D3 v) {
  f->Add(float(v.x));
  f->Add(float(v.y));
  f->Add(float(v.z));
}

// One request per (alpha, shape): the shape in world space, one query per (placement of that
// shape, view, azimuth) with the frame that puts the light where the placement says.
struct QueryInfo {
  size_t placement;
  double view_deg, azimuth_deg;
  D3 wo;  // local
};

glint::v1::EvaluateRequest MakeRequest(const Sweep &sw, int ndf, double alpha, int shape,
                                       std::vector<QueryInfo> *info) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::SMOOTH);
  m->set_ndf(ndf == 2 ? glint::v1::BECKMANN : glint::v1::GGX);
  m->set_alpha_x(float(alpha));
  m->set_alpha_y(float(alpha));
  for (int c = 0; c < 3; ++c) m->mutable_schlick()->add_f0(1.0f);
  auto *poly = r.add_lights()->mutable_polygon();
  for (auto [x, y] : Shapes()[size_t(shape)].xy) {
    poly->add_vertices(float(x));
    poly->add_vertices(float(y));
    poly->add_vertices(0.0f);
  }
  for (int c = 0; c < 3; ++c) poly->add_radiance(1.0f);
  poly->set_two_sided(false);
  r.set_seed(1);
  auto *q = r.mutable_queries();
  uint32_t n = 0;
  for (size_t k = 0; k < sw.placements.size(); ++k) {
    const Placement &pl = sw.placements[k];
    if (pl.shape != shape) continue;
    const Pose p = PoseOf(pl);
    // local -> world: x -> (p1.x, p2.x, p3.x) etc. (the rows p1, p2, p3 map onto the axes),
    // and the shading point (local origin) sits at -(p1.c, p2.c, p3.c).
    auto to_world = [&](D3 v) { return D3{Dot(p.p1, v), Dot(p.p2, v), Dot(p.p3, v)}; };
    const D3 position = to_world(p.centre) * -1.0;
    for (double view : sw.views_deg) {
      for (double az : sw.azimuths_deg) {
        const double t = Rad(view), a = Rad(az);
        const D3 wo = {std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t)};
        Add3(q->mutable_wo(), to_world(wo));
        Add3(q->mutable_position(), position);
        Add3(q->mutable_normal(), to_world({0, 0, 1}));
        Add3(q->mutable_tangent(), to_world({1, 0, 0}));
        info->push_back({k, view, az, wo});
        ++n;
      }
    }
  }
  q->set_count(n);
  return r;
}

// ---------------------------------------------------------------------------------------------
// Truth by nested globally adaptive Gauss-Kronrod (7-15) over the light's plane, in double (the
// scheme of tests/area/area_lights_test.cpp PlaneAdaptive, where it is checked against a
// brute-force hemisphere integration and against REFERENCE to ~1e-7). The polygon is clipped to
// the horizon in its plane, every row has exact x-limits, x = d tan u, y = d tan v keeps huge
// lights finite, and breakpoints at the vertex rows and graded ones around the mirror direction
// let the adaptivity resolve alpha = 0.01. Unlike REFERENCE it stays accurate for
// hemisphere-filling lights at grazing views (REFERENCE-1024 is off by up to 10% there: see the
// introduction, and
// --truth reference).
// L * int_P f cos_i dwi (red channel, grey Schlick f0 = 1, radiance 1) for a polygon given in
// the local frame (one-sided, facing the origin) and a local wo.
double PlaneAdaptive(int ndf, double alpha, D3 wo, const std::vector<D3> &poly, double rel_tol) {
  using glint::test::plane::Vec;
  kd::SmoothMaterial m;
  m.ndf = ndf;
  m.alpha_x = m.alpha_y = alpha;
  m.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m.fresnel.a = kd::make_real3(1.0, 1.0, 1.0);
  m.fresnel.b = kd::make_real3(0.0, 0.0, 0.0);
  std::vector<Vec> p;
  for (D3 v : poly) p.push_back({v.x, v.y, v.z});
  auto f_cos = [&](Vec wi, Vec o) {
    return kd::smooth_reflect_cos(m, kd::make_real3(wi.x, wi.y, wi.z),
                                  kd::make_real3(o.x, o.y, o.z))
        .x;
  };
  return glint::test::plane::PlaneAdaptive(f_cos, {wo.x, wo.y, wo.z}, p, rel_tol);
}

int TruthSamples(double alpha) {
  return alpha < 0.02 ? 1024 : alpha < 0.06 ? 512 : 256;
}

// Truth (red channel) of every query of every request: REFERENCE fp64 on the host path, chunks
// of 32 queries spread over `threads` threads.
std::vector<std::vector<double>> Truth(const std::vector<glint::v1::EvaluateRequest> &requests,
                                       const std::vector<std::vector<QueryInfo>> &infos,
                                       const Sweep &sw, bool use_reference, int threads) {
  struct Job {
    size_t request;
    uint32_t begin, end;
  };
  std::vector<Job> jobs;
  std::vector<std::vector<double>> truth(requests.size());
  std::vector<glint::EvalPlan> plans;
  for (size_t r = 0; r < requests.size(); ++r) {
    glint::v1::EvaluateRequest t = requests[r];
    t.set_precision(glint::v1::FP64);
    t.set_area_method(glint::v1::REFERENCE);
    t.set_area_samples(uint32_t(TruthSamples(t.material().alpha_x())));
    plans.push_back(glint::MakeEvalPlan(t, t.queries()));
    const uint32_t n = t.queries().count();
    truth[r].assign(n, 0.0);
    for (uint32_t b = 0; b < n; b += 32) jobs.push_back({r, b, std::min(n, b + 32)});
  }
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t j; (j = next.fetch_add(1)) < jobs.size();) {
      const Job &job = jobs[j];
      if (!use_reference) {
        const auto &mat = requests[job.request].material();
        const int ndf = mat.ndf() == glint::v1::BECKMANN ? 2 : 1;
        for (uint32_t i = job.begin; i < job.end; ++i) {
          const QueryInfo &qi = infos[job.request][i];
          truth[job.request][i] = PlaneAdaptive(ndf, mat.alpha_x(), qi.wo,
                                                LocalPolygon(sw.placements[qi.placement]), 1e-7);
        }
        continue;
      }
      glint::v1::QueryBatch s =
          glint::client::SliceQueries(requests[job.request].queries(), job.begin, job.end);
      std::vector<float> out(3 * size_t(s.count()));
      glint::HostEvaluate(plans[job.request], s, out.data());
      for (uint32_t i = 0; i < s.count(); ++i) truth[job.request][job.begin + i] = out[3 * i];
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work);
  for (auto &t : pool) t.join();
  return truth;
}

using Stats = glint::bench::ErrorStats;
using glint::bench::Summarise;

using Method = glint::bench::AreaMethodChoice;

struct Row {
  std::string ndf, method, status;
  uint32_t samples = 0;
  double evals_per_s = NAN;
  uint64_t queries = 0;
  Stats all{NAN, NAN, NAN}, band[3] = {{NAN, NAN, NAN}, {NAN, NAN, NAN}, {NAN, NAN, NAN}};
  struct Worst {
    double error, value;
    size_t request;
    uint32_t query;
  };
  std::vector<Worst> worst;  // largest errors first (--worst N)
};

int Band(double alpha) {
  return alpha < 0.1 ? 0 : alpha <= 0.4 ? 1 : 2;
}
const char *kBandNames[3] = {"alpha < 0.1", "0.1-0.4", "alpha > 0.4"};

std::string Fmt(double v, const char *f = "%.3g") {
  if (std::isnan(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

Row Measure(glint::DeviceEngine &engine, const Method &me, int ndf,
            const std::vector<glint::v1::EvaluateRequest> &base,
            const std::vector<std::vector<double>> &truth, double floor, int repeat,
            size_t n_worst) {
  Row row;
  row.ndf = ndf == 2 ? "beckmann" : "ggx";
  row.method = glint::v1::AreaMethod_Name(me.method);
  row.samples = me.samples;
  glint::ValidationLimits limits;
  limits.fp64_available = engine.info().fp64;
  std::vector<double> errors, band_errors[3];
  double seconds = 0;
  for (size_t r = 0; r < base.size(); ++r) {
    glint::v1::EvaluateRequest req = base[r];
    req.set_precision(glint::v1::FP32);
    req.set_area_method(me.method);
    req.set_area_samples(me.samples);
    glint::Status s = glint::ValidateSettings(req, limits);
    if (s.ok()) s = glint::ValidateQueries(req.queries(), true, limits);
    if (!s.ok()) {
      row.status = "not available: " + s.message();
      return row;
    }
    const glint::EvalPlan plan = glint::MakeEvalPlan(req, req.queries());
    const uint32_t n = req.queries().count();
    std::vector<float> out(3 * size_t(n));
    // Twice untimed: compile + first-enqueue work, then a clean time to size the tiling.
    double t_single = 0;
    for (int k = 0; k < 2; ++k) {
      auto t0 = Clock::now();
      s = engine.Evaluate(0, plan, req.queries(), out.data());
      t_single = std::chrono::duration<double>(Clock::now() - t0).count();
      if (!s.ok()) {
        row.status = "failed: " + s.message();
        return row;
      }
    }
    const double alpha = req.material().alpha_x();
    for (uint32_t i = 0; i < n; ++i) {
      const double ref = truth[r][i], x = out[3 * i];
      const double e = std::fabs(x - ref) / std::max(ref, floor);
      errors.push_back(std::isfinite(x) ? e : INFINITY);
      band_errors[Band(alpha)].push_back(errors.back());
      row.worst.push_back({errors.back(), x, r, i});
    }
    // Grow the timed batch (the request's queries repeated) until one run takes >= 50 ms, so
    // buffer set-up and the launch are amortised.
    const uint32_t max_tiles = std::max(1u, glint::ValidationLimits{}.max_batch / n);
    uint32_t tiles = 1;
    double t_run = t_single;
    glint::v1::QueryBatch big = req.queries();
    while (t_run < 0.05 && tiles < max_tiles) {
      const double grow = std::clamp(0.06 / std::max(t_run, 1e-6), 2.0, 64.0);
      tiles = uint32_t(std::min(double(max_tiles), std::ceil(tiles * grow)));
      big = glint::bench::Tile(req.queries(), tiles * n);
      std::vector<float> tmp(3 * size_t(big.count()));
      auto t0 = Clock::now();
      s = engine.Evaluate(0, plan, big, tmp.data());
      t_run = std::chrono::duration<double>(Clock::now() - t0).count();
      if (!s.ok()) {
        row.status = "failed: " + s.message();
        return row;
      }
    }
    std::vector<float> big_out(3 * size_t(big.count()));
    std::vector<double> t;
    for (int k = 0; k < repeat; ++k) {
      auto t0 = Clock::now();
      s = engine.Evaluate(0, plan, big, big_out.data());
      t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
      if (!s.ok()) {
        row.status = "failed: " + s.message();
        return row;
      }
    }
    std::sort(t.begin(), t.end());
    seconds += t[t.size() / 2];
    row.queries += big.count();
  }
  const size_t keep = std::min(n_worst, row.worst.size());
  std::partial_sort(row.worst.begin(), row.worst.begin() + long(keep), row.worst.end(),
                    [](const Row::Worst &a, const Row::Worst &b) { return a.error > b.error; });
  row.worst.resize(keep);
  row.status = "ok";
  row.evals_per_s = double(row.queries) / seconds;
  row.all = Summarise(errors);
  for (int b = 0; b < 3; ++b) row.band[b] = Summarise(band_errors[b]);
  return row;
}

}  // namespace

int main(int argc, char **argv) {
  bool quick = false, beckmann = false;
  int repeat = -1;
  size_t n_worst = 0;
  bool truth_reference = false;
  std::string csv;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick")
      quick = true;
    else if (a == "--beckmann")
      beckmann = true;
    else if (a == "--csv" && i + 1 < argc)
      csv = argv[++i];
    else if (a == "--truth" && i + 1 < argc) {
      const std::string t = argv[++i];
      if (t != "adaptive" && t != "reference") {
        std::fprintf(stderr, "--truth adaptive|reference\n");
        return 2;
      }
      truth_reference = t == "reference";
    } else if (a == "--worst" && i + 1 < argc)
      n_worst = size_t(std::stoul(argv[++i]));
    else if (a == "--repeat" && i + 1 < argc)
      repeat = std::stoi(argv[++i]);
    else {
      std::fprintf(stderr,
                   "usage: bench_area [--quick] [--beckmann] [--csv FILE] [--repeat R] [--worst N] "
                   "[--truth adaptive|reference]\n");
      return 2;
    }
  }
  if (repeat < 1) repeat = quick ? 3 : 5;
  const Sweep sw = MakeSweep(quick);
  const std::vector<Method> &methods = glint::bench::AreaMethodChoices();

  std::unique_ptr<glint::DeviceEngine> engine;
  glint::Status st = glint::bench::CreateEngine(glint::bench::DefaultCacheDir(), &engine);
  if (!st.ok()) {
    std::fprintf(stderr, "%s\n", st.message().c_str());
    return 1;
  }

  std::printf("# Polygon lights on the smooth model: speed vs accuracy%s\n\n",
              quick ? " (--quick sweep)" : "");
  std::printf("device: %s, fp32, 1 lane; median of %d runs per request\n\n",
              engine->info().name.c_str(), repeat);
  std::printf(
      "light placements (local frame; solid angle of the whole polygon, part below the "
      "horizon):\n\n| shape | distance | elevation | tilt | solid angle [sr] | below |\n"
      "|---|---|---|---|---|---|\n");
  for (const Placement &pl : sw.placements) {
    const auto v = LocalPolygon(pl);
    std::printf("| %s | %g | %g | %g | %.3g | %.0f%% |\n", Shapes()[size_t(pl.shape)].name,
                pl.distance, pl.elevation_deg, pl.tilt_deg, SolidAngle(v), 100 * BelowFraction(v));
  }
  std::printf("\n");

  std::vector<Row> rows;
  for (int ndf : beckmann ? std::vector<int>{1, 2} : std::vector<int>{1}) {
    std::vector<glint::v1::EvaluateRequest> requests;
    std::vector<std::vector<QueryInfo>> infos;
    for (double alpha : sw.alphas)
      for (int shape = 0; shape < int(Shapes().size()); ++shape) {
        std::vector<QueryInfo> info;
        glint::v1::EvaluateRequest r = MakeRequest(sw, ndf, alpha, shape, &info);
        if (r.queries().count() == 0) continue;
        requests.push_back(std::move(r));
        infos.push_back(std::move(info));
      }
    uint64_t n_queries = 0;
    for (const auto &r : requests) n_queries += r.queries().count();
    auto t0 = Clock::now();
    const auto truth = Truth(requests, infos, sw, truth_reference, 2);
    const double t_truth = std::chrono::duration<double>(Clock::now() - t0).count();
    double top = 0;
    for (const auto &t : truth)
      for (double v : t) top = std::max(top, v);
    const double floor = 1e-3 * top;
    const char *ndf_name = ndf == 2 ? "Beckmann" : "GGX";
    std::printf(
        "## %s: %zu requests, %llu queries; truth %s in %.1f s; largest truth %.3f, "
        "error floor %.2e\n\n",
        ndf_name, requests.size(), (unsigned long long)n_queries,
        truth_reference ? "REFERENCE fp64 host (1024/512/256 nodes for alpha "
                          "<0.02/<0.06/else)"
                        : "adaptive plane integration fp64 (rel. tol. 1e-7)",
        t_truth, top, floor);
    std::printf(
        "| method | samples | evals/s | mean | p95 | max | %s mean/p95/max | %s "
        "mean/p95/max | %s mean/p95/max |\n|---|---|---|---|---|---|---|---|---|\n",
        kBandNames[0], kBandNames[1], kBandNames[2]);
    std::fflush(stdout);
    for (const Method &me : methods) {
      Row row = Measure(*engine, me, ndf, requests, truth, floor, repeat, n_worst);
      if (row.status != "ok") {
        std::printf("| %s | %u | %s | | | | | | |\n", row.method.c_str(), row.samples,
                    row.status.c_str());
      } else {
        std::string bands[3];
        for (int b = 0; b < 3; ++b)
          bands[b] =
              Fmt(row.band[b].mean) + " / " + Fmt(row.band[b].p95) + " / " + Fmt(row.band[b].max);
        std::printf("| %s | %u | %s M | %s | %s | %s | %s | %s | %s |\n", row.method.c_str(),
                    row.samples, Fmt(row.evals_per_s / 1e6, "%.3g").c_str(),
                    Fmt(row.all.mean).c_str(), Fmt(row.all.p95).c_str(), Fmt(row.all.max).c_str(),
                    bands[0].c_str(), bands[1].c_str(), bands[2].c_str());
      }
      std::fflush(stdout);
      rows.push_back(row);
    }
    std::printf("\n");
    for (const Row &row : rows) {
      if (row.worst.empty() || row.ndf != (ndf == 2 ? "beckmann" : "ggx")) continue;
      std::printf(
          "worst %s %u (alpha, shape, distance, elevation, tilt, view, azimuth: "
          "value vs truth, error):\n",
          row.method.c_str(), row.samples);
      for (const Row::Worst &w : row.worst) {
        const QueryInfo &qi = infos[w.request][w.query];
        const Placement &pl = sw.placements[qi.placement];
        std::printf("  %g %s %g %g %g %g %g: %.4g vs %.4g, %.3g\n",
                    requests[w.request].material().alpha_x(), Shapes()[size_t(pl.shape)].name,
                    pl.distance, pl.elevation_deg, pl.tilt_deg, qi.view_deg, qi.azimuth_deg,
                    w.value, truth[w.request][w.query], w.error);
      }
    }
    std::printf("\n");
  }

  if (!csv.empty()) {
    std::ofstream f(csv);
    if (!f) {
      std::fprintf(stderr, "cannot write %s\n", csv.c_str());
      return 1;
    }
    f << "ndf,method,samples,evals_per_s,mean,p95,max,mean_lo,p95_lo,max_lo,mean_mid,p95_mid,"
         "max_mid,mean_hi,p95_hi,max_hi,status\n";
    auto num = [](double v) { return std::isnan(v) ? std::string() : Fmt(v, "%.6g"); };
    for (const Row &r : rows) {
      std::string status = r.status;
      std::replace(status.begin(), status.end(), '"', '\'');
      f << r.ndf << ',' << r.method << ',' << r.samples << ',' << num(r.evals_per_s) << ','
        << num(r.all.mean) << ',' << num(r.all.p95) << ',' << num(r.all.max);
      for (const Stats &b : r.band)
        f << ',' << num(b.mean) << ',' << num(b.p95) << ',' << num(b.max);
      f << ",\"" << status << "\"\n";
    }
    std::printf("wrote %s\n", csv.c_str());
  }
  return 0;
}
