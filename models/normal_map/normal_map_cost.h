// NORMAL_MAP's admission cost per query (server/request_cost.h, Model::query_costs): its work
// is the triangles one P-NDF evaluation integrates (normal_map_pndf.h, nm_traverse), which grow
// with the footprint's cut-off box, times the P-NDF evaluations a query makes (one per punctual
// light or probe, up to two per polygon-light MIS sample). The material alone cannot tell: a
// one-texel footprint and a 2-period one differ by ~10^5 (README "Cost").
#pragma once

#include <cstdint>
#include <string>

#include "glint/v1/glint.pb.h"

namespace glint {

// Cells (two triangles each) of a W x H vertex table (the map's texels, or its 4W x 4H
// Catmull-Rom grid at subdivision 4) that one P-NDF evaluation of the footprint at (u, v) with
// Jacobian fp = (du/dx, dv/dx, du/dy, dv/dy) can integrate: the cells nm_space_culled keeps,
// summed over the period copies the kernel's own nm_footprint box touches (clamped to
// GLINT_NM_MAX_PERIODS periods, or one whole period in the large-footprint limit). An upper
// bound on NmStats::triangles / 2, reached when no cell is pruned by the normals' cut-off (a
// flat map queried at its normal). O(1): at most 3 period copies per axis.
double NormalMapFootprintCells(uint32_t W, uint32_t H, float u, float v, const float fp[4],
                               float cutoff);

// Admission cost of the queries `q` under `settings` (a NORMAL_MAP request whose map the store
// holds; settings.queries() is not read), in units of one smooth BRDF evaluation: the largest
// per query and their sum, and what they count for the refusal message, which names the
// dearest query as first_query + its index in q (its place in a stream). False when it cannot
// tell (no footprints, or the map is not held: validation refuses that).
bool NormalMapQueryCosts(const glint::v1::EvaluateRequest &settings, const glint::v1::QueryBatch &q,
                         uint64_t first_query, double *max_units, double *sum_units,
                         std::string *parts);

// How NORMAL_MAP integrates polygon lights, for the cost's wording (Model::polygon_method): its
// own MIS of light samples and P-NDF samples (normal_map_polygons.h), area_samples of each;
// area_method does not apply.
std::string NormalMapPolygonMethod(const glint::v1::EvaluateRequest &settings);

}  // namespace glint
