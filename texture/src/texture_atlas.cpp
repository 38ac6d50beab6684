#include "texture/texture_atlas.h"

#include <lz4.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <tuple>

namespace holofuse {

namespace {

// Which square each triangle goes to (a key that names the same patch of
// surface in every frame) and which half of it.
struct SquareAssignment {
  std::vector<uint64_t> key_of_triangle;
  std::vector<bool> odd;
  bool keyed = false;  // keys name patches of surface, so squares may be kept
};

// A marching-cubes triangle lies in one cube of the lattice: its vertices
// sit on edges of that cube, each edge based at the cube's lowest corner
// plus 0 or 1 on the axes across it, so the cube's corner is the smallest
// coordinate per axis. The cube's triangles, in the order of their vertex
// keys, pair up into squares: the same cube in the same configuration
// fills the same squares the same way.
bool keyByLatticeCell(const Mesh& mesh, const glm::u64vec3& lattice, SquareAssignment& out) {
  const size_t triangles = mesh.triangleCount();
  if (lattice.x == 0 || lattice.y == 0 || lattice.z == 0 ||
      mesh.vertex_keys.size() != mesh.vertexCount())
    return false;
  const uint64_t points = lattice.x * lattice.y * lattice.z;
  struct Entry {
    uint64_t cell;
    std::array<uint64_t, 3> keys;
    uint32_t triangle;
  };
  std::vector<Entry> entries(triangles);
  for (size_t t = 0; t < triangles; ++t) {
    Entry& e = entries[t];
    glm::u64vec3 corner(UINT64_MAX);
    for (int k = 0; k < 3; ++k) {
      const uint64_t key = mesh.vertex_keys[mesh.indices[3 * t + k]];
      const uint64_t point = key / 3;
      if (point >= points) return false;  // not a key on this lattice
      const glm::u64vec3 at(point % lattice.x, (point / lattice.x) % lattice.y,
                            point / (lattice.x * lattice.y));
      corner = glm::min(corner, at);
      e.keys[k] = key;
    }
    std::sort(e.keys.begin(), e.keys.end());
    e.cell = (corner.z * lattice.y + corner.y) * lattice.x + corner.x;
    e.triangle = static_cast<uint32_t>(t);
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return std::tie(a.cell, a.keys, a.triangle) < std::tie(b.cell, b.keys, b.triangle);
  });
  out.key_of_triangle.assign(triangles, 0);
  out.odd.assign(triangles, false);
  // A cell holds at most five triangles; the ordinal gets 16 bits so no
  // mesh, however made, gives two pairs one key.
  uint32_t ordinal = 0;
  for (size_t i = 0; i < entries.size(); ++i) {
    ordinal = (i > 0 && entries[i].cell == entries[i - 1].cell) ? ordinal + 1 : 0;
    if (ordinal / 2 >= (1u << 16)) return false;
    out.key_of_triangle[entries[i].triangle] = (entries[i].cell << 16) | (ordinal / 2);
    out.odd[entries[i].triangle] = (ordinal % 2) == 1;
  }
  out.keyed = true;
  return true;
}

// Charts: a triangle's square is its lattice cell's block of n^3 cells and
// the dominant axis (signed) of the surface's normal around it (or, for a
// receiver before protocol 1.12, of its own normal), so a block's surface
// facing one way shares one square, projected orthographically along that
// axis. The normal is the area-weighted sum
// over the triangle's cell and the cell's six face neighbours, not the
// triangle's own: a hull's facets tilt from frame to frame, and a patch
// whose triangles each took their own axis changed chart wherever one
// crossed 45 degrees, a new square the video could not predict (eval,
// h264 layers, 4 cells a chart: clean 157.8 -> 134.5 KB a frame, SSIM
// 0.6948 -> 0.6946; many-cameras 143.2 -> 127.1 KB, SSIM 0.8099 ->
// 0.8106; charts moved a frame 21% -> 18% and 19% -> 15%). The sums are
// integers, so they do not depend on the order of the triangles, and both
// sides of the wire compute them from the same decoded positions: they
// agree on every triangle's axis.
bool keyByChart(const Mesh& mesh, const glm::u64vec3& lattice, uint32_t chart_cells,
                bool face_surface_around, SquareAssignment& out,
                std::vector<uint8_t>& axis_of_triangle) {
  if (!keyByLatticeCell(mesh, lattice, out)) return false;
  const uint64_t n = chart_cells;
  const glm::u64vec3 blocks((lattice.x + n - 1) / n, (lattice.y + n - 1) / n,
                            (lattice.z + n - 1) / n);
  const size_t triangles = mesh.triangleCount();
  // Twice a triangle's area vector in units of 2^-32 square metres: a
  // millimetre-sized triangle still counts. Each component is capped at
  // 2^42 units (a triangle of 512 square metres), so seven cells of the
  // most triangles keyByLatticeCell admits (2^17) cannot overflow, whatever
  // positions arrive.
  constexpr double kAreaUnits = 4294967296.0, kMostUnits = 4398046511104.0;
  const auto own_normal = [&](size_t t) {
    const glm::dvec3 a(mesh.positions[mesh.indices[3 * t]]),
        b(mesh.positions[mesh.indices[3 * t + 1]]), c(mesh.positions[mesh.indices[3 * t + 2]]);
    return glm::cross(b - a, c - a);
  };
  std::unordered_map<uint64_t, glm::i64vec3> cell_normals;
  if (face_surface_around) cell_normals.reserve(triangles);
  for (size_t t = 0; t < triangles && face_surface_around; ++t) {
    const glm::dvec3 normal = own_normal(t) * kAreaUnits;
    glm::i64vec3 units(0);
    for (int k = 0; k < 3; ++k) {  // NaN (a corrupt position) counts as nothing
      if (!std::isnan(normal[k]))
        units[k] = std::llround(std::clamp(normal[k], -kMostUnits, kMostUnits));
    }
    cell_normals[out.key_of_triangle[t] >> 16] += units;
  }
  axis_of_triangle.assign(triangles, 0);
  for (size_t t = 0; t < triangles; ++t) {
    const uint64_t cell = out.key_of_triangle[t] >> 16;
    const glm::u64vec3 at(cell % lattice.x, (cell / lattice.x) % lattice.y,
                          cell / (lattice.x * lattice.y));
    const glm::u64vec3 block(at.x / n, at.y / n, at.z / n);
    glm::dvec3 normal;
    if (!face_surface_around) {
      normal = own_normal(t);
    } else {
      glm::i64vec3 around = cell_normals.at(cell);
      uint64_t stride = 1;
      for (int k = 0; k < 3; ++k) {
        if (at[k] > 0) {
          const auto below = cell_normals.find(cell - stride);
          if (below != cell_normals.end()) around += below->second;
        }
        if (at[k] + 1 < lattice[k]) {
          const auto above = cell_normals.find(cell + stride);
          if (above != cell_normals.end()) around += above->second;
        }
        stride *= lattice[k];
      }
      normal = glm::dvec3(around);
    }
    int axis = 0;
    for (int k = 1; k < 3; ++k) {
      if (std::abs(normal[k]) > std::abs(normal[axis])) axis = k;
    }
    const uint8_t code = static_cast<uint8_t>(2 * axis + (normal[axis] < 0 ? 1 : 0));
    axis_of_triangle[t] = code;
    out.key_of_triangle[t] = (((block.z * blocks.y + block.y) * blocks.x + block.x) << 3) | code;
    out.odd[t] = false;
  }
  return true;
}

SquareAssignment assignSquares(const Mesh& mesh, const glm::u64vec3& lattice) {
  SquareAssignment out;
  if (keyByLatticeCell(mesh, lattice, out)) return out;
  // The paper's global order: triangle t in square t / 2.
  const size_t triangles = mesh.triangleCount();
  out.key_of_triangle.resize(triangles);
  out.odd.resize(triangles);
  for (size_t t = 0; t < triangles; ++t) {
    out.key_of_triangle[t] = t / 2;
    out.odd[t] = (t % 2) == 1;
  }
  out.keyed = false;
  return out;
}

uint32_t ceilSqrt(double value) {
  uint32_t side = static_cast<uint32_t>(std::ceil(std::sqrt(value)));
  while (double(side) * side < value) ++side;
  return std::max<uint32_t>(side, 1);
}

// Every triangle's cell and inner-triangle UVs from its square's slot.
template <typename SlotOf>
std::vector<AtlasCell> placeTriangles(Mesh& mesh, const SquareAssignment& assignment, uint32_t side,
                                      uint32_t square_texels, uint32_t texels, SlotOf slot_of) {
  const size_t triangles = mesh.triangleCount();
  std::vector<AtlasCell> cells(triangles);
  std::vector<glm::vec2> uvs(3 * triangles);
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t slot = slot_of(assignment.key_of_triangle[t]);
    AtlasCell& cell = cells[t];
    cell.x = (slot % side) * square_texels;
    cell.y = (slot / side) * square_texels;
    cell.odd = assignment.odd[t];
    // The inner triangle's first corner goes to the vertex of the smallest
    // key and the rest follow the winding: a receiver whose codec rotated
    // the triangle's corners puts each texel on the same point.
    int first = 0;
    if (assignment.keyed) {
      for (int k = 1; k < 3; ++k) {
        if (mesh.vertex_keys[mesh.indices[3 * t + k]] <
            mesh.vertex_keys[mesh.indices[3 * t + first]])
          first = k;
      }
    }
    const auto corners = innerTriangleTexels(cell, square_texels);
    for (int k = 0; k < 3; ++k)
      uvs[3 * t + (first + k) % 3] = glm::vec2(corners[k] / double(texels));
  }
  mesh.corner_uvs = std::move(uvs);
  return cells;
}

