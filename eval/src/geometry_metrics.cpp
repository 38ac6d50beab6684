#include "eval/geometry_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "render_client/reference/depth_map.h"

namespace holofuse::eval {
namespace {

// Vertices bucketed in cubes of `cell` metres, for nearest-point queries.
class PointGrid {
 public:
  PointGrid(const std::vector<glm::vec3>& points, double cell) : points_(points), cell_(cell) {
    for (size_t i = 0; i < points.size(); ++i) buckets_[key(cellOf(points[i]))].push_back(static_cast<uint32_t>(i));
  }

  // Searches shells of cells outwards until no closer point can exist.
  double nearest(const glm::vec3& p) const {
    const glm::ivec3 c = cellOf(p);
    double best = std::numeric_limits<double>::infinity();
    for (int r = 0; r < 1024; ++r) {
      for (int z = -r; z <= r; ++z) {
        for (int y = -r; y <= r; ++y) {
          for (int x = -r; x <= r; ++x) {
            if (std::max({std::abs(x), std::abs(y), std::abs(z)}) != r) continue;  // this shell only
            const auto it = buckets_.find(key(c + glm::ivec3(x, y, z)));
            if (it == buckets_.end()) continue;
            for (uint32_t i : it->second) best = std::min(best, double(glm::length(points_[i] - p)));
          }
        }
      }
      // Every point not yet seen lies beyond r whole cells.
      if (best <= r * cell_) break;
    }
    return best;
  }

 private:
  glm::ivec3 cellOf(const glm::vec3& p) const { return glm::ivec3(glm::floor(glm::dvec3(p) / cell_)); }
  static uint64_t key(const glm::ivec3& c) {
    return (uint64_t(uint32_t(c.x) & 0x1fffff) << 42) | (uint64_t(uint32_t(c.y) & 0x1fffff) << 21) |
           uint64_t(uint32_t(c.z) & 0x1fffff);
  }
  const std::vector<glm::vec3>& points_;
  double cell_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> buckets_;
};

double meanNearest(const Mesh& from, const PointGrid& to) {
  double sum = 0;
  for (const auto& p : from.positions) sum += to.nearest(p);
  return sum / static_cast<double>(from.positions.size());
}

}  // namespace

double chamferDistance(const Mesh& a, const Mesh& b) {
  if (a.positions.empty() || b.positions.empty()) return std::numeric_limits<double>::infinity();
  const double cell = 0.02;
  const PointGrid grid_a(a.positions, cell), grid_b(b.positions, cell);
  return 0.5 * (meanNearest(a, grid_b) + meanNearest(b, grid_a));
}

double silhouetteIoU(const Mesh& mesh, const Camera& camera, const Image8& mask) {
  const render::reference::DepthMap map = render::reference::rasterizeDepth(mesh, camera);
  size_t both = 0, either = 0;
  for (size_t i = 0; i < map.depth.size() && i < mask.pixels.size(); ++i) {
    const bool drawn = map.depth[i] != render::reference::kNoDepth, truth = mask.pixels[i] != 0;
    both += drawn && truth;
    either += drawn || truth;
  }
  return either ? static_cast<double>(both) / static_cast<double>(either) : 1.0;
}

}  // namespace holofuse::eval
