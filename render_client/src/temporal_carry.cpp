#include "render_client/temporal_carry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace holofuse::render {

CarryMap carryAcross(const Mesh& previous, const Mesh& next, double max_distance) {
  CarryMap map;
  map.previous.assign(next.vertexCount(), -1);
  std::unordered_map<uint64_t, int32_t> by_key;
  if (previous.vertex_keys.size() == previous.vertexCount()) {
    by_key.reserve(previous.vertexCount());
    for (size_t v = 0; v < previous.vertexCount(); ++v) by_key.emplace(previous.vertex_keys[v], static_cast<int32_t>(v));
  }
  // By key first; the vertices left over look for the nearest previous one.
  const bool keyed = next.vertex_keys.size() == next.vertexCount() && !by_key.empty();
  std::vector<uint32_t> unmatched;
  for (size_t v = 0; v < next.vertexCount(); ++v) {
    if (keyed) {
      auto it = by_key.find(next.vertex_keys[v]);
      if (it != by_key.end()) {
        map.previous[v] = it->second;
        ++map.by_key;
        continue;
      }
    }
    unmatched.push_back(static_cast<uint32_t>(v));
  }
  const bool nearest = max_distance > 0 && !unmatched.empty();
  // A dense grid over the previous vertices' box, cells at least
  // max_distance wide, built only when some vertex needs it: the nearest
  // previous vertex within max_distance lies in the 27 cells around. Each
  // cell heads a list threaded through one array. (A hash map of cells
  // cost 2 ms per new mesh on a 6k-vertex hull, most of it in lookups.)
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const glm::vec3& p : previous.positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  const bool searchable = nearest && lo.x <= hi.x;
  double cell = max_distance;
  glm::ivec3 dims(1);
  constexpr double kMaxCells = 1 << 22;
  if (searchable) {
    auto countCells = [&] { return glm::floor((hi - lo) / cell) + 1.0; };
    while (countCells().x * countCells().y * countCells().z > kMaxCells) cell *= 2;
    dims = glm::ivec3(countCells());
  }
  auto cellOf = [&](const glm::vec3& p) { return glm::ivec3(glm::floor((glm::dvec3(p) - lo) / cell)); };
  auto cellIndex = [&](const glm::ivec3& c) {
    return (static_cast<size_t>(c.z) * static_cast<size_t>(dims.y) + static_cast<size_t>(c.y)) * static_cast<size_t>(dims.x) +
           static_cast<size_t>(c.x);
  };
  std::vector<int32_t> first_in_cell, next_in_cell;
  if (searchable) {
    first_in_cell.assign(static_cast<size_t>(dims.x) * dims.y * dims.z, -1);
    next_in_cell.assign(previous.vertexCount(), -1);
    for (size_t v = 0; v < previous.vertexCount(); ++v) {
      const glm::vec3& p = previous.positions[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
      int32_t& head = first_in_cell[cellIndex(glm::clamp(cellOf(p), glm::ivec3(0), dims - 1))];
      next_in_cell[v] = head;
      head = static_cast<int32_t>(v);
    }
  }
  for (uint32_t v : unmatched) {
    const glm::vec3& p = next.positions[v];
    if (searchable && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) {
      const glm::dvec3 from = (glm::dvec3(p) - lo) / cell;
      double best = max_distance * max_distance;
      int32_t found = -1;
      // Cells -1..+1 around p's, within the grid (p may lie outside it).
      const glm::ivec3 c = glm::ivec3(glm::clamp(glm::floor(from), glm::dvec3(-2.0), glm::dvec3(dims) + 1.0));
      for (int z = std::max(c.z - 1, 0); z <= std::min(c.z + 1, dims.z - 1); ++z) {
        for (int y = std::max(c.y - 1, 0); y <= std::min(c.y + 1, dims.y - 1); ++y) {
          for (int x = std::max(c.x - 1, 0); x <= std::min(c.x + 1, dims.x - 1); ++x) {
            for (int32_t w = first_in_cell[cellIndex({x, y, z})]; w >= 0; w = next_in_cell[static_cast<size_t>(w)]) {
              const glm::dvec3 d = glm::dvec3(previous.positions[w]) - glm::dvec3(p);
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
