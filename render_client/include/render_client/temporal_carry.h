// Follows vertices from one mesh to the next so the temporal texture field
// (paper 000 eq. 5) survives a mesh that is rebuilt every frame: a vertex
// keeps the field of the previous vertex with the same key (the grid edge
// it sits on, docs/design.md section 6 step 9), else of the nearest previous
// vertex within a radius, else it starts fresh.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.h"

namespace holofuse::render {

struct CarryMap {
  std::vector<int32_t> previous;  // per new vertex: index in the previous mesh, -1 for none
  size_t by_key = 0, by_nearest = 0, fresh = 0;
};

// max_distance: how far the nearest previous vertex may be (a couple of
// voxels); <= 0 disables the nearest-vertex fallback.
CarryMap carryAcross(const Mesh& previous, const Mesh& next, double max_distance);

// The previous field [camera][vertex] moved onto the new mesh; fresh
// vertices take `fresh` (the current target field) so new surface does not
// fade in from nothing.
std::vector<std::vector<double>> carryField(const std::vector<std::vector<double>>& previous_field,
                                            const CarryMap& map,
                                            const std::vector<std::vector<double>>& fresh);

}  // namespace holofuse::render
