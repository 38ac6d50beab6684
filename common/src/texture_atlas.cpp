#include "common/texture_atlas.h"

#include <algorithm>
#include <cmath>
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

bool texelInHalf(const AtlasCell& cell, uint32_t square_texels, uint32_t x, uint32_t y) {
  const uint32_t diagonal = (x - cell.x) + (y - cell.y);  // texel centre u + v - 1
  return cell.odd ? diagonal >= square_texels : diagonal < square_texels;
}

TextureAtlas::TextureAtlas(const AtlasOptions& options) : options_(options) {
  options_.texels = std::clamp(options_.texels, kMinAtlasTexels, kMaxAtlasTexels);
  options_.max_texels = std::clamp(options_.max_texels, options_.texels, kMaxAtlasTexels);
  options_.min_square_texels = std::max<uint32_t>(options_.min_square_texels, 6);
  options_.headroom = std::clamp(options_.headroom, 1.0, 4.0);
}

StatusOr<std::vector<AtlasCell>> TextureAtlas::layOut(Mesh& mesh, AtlasStats* stats) {
  const SquareAssignment assignment = assignSquares(mesh, options_.lattice);
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
      for (texels = options_.texels;
           texels / side < options_.min_square_texels && texels * 2 <= options_.max_texels;)
        texels *= 2;
      if (texels / side >= options_.min_square_texels) {
        fits = true;
        break;
      }
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
    square_texels = texels / side;
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

  const size_t triangles = mesh.triangleCount();
  std::vector<AtlasCell> cells(triangles);
  std::vector<glm::vec2> uvs(3 * triangles);
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t slot = slot_of_key.at(assignment.key_of_triangle[t]);
    AtlasCell& cell = cells[t];
    cell.x = (slot % side) * square_texels;
    cell.y = (slot / side) * square_texels;
    cell.odd = assignment.odd[t];
    const auto corners = innerTriangleTexels(cell, square_texels);
    for (int k = 0; k < 3; ++k) uvs[3 * t + k] = glm::vec2(corners[k] / double(texels));
  }

  mesh.corner_uvs = std::move(uvs);
  texels_ = texels;
  squares_per_side_ = side;
  square_texels_ = square_texels;
  slot_of_key_ = assignment.keyed ? std::move(slot_of_key) : decltype(slot_of_key){};
  if (stats != nullptr) {
    stats->texels = texels;
    stats->squares_per_side = side;
    stats->square_texels = square_texels;
    stats->squares_used = static_cast<uint32_t>(squares);
    stats->squares_kept = kept;
    stats->regridded = regrid;
  }
  return cells;
}

}  // namespace holofuse
