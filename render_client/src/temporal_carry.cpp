#include "render_client/temporal_carry.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace holofuse::render {

CarryMap carryAcross(const Mesh& previous, const Mesh& next, double max_distance) {
  CarryMap map;
  map.previous.assign(next.vertexCount(), -1);
  // Previous vertices by key in an open-addressed table (linear probing,
  // at most half full): a std::unordered_map cost 0.45 ms per new mesh
  // on a 6k-vertex hull, mostly allocation.
  const bool keyed = next.vertex_keys.size() == next.vertexCount() &&
                     previous.vertex_keys.size() == previous.vertexCount() &&
                     previous.vertexCount() > 0;
  size_t slots = 1;
  while (keyed && slots < 2 * previous.vertexCount()) slots *= 2;
  std::vector<uint64_t> slot_key(keyed ? slots : 0);
  std::vector<int32_t> slot_vertex(keyed ? slots : 0, -1);
  // The slot holding key, or the empty slot where it would go.
  auto slotOf = [&](uint64_t key) {
    size_t at = static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> 20) & (slots - 1);
    while (slot_vertex[at] >= 0 && slot_key[at] != key) at = (at + 1) & (slots - 1);
    return at;
  };
  if (keyed) {
    for (size_t v = 0; v < previous.vertexCount(); ++v) {
      const uint64_t key = previous.vertex_keys[v];
      const size_t at = slotOf(key);
      if (slot_vertex[at] < 0) {  // the first vertex with a key keeps it
        slot_key[at] = key;
        slot_vertex[at] = static_cast<int32_t>(v);
      }
    }
  }
  // By key first; the vertices left over look for the nearest previous one.
  std::vector<uint32_t> unmatched;
  for (size_t v = 0; v < next.vertexCount(); ++v) {
    if (keyed) {
      const size_t at = slotOf(next.vertex_keys[v]);
      if (slot_vertex[at] >= 0) {
        map.previous[v] = slot_vertex[at];
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
  auto cellOf = [&](const glm::vec3& p) {
    return glm::ivec3(glm::floor((glm::dvec3(p) - lo) / cell));
  };
  auto cellIndex = [&](const glm::ivec3& c) {
    return (static_cast<size_t>(c.z) * static_cast<size_t>(dims.y) + static_cast<size_t>(c.y)) *
               static_cast<size_t>(dims.x) +
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
      // Cells -1..+1 around p's, within the grid (p may lie outside it);
      // a cell whose box lies farther than the best so far is skipped.
      const glm::ivec3 c =
          glm::ivec3(glm::clamp(glm::floor(from), glm::dvec3(-2.0), glm::dvec3(dims) + 1.0));
      auto search = [&](int x, int y, int z) {
        const glm::dvec3 nearest_in_box =
            glm::clamp(from, glm::dvec3(x, y, z), glm::dvec3(x + 1, y + 1, z + 1));
        const glm::dvec3 gap = (from - nearest_in_box) * cell;
        if (glm::dot(gap, gap) > best) return;
        for (int32_t w = first_in_cell[cellIndex({x, y, z})]; w >= 0;
             w = next_in_cell[static_cast<size_t>(w)]) {
          const glm::dvec3 d = glm::dvec3(previous.positions[w]) - glm::dvec3(p);
          const double d2 = glm::dot(d, d);
          // Ties go to the lower index: the same input, the same map.
          if (d2 < best || (d2 == best && found >= 0 && w < found)) {
            best = d2;
            found = w;
          }
        }
      };
      const glm::ivec3 own = glm::clamp(c, glm::ivec3(0), dims - 1);
      if (own == c)
        search(c.x, c.y, c.z);  // p's own cell first: its best prunes most of the others
      for (int z = std::max(c.z - 1, 0); z <= std::min(c.z + 1, dims.z - 1); ++z) {
        for (int y = std::max(c.y - 1, 0); y <= std::min(c.y + 1, dims.y - 1); ++y) {
          for (int x = std::max(c.x - 1, 0); x <= std::min(c.x + 1, dims.x - 1); ++x) {
            if (glm::ivec3(x, y, z) != c) search(x, y, z);
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
      const bool carried =
          p >= 0 && i < previous_field.size() && static_cast<size_t>(p) < previous_field[i].size();
      out[i][v] = carried ? previous_field[i][p] : fresh[i][v];
    }
  }
  return out;
}

}  // namespace holofuse::render
