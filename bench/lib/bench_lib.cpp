#include "bench/lib/bench_lib.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <sstream>

#include "client/lib/glint_client.h"
#include "server/validation.h"
#include "test_queries.h"

namespace glint::bench {

glint::v1::QueryBatch Tile(const glint::v1::QueryBatch &base, uint32_t count) {
  glint::v1::QueryBatch out;
  const uint32_t n = base.count();
  for (uint32_t done = 0; done < count;) {
    const uint32_t part = std::min(n, count - done);
    // MergeFrom appends every repeated field, so a field added to QueryBatch later is tiled too.
    out.MergeFrom(glint::client::SliceQueries(base, 0, part));
    done += part;
  }
  out.set_count(count);
  return out;
}

glint::v1::QueryBatch SharedQueries(uint32_t count, bool probe) {
  return glint::test::RandomQueries(count, probe, false, 42);
}

QueryStats StatsOf(const glint::v1::QueryBatch &q) {
  QueryStats s;
  double area = 0;
  for (uint32_t i = 0; i < q.count() && q.footprint_size() >= 4 * int(q.count()); ++i) {
    const float *f = q.footprint().data() + 4 * i;
    area += std::fabs(double(f[0]) * f[3] - double(f[2]) * f[1]);
  }
  s.mean_footprint_area = q.count() ? area / q.count() : 0;
  return s;
}

const char *LightsName(Lights l) {
  switch (l) {
    case Lights::kProbe:
      return "probe";
    case Lights::kDirectionalPoint:
      return "directional_point";
    case Lights::kQuad:
      return "quad";
    case Lights::kFourQuads:
      return "four_quads";
  }
  return "?";
}

bool HasPolygons(Lights l) {
  return l == Lights::kQuad || l == Lights::kFourQuads;
}

namespace {

void AddQuad(glint::v1::EvaluateRequest *r, std::initializer_list<float> vertices,
             std::initializer_list<float> radiance) {
  auto *p = r->add_lights()->mutable_polygon();
  for (float v : vertices) p->add_vertices(v);
  for (float v : radiance) p->add_radiance(v);
  p->set_two_sided(true);
}

}  // namespace

void AddLights(Lights lights, glint::v1::EvaluateRequest *r) {
  switch (lights) {
    case Lights::kProbe:
      return;
    case Lights::kDirectionalPoint: {
      // Finite sizes because the BINOMIAL model refuses delta lights; the smooth model shades
      // them as a direction and a point.
      auto *d = r->add_lights()->mutable_directional();
      for (float v : {0.6f, 0.0f, 0.8f}) d->add_direction(v);
      for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
      d->set_cone_half_angle_deg(0.5f);
      auto *p = r->add_lights()->mutable_point();
      for (float v : {-1.0f, 2.0f, 3.0f}) p->add_position(v);
      for (float v : {5.0f, 5.0f, 4.0f}) p->add_intensity(v);
      p->set_radius(0.1f);
      return;
    }
    case Lights::kQuad:
      AddQuad(r, {-3, -3, 3, 3, -3, 3, 3, 3, 3, -3, 3, 3}, {1.0f, 0.5f, 0.25f});
      return;
    case Lights::kFourQuads:
      // A softbox-like rig: key, fill, a tilted rim and a small high light.
      AddQuad(r, {0.5f, -0.5f, 2, 1.5f, -0.5f, 2, 1.5f, 0.5f, 2, 0.5f, 0.5f, 2}, {4, 4, 4});
      AddQuad(r, {-2, -1, 2.5f, -1, -1, 2.5f, -1, 0, 2.5f, -2, 0, 2.5f}, {1, 1.5f, 2});
      AddQuad(r, {-0.5f, 1.5f, 1, 0.5f, 1.5f, 1, 0.5f, 2, 2, -0.5f, 2, 2}, {2, 1, 0.5f});
      AddQuad(r, {-0.5f, -0.5f, 4, 0.5f, -0.5f, 4, 0.5f, 0.5f, 4, -0.5f, 0.5f, 4}, {8, 8, 8});
      return;
  }
}

Status Validate(const glint::v1::EvaluateRequest &request, bool fp64_available) {
  ValidationLimits limits;
  limits.fp64_available = fp64_available;
  Status s = ValidateSettings(request, limits);
  if (s.ok()) s = ValidateQueries(request.queries(), request.lights_size() > 0, limits);
  if (s.ok()) s = ValidateQueriesForModel(request.queries(), request);
  return s;
}

std::set<std::string> SplitList(const std::string &s) {
  std::set<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.insert(item);
  return out;
}

std::string DefaultCacheDir() {
  if (const char *d = std::getenv("GLINT_CACHE_DIR")) return d;
  if (const char *x = std::getenv("XDG_CACHE_HOME")) return std::string(x) + "/glint";
  if (const char *h = std::getenv("HOME")) return std::string(h) + "/.cache/glint";
  return "";
}

Status CreateEngine(const std::string &cache_dir, std::unique_ptr<DeviceEngine> *engine,
                    bool ltc_only_programs) {
  DeviceEngineOptions options;
  options.workers = 1;
  options.cache_dir = cache_dir;
  options.ltc_only_programs = ltc_only_programs;
  return DeviceEngine::Create(options, engine);
}

ErrorStats Summarise(std::vector<double> e) {
  if (e.empty()) return {NAN, NAN, NAN};
  std::sort(e.begin(), e.end());
  double sum = 0;
  for (double x : e) sum += x;
  const size_t p95 = std::min(e.size() - 1, size_t(std::ceil(0.95 * double(e.size()))) - 1);
  return {sum / double(e.size()), e[p95], e.back()};
}

std::vector<double> RgbSums(const float *rgb, uint32_t n) {
  std::vector<double> s(n);
  for (uint32_t i = 0; i < n; ++i) s[i] = double(rgb[3 * i]) + rgb[3 * i + 1] + rgb[3 * i + 2];
  return s;
}

std::vector<double> RelativeErrors(const float *x, const std::vector<double> &ref_sum, double floor,
                                   uint32_t *nonfinite) {
  const std::vector<double> xs = RgbSums(x, uint32_t(ref_sum.size()));
  std::vector<double> e;
  e.reserve(ref_sum.size());
  *nonfinite = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    if (std::isfinite(xs[i]))
      e.push_back(std::fabs(xs[i] - ref_sum[i]) / std::max(ref_sum[i], floor));
    else
      ++*nonfinite;
  }
  return e;
}

double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace glint::bench
