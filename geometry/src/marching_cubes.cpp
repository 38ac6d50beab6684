#include "geometry/marching_cubes.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <unordered_map>

namespace holofuse {
namespace {

// Corner c of a cube sits at (c & 1, (c >> 1) & 1, (c >> 2) & 1).
glm::dvec3 cornerOffset(int c) { return glm::dvec3(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

struct CubeEdge {
  int axis;
  int base;   // corner with the lower coordinate along axis
  int other;  // base + (1 << axis)
};

// Edge id = axis * 4 + k; the four edges along an axis start at the four
// corners whose bit for that axis is zero.
std::array<CubeEdge, 12> makeEdges() {
  std::array<CubeEdge, 12> edges{};
  for (int axis = 0; axis < 3; ++axis) {
    int k = 0;
    for (int c = 0; c < 8; ++c) {
      if (c & (1 << axis)) continue;
      edges[axis * 4 + k++] = CubeEdge{axis, c, c | (1 << axis)};
    }
  }
  return edges;
}

const std::array<CubeEdge, 12>& cubeEdges() {
  static const auto kEdges = makeEdges();
  return kEdges;
}

int edgeBetween(int a, int b) {
  for (int e = 0; e < 12; ++e) {
    const auto& edge = cubeEdges()[e];
    if ((edge.base == a && edge.other == b) || (edge.base == b && edge.other == a)) return e;
  }
  return -1;
}

// The six faces, corners in cyclic order around each face.
constexpr int kFaces[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4},
                              {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};

std::vector<int> triangulateCase(int config) {
  auto inside = [config](int c) { return (config >> c) & 1; };
  // Each crossed cube edge is linked to one crossed edge on each of its two
  // faces; the links form closed loops, one per surface patch.
  std::array<std::vector<int>, 12> links;
  for (const auto& face : kFaces) {
    int crossed[4];
    int count = 0;
    for (int i = 0; i < 4; ++i) {
      const int a = face[i], b = face[(i + 1) % 4];
      if (inside(a) != inside(b)) crossed[count++] = i;
    }
    auto faceEdge = [&](int i) { return edgeBetween(face[i % 4], face[(i + 1) % 4]); };
    if (count == 2) {
      const int e0 = faceEdge(crossed[0]), e1 = faceEdge(crossed[1]);
      links[e0].push_back(e1);
      links[e1].push_back(e0);
    } else if (count == 4) {
      // Ambiguous face: cut off each inside corner on its own. The choice
      // depends only on this face's corners, so both cubes sharing the face
      // make it alike and the surface stays closed.
      for (int i = 0; i < 4; ++i) {
        if (!inside(face[i])) continue;
        const int e0 = faceEdge(i + 3), e1 = faceEdge(i);
        links[e0].push_back(e1);
        links[e1].push_back(e0);
      }
    }
  }
  std::vector<int> triangles;
  std::array<bool, 12> visited{};
  for (int start = 0; start < 12; ++start) {
    if (links[start].empty() || visited[start]) continue;
    std::vector<int> loop;
    int prev = -1, cur = start;
    while (!visited[cur]) {
      visited[cur] = true;
      loop.push_back(cur);
      const int next = links[cur][0] != prev ? links[cur][0] : links[cur][1];
      prev = cur;
      cur = next;
    }
    // Orient the loop so its normal points from the inside corners to the
    // outside ones (Newell's normal over the edge midpoints).
    glm::dvec3 normal(0.0), inward(0.0);
    for (size_t i = 0; i < loop.size(); ++i) {
      const auto& e0 = cubeEdges()[loop[i]];
      const auto& e1 = cubeEdges()[loop[(i + 1) % loop.size()]];
      const glm::dvec3 p = 0.5 * (cornerOffset(e0.base) + cornerOffset(e0.other));
      const glm::dvec3 q = 0.5 * (cornerOffset(e1.base) + cornerOffset(e1.other));
      normal += glm::cross(p, q);
      const int in = inside(e0.base) ? e0.base : e0.other;
      const int out = inside(e0.base) ? e0.other : e0.base;
      inward += cornerOffset(in) - cornerOffset(out);
    }
    if (glm::dot(normal, inward) > 0) std::reverse(loop.begin(), loop.end());
    for (size_t i = 1; i + 1 < loop.size(); ++i) {
      triangles.push_back(loop[0]);
      triangles.push_back(loop[i]);
      triangles.push_back(loop[i + 1]);
    }
  }
  return triangles;
}

}  // namespace

const std::vector<std::vector<int>>& marchingCubesCaseTable() {
  static const std::vector<std::vector<int>> kTable = [] {
    std::vector<std::vector<int>> table(256);
    for (int config = 0; config < 256; ++config) table[config] = triangulateCase(config);
    return table;
  }();
  return kTable;
}

ScalarGrid sampleGrid(const glm::dvec3& origin, double spacing, int nx, int ny, int nz,
                      const std::function<double(const glm::dvec3&)>& f) {
  ScalarGrid grid;
  grid.nx = nx;
  grid.ny = ny;
  grid.nz = nz;
  grid.origin = origin;
  grid.spacing = spacing;
  grid.values.resize(static_cast<size_t>(nx) * ny * nz);
  size_t i = 0;
  for (int z = 0; z < nz; ++z) {
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) grid.values[i++] = static_cast<float>(f(grid.point(x, y, z)));
    }
  }
  return grid;
}

namespace {

// The surface of the cube layers [z0, z1): triangles over the slab's own
// vertices, numbered in the order its cubes first reach them.
struct SlabSurface {
  std::vector<glm::vec3> positions;
  std::vector<uint64_t> keys;
  std::vector<uint32_t> indices;
};

SlabSurface marchSlab(const ScalarGrid& grid, int z0, int z1) {
  const auto& table = marchingCubesCaseTable();
  const auto& edges = cubeEdges();
  SlabSurface slab;
  // The slab's edges start on its grid planes z0..z1: a dense table of
  // them is cheaper than hashing (3 edges per point).
  const uint64_t plane = static_cast<uint64_t>(grid.nx) * grid.ny;
  const uint64_t first_key = static_cast<uint64_t>(z0) * plane * 3;
  std::vector<uint32_t> vertex_of_edge(static_cast<size_t>(z1 - z0 + 1) * plane * 3, UINT32_MAX);
  auto vertexFor = [&](int x, int y, int z, const CubeEdge& edge) -> uint32_t {
    const int bx = x + (edge.base & 1), by = y + ((edge.base >> 1) & 1),
              bz = z + ((edge.base >> 2) & 1);
    const uint64_t key = ((static_cast<uint64_t>(bz) * grid.ny + by) * grid.nx + bx) * 3 +
                         static_cast<uint64_t>(edge.axis);
    uint32_t& vertex = vertex_of_edge[key - first_key];
    if (vertex == UINT32_MAX) {
      vertex = static_cast<uint32_t>(slab.positions.size());
      const int ox = bx + (edge.axis == 0), oy = by + (edge.axis == 1), oz = bz + (edge.axis == 2);
      const double v0 = grid.at(bx, by, bz), v1 = grid.at(ox, oy, oz);
      // Linear placement of the zero crossing, kept off the end points so no
      // triangle collapses to zero area.
      const double t = std::clamp(v0 / (v0 - v1), 1e-3, 1.0 - 1e-3);
      const glm::dvec3 p =
          grid.point(bx, by, bz) + t * (grid.point(ox, oy, oz) - grid.point(bx, by, bz));
      slab.positions.emplace_back(p);
      slab.keys.push_back(key);
    }
    return vertex;
  };
  for (int z = z0; z < z1; ++z) {
    for (int y = 0; y + 1 < grid.ny; ++y) {
      for (int x = 0; x + 1 < grid.nx; ++x) {
        int config = 0;
        for (int c = 0; c < 8; ++c) {
          if (grid.at(x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1)) > 0.0f) config |= 1 << c;
        }
        for (int e : table[config]) slab.indices.push_back(vertexFor(x, y, z, edges[e]));
      }
    }
  }
  return slab;
}

}  // namespace

