#include "render_client/temporal_carry.h"

#include <cmath>
#include <limits>
#include <unordered_map>

namespace holofuse::render {
namespace {

struct CellHash {
  size_t operator()(const glm::ivec3& c) const {
    return (static_cast<size_t>(c.x) * 73856093u) ^ (static_cast<size_t>(c.y) * 19349663u) ^
           (static_cast<size_t>(c.z) * 83492791u);
  }
};

}  // namespace

CarryMap carryAcross(const Mesh& previous, const Mesh& next, double max_distance) {
  CarryMap map;
  map.previous.assign(next.vertexCount(), -1);
  std::unordered_map<uint64_t, int32_t> by_key;
  if (previous.vertex_keys.size() == previous.vertexCount()) {
    by_key.reserve(previous.vertexCount());
    for (size_t v = 0; v < previous.vertexCount(); ++v) by_key.emplace(previous.vertex_keys[v], static_cast<int32_t>(v));
  }
  // A uniform grid of cell max_distance over the previous vertices: the
  // nearest one within max_distance lies in the 27 cells around.
  std::unordered_map<glm::ivec3, std::vector<int32_t>, CellHash> grid;
  const bool nearest = max_distance > 0;
  auto cellOf = [&](const glm::vec3& p) { return glm::ivec3(glm::floor(glm::dvec3(p) / max_distance)); };
  if (nearest) {
    for (size_t v = 0; v < previous.vertexCount(); ++v) {
      if (std::isfinite(previous.positions[v].x)) grid[cellOf(previous.positions[v])].push_back(static_cast<int32_t>(v));
    }
  }
  const bool keyed = next.vertex_keys.size() == next.vertexCount() && !by_key.empty();
  for (size_t v = 0; v < next.vertexCount(); ++v) {
    if (keyed) {
      auto it = by_key.find(next.vertex_keys[v]);
      if (it != by_key.end()) {
        map.previous[v] = it->second;
        ++map.by_key;
        continue;
      }
    }
    if (nearest && std::isfinite(next.positions[v].x)) {
      const glm::ivec3 c = cellOf(next.positions[v]);
      double best = max_distance * max_distance;
      int32_t found = -1;
      for (int dz = -1; dz <= 1; ++dz) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            auto it = grid.find(c + glm::ivec3(dx, dy, dz));
            if (it == grid.end()) continue;
            for (int32_t w : it->second) {
              const glm::dvec3 d = glm::dvec3(previous.positions[w]) - glm::dvec3(next.positions[v]);
              const double d2 = glm::dot(d, d);
              // Ties go to the lower index: the same input, the same map.
              if (d2 < best || (d2 == best && found >= 0 && w < found)) {
                best = d2;
                found = w;
              }
            }
          }
        }
      }
      if (found >= 0) {
        map.previous[v] = found;
        ++map.by_nearest;
        continue;
      }
    }
    ++map.fresh;
  }
  return map;
}

std::vector<std::vector<double>> carryField(const std::vector<std::vector<double>>& previous_field,
                                            const CarryMap& map,
                                            const std::vector<std::vector<double>>& fresh) {
  std::vector<std::vector<double>> out(fresh.size(), std::vector<double>(map.previous.size(), 0.0));
  for (size_t i = 0; i < fresh.size(); ++i) {
    for (size_t v = 0; v < map.previous.size(); ++v) {
      const int32_t p = map.previous[v];
      const bool carried = p >= 0 && i < previous_field.size() && static_cast<size_t>(p) < previous_field[i].size();
      out[i][v] = carried ? previous_field[i][p] : fresh[i][v];
    }
  }
  return out;
}

}  // namespace holofuse::render
