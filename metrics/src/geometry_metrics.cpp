#include "metrics/geometry_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "geometry/depth_raster.h"

namespace holofuse::metrics {
namespace {

// The point of segment ab nearest to p (a point when a == b).
glm::dvec3 nearestOnSegment(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
  const double length2 = glm::dot(b - a, b - a);
  return length2 > 0 ? a + (b - a) * std::clamp(glm::dot(p - a, b - a) / length2, 0.0, 1.0) : a;
}

// The point of triangle abc nearest to p: the Voronoi regions of its
// vertices, then its edges, then its face (Ericson, Real-Time Collision
// Detection, section 5.1.5). A triangle without area (two corners on one
// point, or all three on a line, as quantisation makes) is its three
// edges: the region tests would divide by zero there.
glm::dvec3 nearestOnTriangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                             const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a;
  if (!(glm::length(glm::cross(ab, ac)) > 1e-12 * std::max(glm::dot(ab, ab), glm::dot(ac, ac)))) {
    glm::dvec3 best = nearestOnSegment(p, a, b);
    for (const glm::dvec3& q : {nearestOnSegment(p, b, c), nearestOnSegment(p, c, a)}) {
      if (glm::length(p - q) < glm::length(p - best)) best = q;
    }
    return best;
  }
  const double d1 = glm::dot(ab, p - a), d2 = glm::dot(ac, p - a);
  if (d1 <= 0 && d2 <= 0) return a;
  const double d3 = glm::dot(ab, p - b), d4 = glm::dot(ac, p - b);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const double d5 = glm::dot(ab, p - c), d6 = glm::dot(ac, p - c);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double sum = va + vb + vc;
  return a + ab * (vb / sum) + ac * (vc / sum);
}

// A mesh's surface (its triangles, or its vertices when it has none)
// bucketed in cubes of `cell` metres, for nearest-distance queries: a
// triangle sits in every cube its bounding box touches.
class SurfaceGrid {
 public:
  SurfaceGrid(const Mesh& mesh, double cell) : mesh_(mesh), cell_(cell) {
    const size_t elements = mesh.indices.empty() ? mesh.positions.size() : mesh.triangleCount();
    for (size_t e = 0; e < elements; ++e) {
      glm::dvec3 lo(std::numeric_limits<double>::infinity()),
          hi(-std::numeric_limits<double>::infinity());
      for (int k = 0; k < corners(); ++k) {
        lo = glm::min(lo, corner(e, k));
        hi = glm::max(hi, corner(e, k));
      }
      const glm::ivec3 from = cellOf(lo), to = cellOf(hi);
      for (int z = from.z; z <= to.z; ++z) {
        for (int y = from.y; y <= to.y; ++y) {
          for (int x = from.x; x <= to.x; ++x)
            buckets_[key({x, y, z})].push_back(static_cast<uint32_t>(e));
        }
      }
    }
  }

  // Searches shells of cells outwards until nothing closer can exist.
  double nearest(const glm::dvec3& p) const {
    const glm::ivec3 c = cellOf(p);
    double best = std::numeric_limits<double>::infinity();
    for (int r = 0; r < 1024; ++r) {
      for (int z = -r; z <= r; ++z) {
        for (int y = -r; y <= r; ++y) {
          for (int x = -r; x <= r; ++x) {
            if (std::max({std::abs(x), std::abs(y), std::abs(z)}) != r)
              continue;  // this shell only
            const auto it = buckets_.find(key(c + glm::ivec3(x, y, z)));
            if (it == buckets_.end()) continue;
            for (uint32_t e : it->second) best = std::min(best, distance(p, e));
          }
        }
      }
      // Every element not yet seen lies beyond r whole cells.
      if (best <= r * cell_) break;
    }
    return best;
  }

 private:
  int corners() const { return mesh_.indices.empty() ? 1 : 3; }
  glm::dvec3 corner(size_t element, int k) const {
    return glm::dvec3(
        mesh_.positions[mesh_.indices.empty() ? element : mesh_.indices[3 * element + k]]);
  }
  double distance(const glm::dvec3& p, size_t element) const {
    if (mesh_.indices.empty()) return glm::length(p - corner(element, 0));
    return glm::length(
        p - nearestOnTriangle(p, corner(element, 0), corner(element, 1), corner(element, 2)));
  }
  glm::ivec3 cellOf(const glm::dvec3& p) const { return glm::ivec3(glm::floor(p / cell_)); }
  static uint64_t key(const glm::ivec3& c) {
    return (uint64_t(uint32_t(c.x) & 0x1fffff) << 42) | (uint64_t(uint32_t(c.y) & 0x1fffff) << 21) |
           uint64_t(uint32_t(c.z) & 0x1fffff);
  }
  const Mesh& mesh_;
  double cell_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> buckets_;
};

double meanNearest(const Mesh& from, const SurfaceGrid& to) {
  double sum = 0;
  for (const auto& p : from.positions) sum += to.nearest(glm::dvec3(p));
  return sum / static_cast<double>(from.positions.size());
}

}  // namespace

double chamferDistance(const Mesh& a, const Mesh& b) {
  if (a.positions.empty() || b.positions.empty()) return std::numeric_limits<double>::infinity();
  const double cell = 0.02;
  const SurfaceGrid grid_a(a, cell), grid_b(b, cell);
  return 0.5 * (meanNearest(a, grid_b) + meanNearest(b, grid_a));
}

double silhouetteIoU(const Mesh& mesh, const Camera& camera, const Image8& mask) {
  const DepthMap map = rasterizeDepth(mesh, camera);
  size_t both = 0, either = 0;
  for (size_t i = 0; i < map.depth.size() && i < mask.pixels.size(); ++i) {
    const bool drawn = map.depth[i] != kNoDepth, truth = mask.pixels[i] != 0;
    both += drawn && truth;
    either += drawn || truth;
  }
  return either ? static_cast<double>(both) / static_cast<double>(either) : 1.0;
}

}  // namespace holofuse::metrics
