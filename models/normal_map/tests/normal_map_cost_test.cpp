// NORMAL_MAP's admission cost per query (models/normal_map/normal_map_cost.h): the cells its
// footprint's cut-off box reaches against the kernel's own triangle count (NmStats, host fp64)
// on a flat map queried at its normal, where nothing is pruned by the normals, and against an
// explicit count of the cells overlapping the box; the count grows as footprint^2 until the
// 2-period clamp and is the whole period in the large-footprint limit. Admission: the outside
// probe's request (issue 12: a 1 x 4097 map, subdivision 4, cut-off 10, a huge quad; ~20 s a
// query) is refused naming the cost, the query and --max-query-cost; ordinary requests are not.
#include "models/normal_map/normal_map_cost.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "models/normal_map/normal_map_table.h"
#include "server/batch_eval.h"
#include "server/normal_map_store.h"
#include "server/request_cost.h"
#include "tests/support/kernels_both_precisions.h"

namespace glint {
namespace {

// A flat W x H map ((s, t) = 0 everywhere) at `subdivision`.
std::vector<float> FlatTable(uint32_t w, uint32_t h, int subdivision) {
  return BuildNormalMapTable(w, h, std::vector<float>(size_t(w) * h * 2, 0.0f), subdivision);
}

// Triangles the kernel integrates for D(0, 0): none is pruned by the normals' cut-off.
uint32_t KernelTriangles(const std::vector<float> &table, double u, double v, const float fp[4],
                         double cutoff) {
  const double f[4] = {fp[0], fp[1], fp[2], fp[3]};
  k64::NmStats stats{};
  k64::nm_pndf(table.data(), u, v, f, 0.0, 0.0, 0.05, cutoff, &stats);
  return stats.triangles;
}

// Cells [i, i+1] x [j, j+1] (vertex coordinates, any period copy) overlapping the box of
// half-widths (bx, by) about (cx, cy), counted one by one.
double CellsOverlapping(double cx, double cy, double bx, double by) {
  double n = 0;
  for (double j = std::floor(cy - by) - 2; j <= cy + by + 2; ++j)
    for (double i = std::floor(cx - bx) - 2; i <= cx + bx + 2; ++i)
      n += (i + 1 >= cx - bx && i <= cx + bx && j + 1 >= cy - by && j <= cy + by) ? 1 : 0;
  return n;
}

TEST(NormalMapCost, CellsAreTheKernelsTrianglesOnAFlatMap) {
  struct Case {
    uint32_t w, h;
    int subdivision;
    float u, v, fp[4], cutoff;
  };
  const Case cases[] = {
      {16, 16, 1, 0.5f, 0.5f, {0.0f, 0.0f, 0.0f, 0.0f}, 5},        // the 0.01-texel floor
      {16, 16, 1, 0.5f, 0.5f, {0.125f, 0.0f, 0.0f, 0.125f}, 5},    // 1 texel
      {16, 16, 1, 0.03f, 0.97f, {0.125f, 0.0f, 0.0f, 0.125f}, 3},  // across the period's edges
      {16, 16, 1, 0.3f, 0.6f, {0.1f, 0.05f, -0.02f, 0.03f}, 10},   // sheared, anisotropic
      {16, 16, 1, 0.2f, 0.7f, {0.5f, 0.0f, 0.0f, 0.5f}, 5},        // the 2-period clamp
      {16, 16, 1, 0.2f, 0.7f, {3.0f, 0.0f, 0.0f, 3.0f}, 5},        // the large-footprint limit
      {7, 5, 1, 0.9f, 0.1f, {0.2f, 0.0f, 0.0f, 0.3f}, 4},          // odd sizes
      {1, 33, 4, 0.5f, 0.5f, {1.0f, 0.0f, 0.0f, 1.0f}, 10},        // the probe's shape
      {8, 8, 4, 0.4f, 0.4f, {0.125f, 0.0f, 0.0f, 0.125f}, 5},      // subdivision 4
  };
  for (const Case &c : cases) {
    const auto table = FlatTable(c.w, c.h, c.subdivision);
    const uint32_t W = uint32_t(table[0]), H = uint32_t(table[1]);
    ASSERT_EQ(W, c.w * uint32_t(c.subdivision));
    const double cells = NormalMapFootprintCells(W, H, c.u, c.v, c.fp, c.cutoff);
    EXPECT_EQ(2.0 * cells, double(KernelTriangles(table, c.u, c.v, c.fp, c.cutoff)))
        << c.w << "x" << c.h << " sub " << c.subdivision << " fp " << c.fp[0] << " cutoff "
        << c.cutoff;
  }
}

TEST(NormalMapCost, CellsGrowAsFootprintSquaredUntilTheClamp) {
  const uint32_t W = 512, H = 512;
  const double cutoff = 5.0, pixel_sigma = 0.5, floor = 0.01;
  double previous = 0;
  for (double texels = 0.25; texels <= 16; texels *= 2) {
    // Footprint sigma = texels along each axis: du/dx = dv/dy = texels / (0.5 W).
    const float j = float(texels / (pixel_sigma * W));
    const float fp[4] = {j, 0.0f, 0.0f, j};
    // Unclamped box: cutoff x the Gaussian's sigma (with the kernel's floor), in texels.
    const double sigma = std::sqrt(texels * texels + floor * floor);
    const double b = cutoff * sigma;
    const double cx = 0.37 * W - 0.5, cy = 0.61 * H - 0.5;
    const double cells = NormalMapFootprintCells(W, H, 0.37f, 0.61f, fp, float(cutoff));
    EXPECT_NEAR(cells, CellsOverlapping(cx, cy, b, b), 2 * (2 * b + 2)) << texels;
    EXPECT_GE(cells, (2 * b) * (2 * b)) << texels;
    EXPECT_LE(cells, (2 * b + 2) * (2 * b + 2)) << texels;
    if (previous > 0) {  // 4x per doubling, up to the +1 cell per axis of the box's edges
      const double ratio = cells / previous;
      EXPECT_GT(ratio, 4.0 * std::pow(2 * b / (2 * b + 2), 2) / 1.0001) << texels;
      EXPECT_LT(ratio, 4.0 * std::pow((b + 2) / b, 2)) << texels;
    }
    previous = cells;
  }
  // Beyond the clamp (box GLINT_NM_MAX_PERIODS = 2 periods wide) the count stops growing ...
  const float a[4] = {0.5f, 0.0f, 0.0f, 0.5f}, b[4] = {0.9f, 0.0f, 0.0f, 0.9f};
  const double at = NormalMapFootprintCells(W, H, 0.3f, 0.3f, a, float(cutoff));
  EXPECT_EQ(at, NormalMapFootprintCells(W, H, 0.3f, 0.3f, b, float(cutoff)));
  EXPECT_EQ(at, (2.0 * W + 1) * (2.0 * H + 1));
  // ... and in the large-footprint limit (sigma >= one period) it is one period: W x H.
  const float wide[4] = {2.0f, 0.0f, 0.0f, 2.0f};
  EXPECT_EQ(NormalMapFootprintCells(W, H, 0.3f, 0.3f, wide, float(cutoff)), double(W) * H);
  const float nan[4] = {NAN, 0.0f, 0.0f, 1.0f};
  EXPECT_EQ(NormalMapFootprintCells(W, H, 0.3f, 0.3f, nan, float(cutoff)), double(W) * H);
  // Non-finite uv (admission runs before query validation): the most 3 x 3 copies hold.
  EXPECT_EQ(NormalMapFootprintCells(W, H, NAN, 0.3f, a, float(cutoff)), 9.0 * W * H);
  EXPECT_EQ(NormalMapFootprintCells(W, H, 0.3f, INFINITY, a, float(cutoff)), 9.0 * W * H);
}

std::string InsertFlat(uint32_t w, uint32_t h) {
  DecodedNormalMap map;
  map.width = w;
  map.height = h;
  map.xyz.assign(size_t(3) * w * h, 0.0f);
  for (size_t i = 0; i < size_t(w) * h; ++i) map.xyz[3 * i + 2] = 1.0f;
  glint::v1::NormalMapInfo info;
  EXPECT_TRUE(NormalMaps().Insert("flat", map, &info).ok());
  return info.digest();
}

glint::v1::EvaluateRequest NormalMapRequest(const std::string &digest, int subdivision,
                                            float cutoff) {
  glint::v1::EvaluateRequest r;
  auto *m = r.mutable_material();
  m->set_model(glint::v1::NORMAL_MAP);
  m->mutable_normal_map()->set_digest(digest);
  m->mutable_normal_map()->set_subdivision(uint32_t(subdivision));
  m->mutable_normal_map()->set_cutoff_sigma(cutoff);
  m->mutable_normal_map()->set_intrinsic_roughness(1e-4f);
  return r;
}

void AddQueries(glint::v1::EvaluateRequest *r, uint32_t n, float footprint) {
  auto *q = r->mutable_queries();
  q->set_count(q->count() + n);
  for (uint32_t i = 0; i < n; ++i) {
    for (float v : {0.5f, 0.5f}) q->add_uv(v);
    for (float v : {footprint, 0.0f, 0.0f, footprint}) q->add_footprint(v);
    for (float v : {0.0f, 0.0f, 1.0f}) q->add_wo(v);
  }
}

TEST(NormalMapCost, TheProbesRequestIsRefusedNamingTheCostAndTheQuery) {
  glint::v1::EvaluateRequest r = NormalMapRequest(InsertFlat(1, 4097), 4, 10.0f);
  auto *quad = r.add_lights()->mutable_polygon();
  for (float v : {-1e6f, -1e6f, 1.0f, -1e6f, 1e6f, 1.0f, 1e6f, 1e6f, 1.0f, 1e6f, -1e6f, 1.0f})
    quad->add_vertices(v);
  for (float v : {1.0f, 1.0f, 1.0f}) quad->add_radiance(v);
  AddQueries(&r, 4, 1.0f);
  const RequestCost cost = EstimateQueriesCost(r, r.queries());
  // 128 P-NDF evaluations (64 + 64 MIS samples) of every triangle in a 2-period box of the
  // 4 x 16388 vertex grid: explicitly, cells = NormalMapFootprintCells (checked above against
  // the kernel), so the cost is at least 128 x 2 x cells units.
  const float fp[4] = {1.0f, 0.0f, 0.0f, 1.0f};
  const double cells = NormalMapFootprintCells(4, 4 * 4097, 0.5f, 0.5f, fp, 10.0f);
  EXPECT_GE(cells, 2.0 * 4 * 2.0 * 4 * 4097);  // 2 periods per axis
  EXPECT_GE(cost.per_query, 128 * 2 * cells);
  const Status st = CheckRequestCost(cost, 4, CostLimits{});
  ASSERT_EQ(st.code(), Status::Code::kResourceExhausted) << st.message();
  for (const char *part : {"--max-query-cost 1e+07", "128 P-NDF evaluations", "query 0",
                           "NORMAL_MAP", "4 x 16388 vertex map"})
    EXPECT_NE(st.message().find(part), std::string::npos) << part << ": " << st.message();
}

TEST(NormalMapCost, OrdinaryRequestsAreAdmittedAndTheDearestQueryBoundsTheSlice) {
  const std::string digest = InsertFlat(256, 256);
  // A 512 x 512 preview of one-texel footprints (J = 2 / 256 => sigma 1 texel) under two
  // directional lights, cut-off 5: admitted.
  glint::v1::EvaluateRequest r = NormalMapRequest(digest, 1, 5.0f);
  for (int l = 0; l < 2; ++l) {
    auto *d = r.add_lights()->mutable_directional();
    for (float v : {0.0f, 0.6f, 0.8f}) d->add_direction(v);
    for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
  }
  AddQueries(&r, 1000, 2.0f / 256);
  const uint64_t preview = 512 * 512;
  RequestCost scaled = EstimateQueriesCost(r, r.queries());
  scaled.total *= double(preview) / 1000.0;  // the same queries, 512 x 512 of them
  EXPECT_TRUE(CheckRequestCost(scaled, preview, CostLimits{}).ok());
  // One query with a 16-texel footprint among them: the per-query cost (the slicer's) is that
  // query's, the total the mean's.
  const RequestCost before = EstimateQueriesCost(r, r.queries());
  AddQueries(&r, 1, 32.0f / 256);
  const RequestCost after = EstimateQueriesCost(r, r.queries());
  // The cells grow (16 texels / 1)^2 ~ 214x (box half-widths 80 and 5 texels: 161^2 / 11^2);
  // the cost per query follows them, up to the per-evaluation base, which is at most the
  // triangles' part of a one-texel box (>= 2 x 121 triangles), so at most halves the ratio.
  const float one[4] = {2.0f / 256, 0, 0, 2.0f / 256},
              sixteen[4] = {32.0f / 256, 0, 0, 32.0f / 256};
  const double ratio = NormalMapFootprintCells(256, 256, 0.5f, 0.5f, sixteen, 5.0f) /
                       NormalMapFootprintCells(256, 256, 0.5f, 0.5f, one, 5.0f);
  EXPECT_NEAR(ratio, 161.0 * 161.0 / (11.0 * 11.0), 1.0);
  EXPECT_GT(after.per_query, ratio / 2 * before.per_query);
  EXPECT_LT(after.per_query, ratio * before.per_query);
  EXPECT_LT(after.total, 2 * before.total);  // one query of 1001
  EXPECT_NE(after.parts.find("query 1000"), std::string::npos) << after.parts;
}

// Every path charges one function (EstimateQueriesCost): a stream's settings carry no queries,
// so the cost must come from the batch passed, not settings.queries(); a chunk's refusal names
// the query by its place in the stream; the Sample RPC charges K probe evaluations of each
// query's own footprint (one sample = one P-NDF evaluation, as a probe or one directional
// light); polygon lights are worded by NORMAL_MAP's own MIS, never by the area_method it
// ignores.
TEST(NormalMapCost, EveryPathChargesEachQueryByItsFootprint) {
  const std::string digest = InsertFlat(64, 64);
  glint::v1::EvaluateRequest settings = NormalMapRequest(digest, 1, 5.0f);
  auto *d = settings.add_lights()->mutable_directional();
  for (float v : {0.0f, 0.6f, 0.8f}) d->add_direction(v);
  for (float v : {1.0f, 1.0f, 1.0f}) d->add_irradiance(v);
  glint::v1::EvaluateRequest carrier = settings;  // the same batch inside the request
  AddQueries(&carrier, 3, 2.0f / 64);
  AddQueries(&carrier, 1, 0.5f);
  const glint::v1::QueryBatch &q = carrier.queries();

  const RequestCost unary = EstimateQueriesCost(carrier, q);
  const RequestCost chunk = EstimateQueriesCost(settings, q, 1000);
  EXPECT_TRUE(unary.counted_per_query);
  EXPECT_EQ(chunk.per_query, unary.per_query);
  EXPECT_EQ(chunk.total, unary.total);
  EXPECT_NE(unary.parts.find("query 3's footprint"), std::string::npos) << unary.parts;
  EXPECT_NE(chunk.parts.find("query 1003's footprint"), std::string::npos) << chunk.parts;
  // The material-only guess differs (it cannot see the half-period footprint).
  EXPECT_LT(EstimateRequestCost(settings, 4).per_query, unary.per_query);

  // One directional light is one P-NDF evaluation per query, as a probe and as a sample.
  glint::v1::EvaluateRequest probe;
  *probe.mutable_material() = settings.material();
  const RequestCost probes = EstimateQueriesCost(probe, q);
  EXPECT_EQ(probes.per_query, unary.per_query);
  EXPECT_EQ(probes.total, unary.total);
  const RequestCost sample = EstimateSampleCost(settings, 64, q);
  EXPECT_EQ(sample.per_query, 64 * probes.per_query);
  EXPECT_EQ(sample.total, 64 * probes.total);
  EXPECT_NE(sample.parts.find("query 3's footprint"), std::string::npos) << sample.parts;

  // Polygon lights: NORMAL_MAP's MIS with area_samples of each technique, whatever
  // area_method says.
  glint::v1::EvaluateRequest lit = NormalMapRequest(digest, 1, 5.0f);
  auto *quad = lit.add_lights()->mutable_polygon();
  for (float v : {-1.0f, -1.0f, 1.0f, 1.0f, -1.0f, 1.0f, 1.0f, 1.0f, 1.0f, -1.0f, 1.0f, 1.0f})
    quad->add_vertices(v);
  lit.set_area_method(glint::v1::REFERENCE);
  lit.set_area_samples(16);
  for (const RequestCost &c : {EstimateRequestCost(lit, 4), EstimateQueriesCost(lit, q)}) {
    EXPECT_NE(c.parts.find("by NORMAL_MAP's own MIS (16 light + 16 P-NDF samples"),
              std::string::npos)
        << c.parts;
    EXPECT_EQ(c.parts.find("REFERENCE"), std::string::npos) << c.parts;
  }
  // 32 P-NDF evaluations per query (16 + 16 MIS samples) against one per directional light.
  const RequestCost polygon = EstimateQueriesCost(lit, q);
  EXPECT_NE(polygon.parts.find("32 P-NDF evaluations"), std::string::npos) << polygon.parts;
  EXPECT_NEAR((polygon.per_query - 1) / (unary.per_query - 1), 32.0, 1e-9);
}

// A dynamic batch's slices are sized by the dearest query of any member (BatchPerQueryCost),
// here the half-period footprint in the second part, not by the first part's queries.
TEST(NormalMapCost, TheDearestMemberSizesABatchsSlices) {
  glint::v1::EvaluateRequest settings = NormalMapRequest(InsertFlat(64, 64), 1, 5.0f);
  glint::v1::EvaluateRequest small = settings, big = settings;
  AddQueries(&small, 4, 2.0f / 64);
  AddQueries(&big, 2, 2.0f / 64);
  AddQueries(&big, 1, 0.5f);
  std::vector<float> out(3 * 7);
  std::vector<BatchPart> parts = {{&small.queries(), out.data(), {}, Status::Ok()},
                                  {&big.queries(), out.data() + 12, {}, Status::Ok()}};
  const double dearest = EstimateQueriesCost(settings, big.queries()).per_query;
  EXPECT_GT(dearest, 10 * EstimateQueriesCost(settings, small.queries()).per_query);
  EXPECT_EQ(BatchPerQueryCost(settings, parts), dearest);
  std::swap(parts[0], parts[1]);
  EXPECT_EQ(BatchPerQueryCost(settings, parts), dearest);
}

}  // namespace
}  // namespace glint