// The key lattice's origin and spacing, fitted to the mesh: a vertex lies
// on the lattice edge its key names, so across that edge (on the two other
// axes) it sits on lattice planes, p_k = origin_k + spacing * i_k. A least
// squares fit over those coordinates, one spacing for the three axes. The
// sender and the receiver fit the same decoded positions, so they agree on
// every texel without the lattice's place in the world on the wire.
struct LatticeFit {
  glm::dvec3 origin{0.0};
  double spacing = 0.0;
};

glm::u64vec3 latticePoint(uint64_t key, const glm::u64vec3& lattice) {
  const uint64_t point = key / 3;
  return glm::u64vec3(point % lattice.x, (point / lattice.x) % lattice.y,
                      point / (lattice.x * lattice.y));
}

LatticeFit fitLattice(const Mesh& mesh, const glm::u64vec3& lattice, double fallback_spacing) {
  glm::dvec3 count(0.0), sum_i(0.0), sum_p(0.0);
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    const glm::dvec3 i(latticePoint(mesh.vertex_keys[v], lattice));
    const uint64_t along = mesh.vertex_keys[v] % 3;
    for (int k = 0; k < 3; ++k) {
      if (uint64_t(k) == along) continue;
      count[k] += 1;
      sum_i[k] += i[k];
      sum_p[k] += mesh.positions[v][k];
    }
  }
  const glm::dvec3 mean_i = sum_i / glm::max(count, glm::dvec3(1.0)),
                   mean_p = sum_p / glm::max(count, glm::dvec3(1.0));
  double covariance = 0, variance = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    const glm::dvec3 i(latticePoint(mesh.vertex_keys[v], lattice));
    const uint64_t along = mesh.vertex_keys[v] % 3;
    for (int k = 0; k < 3; ++k) {
      if (uint64_t(k) == along) continue;
      covariance += (i[k] - mean_i[k]) * (mesh.positions[v][k] - mean_p[k]);
      variance += (i[k] - mean_i[k]) * (i[k] - mean_i[k]);
    }
  }
  LatticeFit fit;
  // Too few points to fit (a mesh inside one plane of cells): the spacing
  // the layout implies, the same at both ends.
  fit.spacing = variance > 0.5 && covariance > 0 ? covariance / variance : fallback_spacing;
  fit.origin = mean_p - fit.spacing * mean_i;
  return fit;
}

