// A plain CPU z-buffer of a mesh seen from a camera: the reference of the
// render client's depth maps (paper 000 section 4.2) and the fusion server's
// measure of how far its hull's silhouettes stray from the masks.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"

namespace holofuse {

constexpr double kNoDepth = std::numeric_limits<double>::infinity();

struct DepthMap {
  uint32_t width = 0, height = 0;
  std::vector<double> depth;  // camera-space z per pixel, kNoDepth where no surface
  double at(uint32_t x, uint32_t y) const { return depth[static_cast<size_t>(y) * width + x]; }
};

// Z-buffer of the mesh sampled at pixel centres, perspective-correct.
// Triangles with a vertex behind the near plane are skipped; degenerate
// triangles draw nothing. triangle_of, when given, receives per pixel the
// index of the triangle that won the depth test (-1 where none).
DepthMap rasterizeDepth(const Mesh& mesh, const Camera& camera, double near_plane = 0.05,
                        std::vector<int32_t>* triangle_of = nullptr);

}  // namespace holofuse
