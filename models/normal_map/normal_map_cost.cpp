#include "models/normal_map/normal_map_cost.h"

#include <algorithm>
#include <cassert>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <cstdio>

#include "server/normal_map_store.h"

// The kernel's own footprint (covariance, clamp, large-footprint limit, period copies), in
// double: the cost counts the loops of the code that runs, it does not restate them.
namespace glint::nm_cost {
#define GLINT_USE_DOUBLE 1
#include "models/normal_map/normal_map_pndf.h"
}  // namespace glint::nm_cost

namespace glint {
namespace {

// Cost units (server/request_cost.cpp: one unit ~50 ns of the loaded 2-core PoCL device) per
// triangle one P-NDF evaluation integrates, and per evaluation besides its triangles (the
// footprint, the quadtree root, the period loop). Measured on the loaded shared machine with
// bench/bench_normal_map_cost.cpp (a flat map queried at its normal, nothing pruned: every cell
// in the box integrated): see models/normal_map/README.md "Cost".
constexpr double kUnitsPerTriangle = 10.0;
constexpr double kUnitsPerEvaluation = 200.0;

// Cells i in [0, n) of one period copy, centre c (vertex coordinates, already shifted into the
// copy) and half-width b, that nm_space_culled keeps: not (i + 1 < c - b) and not (i > c + b).
double AxisCells(double n, double c, double b) {
  const double lo = std::max(0.0, std::ceil(c - b - 1.0));
  const double hi = std::min(n - 1.0, std::floor(c + b));
  return hi >= lo ? hi - lo + 1.0 : 0.0;
}

std::string Format(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

}  // namespace

double NormalMapFootprintCells(uint32_t W, uint32_t H, float u, float v, const float fp[4],
                               float cutoff) {
  // Non-finite uv (refused later by query validation, which runs after admission): the
  // kernel's period copies would be undefined; count the most a box at most
  // GLINT_NM_MAX_PERIODS wide can reach, 3 copies of each axis.
  const double most = 9.0 * double(W) * double(H);
  if (!std::isfinite(u) || !std::isfinite(v)) return most;
  const float header[3] = {float(W), float(H), 0.0f};
  double f[4] = {fp[0], fp[1], fp[2], fp[3]};
  int k[4];
  nm_cost::NmQuery q = nm_cost::nm_footprint(header, u, v, f, cutoff, k);
  if (!std::isfinite(q.cx) || !std::isfinite(q.cy) || !std::isfinite(q.box_x) ||
      !std::isfinite(q.box_y) || k[1] - k[0] > 2 || k[3] - k[2] > 2)
    return most;
  double nx = 0, ny = 0;
  for (int kx = k[0]; kx <= k[1]; ++kx) nx += AxisCells(W, q.cx - double(kx) * W, q.box_x);
  for (int ky = k[2]; ky <= k[3]; ++ky) ny += AxisCells(H, q.cy - double(ky) * H, q.box_y);
  return nx * ny;
}

bool NormalMapQueryCosts(const glint::v1::EvaluateRequest &settings, const glint::v1::QueryBatch &q,
                         uint64_t first_query, double *max_units, double *sum_units,
                         std::string *parts) {
  const auto &p = settings.material().normal_map();
  const uint32_t n = q.count();
  if (n == 0 || q.footprint_size() != int64_t(n) * 4 || q.uv_size() != int64_t(n) * 2) return false;
  NormalMapTable table;  // subdivision 1 is stored at upload: only its header is read
  if (!NormalMaps().Table(p.digest(), 1, &table).ok() || !table || table->size() < 2) return false;
  const int subdivision = p.subdivision() == 4 ? 4 : 1;
  const uint32_t W = uint32_t((*table)[0]) * subdivision, H = uint32_t((*table)[1]) * subdivision;
  const float cutoff = p.cutoff_sigma() > 0 ? p.cutoff_sigma() : GLINT_NM_DEFAULT_CUTOFF;
  // P-NDF evaluations per query: one per point or directional light (one for a probe, or when
  // nothing else runs: normal_map_model.cpp HasProbesOrPunctualLights); per polygon light
  // area_samples light samples and as many P-NDF samples, each at most one evaluation
  // (normal_map_polygons.h nm_polygon_integral).
  int punctual = 0, polygons = 0;
  for (const auto &light : settings.lights()) (light.has_polygon() ? polygons : punctual) += 1;
  const double samples = settings.area_samples() ? settings.area_samples() : 64;
  const double evaluations =
      double(punctual > 0 || polygons == 0 ? std::max(punctual, 1) : 0) + polygons * 2.0 * samples;
  double worst = 0, sum = 0, worst_cells = 0;
  uint32_t worst_query = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const double cells = NormalMapFootprintCells(W, H, q.uv(2 * i), q.uv(2 * i + 1),
                                                 q.footprint().data() + 4 * size_t(i), cutoff);
    const double units =
        1.0 + evaluations * (kUnitsPerEvaluation + kUnitsPerTriangle * 2.0 * cells);
    if (units > worst) {
      worst = units;
      worst_cells = cells;
      worst_query = i;
    }
    sum += units;
  }
  *max_units = worst;
  *sum_units = sum;
  *parts = Format(evaluations) + " P-NDF evaluations x up to " + Format(2.0 * worst_cells) +
           " triangles in query " + std::to_string(first_query + worst_query) +
           "'s footprint cut-off box (" + std::to_string(W) + " x " + std::to_string(H) +
           " vertex map, cutoff_sigma " + Format(cutoff) + ")";
  return true;
}

std::string NormalMapPolygonMethod(const glint::v1::EvaluateRequest &settings) {
  const std::string n = std::to_string(settings.area_samples() ? settings.area_samples() : 64);
  return "NORMAL_MAP's own MIS (" + n + " light + " + n +
         " P-NDF samples, area_samples; area_method does not apply)";
}

}  // namespace glint