// Charts' UVs: each triangle's corners projected along its chart's axis
// onto the square, from the corner of the chart's block of lattice cells
// at texel_metres a texel, inside the square's gutter. The projection is
// anchored to the lattice, not to the surface: a part of the surface that
// stays in its chart keeps its texels (what the layers' video predicts
// from), however the rest of the chart changes.
template <typename SlotOf>
void placeCharts(Mesh& mesh, const SquareAssignment& assignment,
                 const std::vector<uint8_t>& axis_of_triangle, const glm::u64vec3& lattice,
                 uint32_t chart_cells, uint32_t side, uint32_t square_texels, uint32_t texels,
                 double texel_metres, SlotOf slot_of,
                 std::unordered_map<uint64_t, glm::dvec2>* anchors = nullptr) {
  const size_t triangles = mesh.triangleCount();
  const double inside = square_texels - 2.0 * kChartGutterTexels;
  const LatticeFit fit = fitLattice(mesh, lattice, texel_metres * inside / chart_cells);
  const uint64_t n = chart_cells;
  const glm::u64vec3 blocks((lattice.x + n - 1) / n, (lattice.y + n - 1) / n,
                            (lattice.z + n - 1) / n);
  // A vertex's place on the lattice in cells: exact across its edge, the
  // fitted fraction along it.
  auto cells_at = [&](uint32_t v) {
    const uint64_t key = mesh.vertex_keys[v];
    glm::dvec3 at(latticePoint(key, lattice));
    const int along = static_cast<int>(key % 3);
    at[along] = std::clamp((mesh.positions[v][along] - fit.origin[along]) / fit.spacing, at[along],
                           at[along] + 1.0);
    return at;
  };
  const double texels_per_cell = fit.spacing / texel_metres;
  std::vector<glm::vec2> uvs(3 * triangles);
  for (size_t t = 0; t < triangles; ++t) {
    const uint64_t key = assignment.key_of_triangle[t];
    const uint64_t block = key >> 3;
    const glm::dvec3 block_cells(double(block % blocks.x * n),
                                 double((block / blocks.x) % blocks.y * n),
                                 double(block / (blocks.x * blocks.y) * n));
    const int axis = axis_of_triangle[t] / 2;
    if (anchors != nullptr) {
      // Where the chart's corner texel lies in the world, across its axis.
      const glm::dvec3 world = fit.origin + fit.spacing * block_cells;
      anchors->try_emplace(key, world[(axis + 1) % 3], world[(axis + 2) % 3]);
    }
    const uint32_t slot = slot_of(key);
    const glm::dvec2 corner(double(slot % side) * square_texels + kChartGutterTexels,
                            double(slot / side) * square_texels + kChartGutterTexels);
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 local = (cells_at(mesh.indices[3 * t + k]) - block_cells) * texels_per_cell;
      const glm::dvec2 projected(local[(axis + 1) % 3], local[(axis + 2) % 3]);
      uvs[3 * t + k] = glm::vec2((corner + glm::clamp(projected, 0.0, inside)) / double(texels));
    }
  }
  mesh.corner_uvs = std::move(uvs);
}

}  // namespace

