// Preprocessing of a normal map for the NORMAL_MAP model (Yan et al. 2014 Sec. 5-6): the
// triangulation's vertex grid (optionally 4 x 4 Catmull-Rom subdivided) and the min-max quadtree
// of (s, t), in the table layout of models/normal_map/normal_map_params.h. Run once per map and
// subdivision by the server's normal-map store (server/normal_map_store.cpp).
#pragma once

#include <cstdint>
#include <vector>

namespace glint {

// `st` holds (s, t) per texel, row-major (width x height). subdivision is 1 or 4. The caller
// has checked that width * subdivision and height * subdivision are at most GLINT_NM_MAX_SIDE.
std::vector<float> BuildNormalMapTable(uint32_t width, uint32_t height,
                                       const std::vector<float> &st, int subdivision);

// Levels of the quadtree over a W x H grid of cells: the smallest L >= 1 with 2^(L-1) >= max(W, H).
int NormalMapLevels(uint32_t width, uint32_t height);

}  // namespace glint