Mesh marchingCubes(const ScalarGrid& grid) {
  // Slabs of cube layers are marched side by side and joined in z order.
  // A vertex on the plane between two slabs is reached by both: the lower
  // one numbered it first, as a scan of the whole grid would, so the
  // joined mesh is the whole scan's, vertex for vertex, however many
  // threads marched it.
  constexpr int kSlabLayers = 4;
  const int layers = std::max(grid.nz - 1, 0);
  const int slab_count = (layers + kSlabLayers - 1) / kSlabLayers;
  std::vector<SlabSurface> slabs(static_cast<size_t>(slab_count));
  tbb::parallel_for(0, slab_count, [&](int i) {
    slabs[i] = marchSlab(grid, i * kSlabLayers, std::min((i + 1) * kSlabLayers, layers));
  });
  Mesh mesh;
  const uint64_t plane_keys = static_cast<uint64_t>(grid.nx) * grid.ny * 3;
  std::unordered_map<uint64_t, uint32_t> on_plane;  // the plane between this slab and the last
  for (int i = 0; i < slab_count; ++i) {
    const SlabSurface& slab = slabs[i];
    const uint64_t bottom = static_cast<uint64_t>(i) * kSlabLayers;
    const uint64_t top = std::min<uint64_t>(bottom + kSlabLayers, layers);
    std::unordered_map<uint64_t, uint32_t> on_top;
    std::vector<uint32_t> joined(slab.positions.size());
    for (size_t v = 0; v < slab.positions.size(); ++v) {
      const uint64_t key = slab.keys[v];
      const uint64_t z = key / plane_keys;
      if (z == bottom && i > 0) {
        if (auto it = on_plane.find(key); it != on_plane.end()) {
          joined[v] = it->second;
          continue;
        }
      }
      joined[v] = static_cast<uint32_t>(mesh.positions.size());
      mesh.positions.push_back(slab.positions[v]);
      mesh.vertex_keys.push_back(key);
      if (z == top) on_top.emplace(key, joined[v]);
    }
    for (uint32_t index : slab.indices) mesh.indices.push_back(joined[index]);
    on_plane = std::move(on_top);
  }
  computeVertexNormals(mesh);
  return mesh;
}

}  // namespace holofuse