std::array<glm::dvec2, 3> innerTriangleTexels(const AtlasCell& cell, uint32_t square_texels) {
  // Algorithm 2 with one texel for its pixel p and the square for w, but
  // for the odd triangle's long side: Algorithm 2 leaves two texels along
  // the diagonal, which keeps nearest sampling apart, while a bilinear
  // sample reads texels up to one away on both axes; at three, the texels
  // the even triangle's samples read (centre u + v <= w) and the odd one's
  // (u + v >= w + 1) are disjoint.
  const double w = square_texels, p = 1.0;
  const glm::dvec2 corner(cell.x, cell.y);
  if (!cell.odd) {
    return {corner + glm::dvec2(p, p), corner + glm::dvec2(w - 2 * p, p),
            corner + glm::dvec2(p, w - 2 * p)};
  }
  return {corner + glm::dvec2(w - p, 3 * p), corner + glm::dvec2(w - p, w - p),
          corner + glm::dvec2(3 * p, w - p)};
}

TextureAtlas::TextureAtlas(const AtlasOptions& options) : options_(options) {
  options_.texels = std::clamp(options_.texels, kMinAtlasTexels, kMaxAtlasTexels);
  options_.max_texels = std::clamp(options_.max_texels, options_.texels, kMaxAtlasTexels);
  options_.min_square_texels = std::max<uint32_t>(options_.min_square_texels, 6);
  options_.headroom = std::clamp(options_.headroom, 1.0, 4.0);
}

