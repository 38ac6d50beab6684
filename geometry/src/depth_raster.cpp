#include "geometry/depth_raster.h"

#include <algorithm>
#include <cmath>

namespace holofuse {

DepthMap rasterizeDepth(const Mesh& mesh, const Camera& camera, double near_plane,
                        std::vector<int32_t>* triangle_of) {
  DepthMap map;
  map.width = camera.width;
  map.height = camera.height;
  map.depth.assign(static_cast<size_t>(camera.width) * camera.height, kNoDepth);
  if (triangle_of) triangle_of->assign(map.depth.size(), -1);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    glm::dvec3 p[3];
    bool usable = true;
    for (int k = 0; k < 3; ++k) {
      const auto projected = camera.project(glm::dvec3(mesh.positions[mesh.indices[t + k]]));
      usable = usable && projected && projected->z > near_plane && std::isfinite(projected->x) &&
               std::isfinite(projected->y);
      if (usable) p[k] = *projected;
    }
    if (!usable) continue;
    const double area =
        (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[2].x - p[0].x) * (p[1].y - p[0].y);
    if (!(std::abs(area) > 1e-12)) continue;  // degenerate in the image
    const int x0 =
        std::max(0, static_cast<int>(std::floor(std::min({p[0].x, p[1].x, p[2].x}) - 0.5)));
    const int x1 = std::min(static_cast<int>(camera.width) - 1,
                            static_cast<int>(std::ceil(std::max({p[0].x, p[1].x, p[2].x}) - 0.5)));
    const int y0 =
        std::max(0, static_cast<int>(std::floor(std::min({p[0].y, p[1].y, p[2].y}) - 0.5)));
    const int y1 = std::min(static_cast<int>(camera.height) - 1,
                            static_cast<int>(std::ceil(std::max({p[0].y, p[1].y, p[2].y}) - 0.5)));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        // Barycentric coordinates in the image plane.
        const double b0 = ((p[1].x - px) * (p[2].y - py) - (p[2].x - px) * (p[1].y - py)) / area;
        const double b1 = ((p[2].x - px) * (p[0].y - py) - (p[0].x - px) * (p[2].y - py)) / area;
        const double b2 = 1.0 - b0 - b1;
        if (b0 < 0 || b1 < 0 || b2 < 0) continue;
        // 1/z is linear in the image: perspective-correct depth.
        const double z = 1.0 / (b0 / p[0].z + b1 / p[1].z + b2 / p[2].z);
        const size_t pixel = static_cast<size_t>(y) * camera.width + x;
        double& stored = map.depth[pixel];
        if (z < stored) {
          stored = z;
          if (triangle_of) (*triangle_of)[pixel] = static_cast<int32_t>(t / 3);
        }
      }
    }
  }
  return map;
}

}  // namespace holofuse