StatusOr<std::vector<AtlasCell>> TextureAtlas::layOut(Mesh& mesh, AtlasStats* stats) {
  const bool charts = options_.chart_cells > 0;
  SquareAssignment assignment;
  std::vector<uint8_t> axes;
  if (charts) {
    if (!(options_.cell_size > 0) || !(options_.texels_per_cell > 0))
      return Status(StatusCode::kMalformed, "texture atlas: charts need the lattice's cell size");
    if (!keyByChart(mesh, options_.lattice, options_.chart_cells,
                    options_.charts_face_surface_around, assignment, axes))
      return Status(StatusCode::kMalformed,
                    "texture atlas: charts need the mesh's vertex keys on the hull's lattice");
  } else {
    assignment = assignSquares(mesh, options_.lattice);
  }
  // A chart's square: its cells at the chosen density inside a gutter.
  const uint32_t chart_texels =
      charts ? static_cast<uint32_t>(std::ceil(options_.chart_cells * options_.texels_per_cell)) +
                   2 * kChartGutterTexels
             : 0;
  std::vector<uint64_t> keys = assignment.key_of_triangle;
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  const uint64_t squares = keys.size();

  // Eq. 1 with spare squares; a new grid only when the squares no longer
  // fit or fill under a quarter of it, so the layout holds from frame to
  // frame.
  bool regrid = !assignment.keyed || squares_per_side_ == 0 ||
                squares > uint64_t{squares_per_side_} * squares_per_side_ ||
                (squares * 4 < uint64_t{squares_per_side_} * squares_per_side_ &&
                 ceilSqrt(squares * options_.headroom) < squares_per_side_);
  uint32_t texels = texels_, side = squares_per_side_, square_texels = square_texels_;
  if (regrid) {
    // Try with headroom first, then without, growing the texture by
    // doubling up to its cap.
    bool fits = false;
    for (const double headroom : {options_.headroom, 1.0}) {
      side = ceilSqrt(std::max<double>(squares, 1) * headroom);
      if (charts) {
        // The density is fixed: the texture is as large as its charts need.
        texels = std::max<uint32_t>(side * chart_texels, kMinAtlasTexels);
        fits = uint64_t{side} * chart_texels <= options_.max_texels;
        if (fits) break;
        continue;
      }
      for (texels = options_.texels;
           texels / side < options_.min_square_texels && texels * 2 <= options_.max_texels;)
        texels *= 2;
      if (texels / side >= options_.min_square_texels) {
        fits = true;
        break;
      }
    }
    if (!fits && charts) {
      return Status(StatusCode::kTooLarge,
                    "texture atlas: " + std::to_string(squares) + " charts of " +
                        std::to_string(chart_texels) + " texels need more than a " +
                        std::to_string(options_.max_texels) +
                        "-texel atlas (raise its largest size or lower the texels per cell)");
    }
    if (!fits) {
      return Status(StatusCode::kTooLarge,
                    "texture atlas: " + std::to_string(mesh.triangleCount()) + " triangles need " +
                        std::to_string(squares) + " squares of at least " +
                        std::to_string(options_.min_square_texels) + " texels; a " +
                        std::to_string(options_.max_texels) + "-texel atlas holds " +
                        std::to_string(uint64_t{options_.max_texels / options_.min_square_texels} *
                                       (options_.max_texels / options_.min_square_texels)) +
                        " (raise the atlas's largest size or coarsen the mesh)");
    }
    square_texels = charts ? chart_texels : texels / side;
  }

  std::unordered_map<uint64_t, uint32_t> slot_of_key;
  slot_of_key.reserve(keys.size());
  uint32_t kept = 0;
  const uint64_t capacity = uint64_t{side} * side;
  if (regrid) {
    // In key order: neighbouring cells get neighbouring squares.
    for (uint32_t i = 0; i < keys.size(); ++i) slot_of_key.emplace(keys[i], i);
  } else {
    std::vector<bool> taken(capacity, false);
    std::vector<uint64_t> arriving;
    for (const uint64_t key : keys) {
      const auto before = slot_of_key_.find(key);
      if (before != slot_of_key_.end()) {
        slot_of_key.emplace(key, before->second);
        taken[before->second] = true;
        ++kept;
      } else {
        arriving.push_back(key);
      }
    }
    uint32_t next_free = 0;
    for (const uint64_t key : arriving) {
      while (taken[next_free]) ++next_free;  // fits: squares <= capacity
      taken[next_free] = true;
      slot_of_key.emplace(key, next_free);
    }
  }

  const auto slot_of = [&](uint64_t key) { return slot_of_key.at(key); };
  std::vector<AtlasCell> cells =
      placeTriangles(mesh, assignment, side, square_texels, texels, slot_of);
  const double texel_metres = charts ? options_.cell_size / options_.texels_per_cell : 0.0;
  std::unordered_map<uint64_t, glm::dvec2> anchors;
  if (charts) {
    placeCharts(mesh, assignment, axes, options_.lattice, options_.chart_cells, side, square_texels,
                texels, texel_metres, slot_of, &anchors);
    for (size_t t = 0; t < cells.size(); ++t) cells[t].chart_axis = axes[t];
  }
  // A square moved: new to the atlas, in another slot, or (charts) its
  // surface half a texel or more away from where it was.
  uint32_t moved = static_cast<uint32_t>(squares) - kept;
  if (!regrid && charts) {
    for (const auto& [key, anchor] : anchors) {
      const auto before = anchors_.find(key);
      if (before != anchors_.end() && slot_of_key_.count(key) &&
          glm::length(anchor - before->second) >= 0.5 * texel_metres)
        ++moved;
    }
  }
  anchors_ = std::move(anchors);
  texels_ = texels;
  squares_per_side_ = side;
  square_texels_ = square_texels;
  layout_ = AtlasLayout{texels, side, square_texels, glm::u64vec3(0), {}, 0, 0.0};
  if (charts) {
    layout_.chart_cells = options_.chart_cells;
    layout_.texel_metres = texel_metres;
    layout_.charts_face_surface_around = options_.charts_face_surface_around;
  }
  if (assignment.keyed) {
    layout_.lattice = options_.lattice;
    layout_.slots.reserve(keys.size());
    for (const uint64_t key : keys) layout_.slots.push_back(slot_of_key.at(key));
  }
  slot_of_key_ = assignment.keyed ? std::move(slot_of_key) : decltype(slot_of_key){};
  if (stats != nullptr) {
    stats->texels = texels;
    stats->squares_per_side = side;
    stats->square_texels = square_texels;
    stats->squares_used = static_cast<uint32_t>(squares);
    stats->squares_kept = kept;
    stats->squares_moved = regrid ? static_cast<uint32_t>(squares) : moved;
    stats->regridded = regrid;
  }
  return cells;
}

StatusOr<std::vector<AtlasCell>> applyAtlasLayout(Mesh& mesh, const AtlasLayout& layout) {
  auto refuse = [](const std::string& what) {
    return Status(StatusCode::kMalformed, "atlas layout: " + what);
  };
  if (!layout.keyed()) return refuse("no key lattice");
  const bool charts = layout.chart_cells > 0;
  if (charts && (!(layout.texel_metres > 0) || !std::isfinite(layout.texel_metres) ||
                 layout.chart_cells > 64))
    return refuse("charts of " + std::to_string(layout.chart_cells) + " cells at " +
                  std::to_string(layout.texel_metres) + " m a texel");
  if (layout.squares_per_side == 0 ||
      layout.square_texels < (charts ? 2 * kChartGutterTexels + 1 : 6) ||
      uint64_t{layout.squares_per_side} * layout.square_texels > layout.texels ||
      layout.texels > kMaxAtlasTexels)
    return refuse(std::to_string(layout.squares_per_side) + " squares of " +
                  std::to_string(layout.square_texels) + " texels do not fit an atlas of " +
                  std::to_string(layout.texels));
  SquareAssignment assignment;
  std::vector<uint8_t> axes;
  if (!(charts ? keyByChart(mesh, layout.lattice, layout.chart_cells,
                            layout.charts_face_surface_around, assignment, axes)
               : keyByLatticeCell(mesh, layout.lattice, assignment)))
    return refuse("the mesh's vertex keys are not on the layout's lattice");
  std::vector<uint64_t> keys = assignment.key_of_triangle;
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  if (keys.size() != layout.slots.size())
    return refuse("the mesh makes " + std::to_string(keys.size()) + " squares, the layout has " +
                  std::to_string(layout.slots.size()));
  const uint64_t capacity = uint64_t{layout.squares_per_side} * layout.squares_per_side;
  for (const uint32_t slot : layout.slots) {
    if (slot >= capacity)
      return refuse("slot " + std::to_string(slot) + " outside a grid of " +
                    std::to_string(capacity));
  }
  const auto slot_of = [&](uint64_t key) {
    const auto at = std::lower_bound(keys.begin(), keys.end(), key);
    return layout.slots[static_cast<size_t>(at - keys.begin())];
  };
  auto cells = placeTriangles(mesh, assignment, layout.squares_per_side, layout.square_texels,
                              layout.texels, slot_of);
  if (charts) {
    placeCharts(mesh, assignment, axes, layout.lattice, layout.chart_cells, layout.squares_per_side,
                layout.square_texels, layout.texels, layout.texel_metres, slot_of);
    for (size_t t = 0; t < cells.size(); ++t) cells[t].chart_axis = axes[t];
  }
  return cells;
}

std::vector<uint8_t> encodeAtlasSlots(const std::vector<uint32_t>& slots) {
  std::vector<uint8_t> raw;
  raw.reserve(slots.size() + 16);
  uint32_t previous = 0;
  for (const uint32_t slot : slots) {
    const int64_t delta = int64_t{slot} - int64_t{previous};
    uint64_t zigzag = static_cast<uint64_t>(delta >= 0 ? 2 * delta : -2 * delta - 1);
    do {  // LEB128: seven bits a byte, the high bit says more follow
      raw.push_back(static_cast<uint8_t>((zigzag & 0x7f) | (zigzag > 0x7f ? 0x80 : 0)));
      zigzag >>= 7;
    } while (zigzag != 0);
    previous = slot;
  }
  std::vector<uint8_t> out(static_cast<size_t>(LZ4_compressBound(static_cast<int>(raw.size()))));
  const int n = LZ4_compress_default(reinterpret_cast<const char*>(raw.data()),
                                     reinterpret_cast<char*>(out.data()),
                                     static_cast<int>(raw.size()), static_cast<int>(out.size()));
  out.resize(static_cast<size_t>(std::max(n, 0)));
  return out;
}

StatusOr<std::vector<uint32_t>> decodeAtlasSlots(std::span<const uint8_t> bytes, uint32_t count) {
  // A grid holds at most (kMaxAtlasTexels / 6)^2 squares.
  constexpr uint64_t kMaxSquares = uint64_t{kMaxAtlasTexels / 6} * (kMaxAtlasTexels / 6);
  if (count > kMaxSquares)
    return Status(StatusCode::kTooLarge, "atlas slots: " + std::to_string(count) +
                                             " squares above cap " + std::to_string(kMaxSquares));
  auto malformed = [&](const std::string& what) {
    return Status(StatusCode::kMalformed, "atlas slots: " + std::to_string(bytes.size()) +
                                              " bytes for " + std::to_string(count) +
                                              " squares: " + what);
  };
  // A delta takes at most five bytes.
  std::vector<uint8_t> raw(5 * size_t{count});
  const int n = raw.empty() ? (bytes.size() == 1 && bytes[0] == 0 ? 0 : -1)
                            : LZ4_decompress_safe(reinterpret_cast<const char*>(bytes.data()),
                                                  reinterpret_cast<char*>(raw.data()),
                                                  static_cast<int>(bytes.size()),
                                                  static_cast<int>(raw.size()));
  if (n < 0) return malformed("not an LZ4 block of at most 5 bytes a square");
  std::vector<uint32_t> slots(count);
  int64_t previous = 0;
  size_t at = 0;
  for (size_t i = 0; i < count; ++i) {
    uint64_t zigzag = 0;
    for (int shift = 0;; shift += 7) {
      if (at >= static_cast<size_t>(n) || shift > 28)
        return malformed("square " + std::to_string(i) + " cut short");
      const uint8_t byte = raw[at++];
      zigzag |= uint64_t{byte & 0x7fu} << shift;
      if ((byte & 0x80) == 0) break;
    }
    const int64_t delta =
        (zigzag & 1) ? -static_cast<int64_t>(zigzag >> 1) - 1 : static_cast<int64_t>(zigzag >> 1);
    previous += delta;
    if (previous < 0 || previous > int64_t{UINT32_MAX})
      return malformed("slot " + std::to_string(i) + " outside 0..2^32");
    slots[i] = static_cast<uint32_t>(previous);
  }
  if (at != static_cast<size_t>(n)) return malformed("bytes left after the last square");
  return slots;
}

}  // namespace holofuse
