// The per-frame texture atlas (Dong and Hollerer 2017, Algorithms 1 and 2)
// and the texture coordinates Draco carries with the mesh.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "codec/image_codec.h"
#include "codec/mesh_codec.h"
#include "geometry/camera.h"
#include "geometry/marching_cubes.h"
#include "texture/texture_atlas.h"
#include "texture/texture_layers.h"

namespace holofuse {
namespace {

constexpr int kGrid = 40;
constexpr double kSpacing = 0.05;

// A sphere on a fixed lattice, as the hull gives one: the same grid edge
// has the same key whatever the centre.
Mesh sphereOnLattice(const glm::dvec3& centre, double radius) {
  const ScalarGrid grid =
      sampleGrid(glm::dvec3(-1.0), kSpacing, kGrid, kGrid, kGrid,
                 [&](const glm::dvec3& p) { return radius - glm::length(p - centre); });
  return marchingCubes(grid);
}

AtlasOptions latticeOptions() {
  AtlasOptions options;
  options.lattice = glm::u64vec3(kGrid);
  return options;
}

// Charts of 4^3 lattice cells at 3 texels a cell.
AtlasOptions chartOptions() {
  AtlasOptions options = latticeOptions();
  options.chart_cells = 4;
  options.texels_per_cell = 3.0;
  options.cell_size = kSpacing;
  return options;
}

double signedArea(const glm::vec2& a, const glm::vec2& b, const glm::vec2& c) {
  return 0.5 * ((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
}

TEST(TextureAtlas, EveryTriangleGetsItsOwnHalfSquareInsetByATexel) {
  Mesh mesh = sphereOnLattice(glm::dvec3(0.013, -0.02, 0.007), 0.7);
  ASSERT_GT(mesh.triangleCount(), 2000u);
  TextureAtlas atlas(latticeOptions());
  AtlasStats stats;
  auto cells = atlas.layOut(mesh, &stats);
  ASSERT_TRUE(cells.isOk()) << cells.status().toString();
  ASSERT_EQ(mesh.corner_uvs.size(), mesh.indices.size());
  ASSERT_EQ(cells->size(), mesh.triangleCount());
  // Eq. 1 with the headroom: enough squares, and no more than it asks.
  EXPECT_GE(uint64_t{stats.squares_per_side} * stats.squares_per_side, stats.squares_used);
  EXPECT_GE(2u * stats.squares_used, mesh.triangleCount());
  EXPECT_EQ(stats.square_texels, stats.texels / stats.squares_per_side);
  EXPECT_GE(stats.square_texels, 6u);
  std::set<std::tuple<uint32_t, uint32_t, bool>> halves;
  const double texels = stats.texels, q = stats.square_texels;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const AtlasCell& cell = (*cells)[t];
    EXPECT_TRUE(halves.emplace(cell.x, cell.y, cell.odd).second)
        << "triangle " << t << " shares a half";
    EXPECT_EQ(cell.x % stats.square_texels, 0u);
    EXPECT_EQ(cell.y % stats.square_texels, 0u);
    const glm::vec2* uv = &mesh.corner_uvs[3 * t];
    EXPECT_GT(std::abs(signedArea(uv[0], uv[1], uv[2])), 0.0) << "triangle " << t;
    for (int k = 0; k < 3; ++k) {
      // In texels from the square's corner: at least a texel inside the
      // square's border, and the two halves' bilinear footprints (a texel
      // around each point) apart across the diagonal.
      const double u = uv[k].x * texels - cell.x, v = uv[k].y * texels - cell.y;
      EXPECT_GE(u, 1.0 - 1e-3);
      EXPECT_GE(v, 1.0 - 1e-3);
      EXPECT_LE(u, q - 1.0 + 1e-3);
      EXPECT_LE(v, q - 1.0 + 1e-3);
      if (cell.odd)
        EXPECT_GE(u + v, q + 2.0 - 1e-3) << "triangle " << t;
      else
        EXPECT_LE(u + v, q - 1.0 + 1e-3) << "triangle " << t;
    }
  }
}

// The point of keying squares by lattice cell: a surface that moves a
// little keeps most of its squares where they were, so the texels of a
// layer stay put; in the paper's mesh order they do not.
TEST(TextureAtlas, ASurfaceThatMovesALittleKeepsMostSquaresInPlace) {
  TextureAtlas keyed(latticeOptions());
  TextureAtlas ordered;  // no lattice: the paper's global order
  double kept_keyed = 0, kept_ordered = 0;
  const int frames = 6;
  for (int f = 0; f <= frames; ++f) {
    // A fifth of a voxel a frame, and breathing.
    Mesh mesh = sphereOnLattice(glm::dvec3(0.01 * f, 0.003 * f, 0.0), 0.7 + 0.004 * f);
    Mesh copy = mesh;
    AtlasStats a, b;
    ASSERT_TRUE(keyed.layOut(mesh, &a).isOk());
    ASSERT_TRUE(ordered.layOut(copy, &b).isOk());
    if (f == 0) {
      EXPECT_TRUE(a.regridded);
      continue;
    }
    EXPECT_FALSE(a.regridded) << "frame " << f;
    kept_keyed += a.keptFraction() / frames;
    kept_ordered += b.keptFraction() / frames;
  }
  EXPECT_GT(kept_keyed, 0.8);
  EXPECT_EQ(kept_ordered, 0.0);
}

TEST(TextureAtlas, TooManyTrianglesGrowTheAtlasOrAreRefusedByName) {
  Mesh mesh = sphereOnLattice(glm::dvec3(0.0), 0.7);
  AtlasOptions small = latticeOptions();
  small.texels = 64;
  small.max_texels = 4096;
  TextureAtlas growing(small);
  AtlasStats stats;
  ASSERT_TRUE(growing.layOut(mesh, &stats).isOk());
  EXPECT_GT(stats.texels, 64u);
  EXPECT_GE(stats.square_texels, 6u);

  small.max_texels = 64;
  TextureAtlas capped(small);
  Mesh refused = sphereOnLattice(glm::dvec3(0.0), 0.7);
  auto result = capped.layOut(refused);
  ASSERT_FALSE(result.isOk());
  EXPECT_NE(result.status().toString().find("triangles need"), std::string::npos)
      << result.status().toString();
  EXPECT_TRUE(refused.corner_uvs.empty()) << "a refused mesh keeps no half-made coordinates";
}

TEST(TextureAtlas, AnEmptyMeshGetsNoCoordinatesAndTheNextFrameIsLaidOut) {
  TextureAtlas atlas(latticeOptions());
  Mesh empty;
  auto none = atlas.layOut(empty);
  ASSERT_TRUE(none.isOk());
  EXPECT_TRUE(none->empty());
  EXPECT_TRUE(empty.corner_uvs.empty());
  Mesh mesh = sphereOnLattice(glm::dvec3(0.0), 0.5);
  ASSERT_TRUE(atlas.layOut(mesh).isOk());
  EXPECT_EQ(mesh.corner_uvs.size(), mesh.indices.size());
}

// Draco carries the coordinates per corner and keeps the vertices shared
// (the field modes need the connectivity): the same vertices and
// triangles come back, each triangle with its coordinates.
TEST(MeshCodec, AnAtlasTravelsWithTheMeshAndItsVerticesStayShared) {
  Mesh mesh = sphereOnLattice(glm::dvec3(0.0), 0.7);
  TextureAtlas atlas(latticeOptions());
  AtlasStats stats;
  ASSERT_TRUE(atlas.layOut(mesh, &stats).isOk());
  auto bytes = encodeDraco(mesh);
  ASSERT_TRUE(bytes.isOk()) << bytes.status().toString();
  auto back = decodeDraco(bytes->data(), bytes->size());
  ASSERT_TRUE(back.isOk()) << back.status().toString();
  EXPECT_EQ(back->vertexCount(), mesh.vertexCount());
  ASSERT_EQ(back->triangleCount(), mesh.triangleCount());
  ASSERT_EQ(back->corner_uvs.size(), back->indices.size());
  ASSERT_EQ(back->vertex_keys.size(), back->vertexCount());
  // Draco reorders: match triangles by their vertices' keys.
  std::map<std::array<uint64_t, 3>, const glm::vec2*> original;
  auto keyOf = [](const Mesh& m, size_t t, int rotation) {
    return std::array<uint64_t, 3>{m.vertex_keys[m.indices[3 * t + rotation % 3]],
                                   m.vertex_keys[m.indices[3 * t + (rotation + 1) % 3]],
                                   m.vertex_keys[m.indices[3 * t + (rotation + 2) % 3]]};
  };
  for (size_t t = 0; t < mesh.triangleCount(); ++t)
    original[keyOf(mesh, t, 0)] = &mesh.corner_uvs[3 * t];
  const double texel = 1.0 / stats.texels;
  size_t matched = 0;
  for (size_t t = 0; t < back->triangleCount(); ++t) {
    for (int r = 0; r < 3; ++r) {
      const auto found = original.find(keyOf(*back, t, r));
      if (found == original.end()) continue;
      ++matched;
      for (int k = 0; k < 3; ++k) {
        const glm::vec2 want = found->second[k], got = back->corner_uvs[3 * t + (r + k) % 3];
        EXPECT_LT(glm::length(glm::dvec2(want - got)), 0.05 * texel) << "triangle " << t;
      }
    }
  }
  EXPECT_EQ(matched, mesh.triangleCount());
  // A texture coordinate outside the texture is refused by name.
  Mesh outside = mesh;
  outside.corner_uvs[7] = glm::vec2(1.5f, 0.5f);
  auto lying = encodeDraco(outside);
  ASSERT_TRUE(lying.isOk());
  auto refused = decodeDraco(lying->data(), lying->size());
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().toString().find("outside [0,1]"), std::string::npos)
      << refused.status().toString();
}

// A receiver gets the layout, not the coordinates: from the decoded mesh's
// vertex keys it finds every triangle's square and puts each corner where
// the sender put that vertex, whatever order Draco gave triangles and
// corners.
TEST(AtlasLayout, AReceiverLaysTheDecodedMeshOutAgainFromItsKeys) {
  TextureAtlas atlas(latticeOptions());
  Mesh first = sphereOnLattice(glm::dvec3(0.0), 0.7);
  ASSERT_TRUE(atlas.layOut(first).isOk());
  // The second frame keeps most squares: its slots are not in key order.
  Mesh mesh = sphereOnLattice(glm::dvec3(0.01, 0.0, 0.0), 0.7);
  AtlasStats stats;
  ASSERT_TRUE(atlas.layOut(mesh, &stats).isOk());
  ASSERT_FALSE(stats.regridded);
  ASSERT_GT(stats.keptFraction(), 0.5);
  const AtlasLayout& sent = atlas.layout();
  ASSERT_TRUE(sent.keyed());
  ASSERT_EQ(sent.slots.size(), stats.squares_used);
  ASSERT_FALSE(std::is_sorted(sent.slots.begin(), sent.slots.end()));

  const std::vector<uint8_t> wire = encodeAtlasSlots(sent.slots);
  EXPECT_LT(wire.size(), sent.slots.size())
      << "a mostly kept layout compresses below a byte a square; kept " << stats.keptFraction();
  auto slots = decodeAtlasSlots(wire, static_cast<uint32_t>(sent.slots.size()));
  ASSERT_TRUE(slots.isOk()) << slots.status().toString();
  EXPECT_EQ(*slots, sent.slots);

  Mesh plain = mesh;
  plain.corner_uvs.clear();
  auto bytes = encodeDraco(plain);
  ASSERT_TRUE(bytes.isOk());
  auto received = decodeDraco(bytes->data(), bytes->size());
  ASSERT_TRUE(received.isOk());
  ASSERT_TRUE(received->corner_uvs.empty());
  AtlasLayout layout = sent;
  layout.slots = *slots;
  auto cells = applyAtlasLayout(*received, layout);
  ASSERT_TRUE(cells.isOk()) << cells.status().toString();
  ASSERT_EQ(received->corner_uvs.size(), received->indices.size());
  // Per triangle (named by its keys) and vertex key: the sender's UV.
  std::map<std::pair<std::set<uint64_t>, uint64_t>, glm::vec2> sender;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    std::set<uint64_t> keys;
    for (int k = 0; k < 3; ++k) keys.insert(mesh.vertex_keys[mesh.indices[3 * t + k]]);
    for (int k = 0; k < 3; ++k)
      sender[{keys, mesh.vertex_keys[mesh.indices[3 * t + k]]}] = mesh.corner_uvs[3 * t + k];
  }
  size_t matched = 0;
  for (size_t t = 0; t < received->triangleCount(); ++t) {
    std::set<uint64_t> keys;
    for (int k = 0; k < 3; ++k) keys.insert(received->vertex_keys[received->indices[3 * t + k]]);
    for (int k = 0; k < 3; ++k) {
      const auto found = sender.find({keys, received->vertex_keys[received->indices[3 * t + k]]});
      ASSERT_NE(found, sender.end()) << "triangle " << t;
      EXPECT_EQ(found->second, received->corner_uvs[3 * t + k]) << "triangle " << t;
      ++matched;
    }
  }
  EXPECT_EQ(matched, mesh.indices.size());

  // What does not fit is refused by name, the mesh's coordinates untouched.
  auto refusedWith = [&](AtlasLayout bad, const std::string& words) {
    Mesh copy = *received;
    copy.corner_uvs.clear();
    auto result = applyAtlasLayout(copy, bad);
    EXPECT_FALSE(result.isOk()) << words;
    if (!result.isOk()) {
      EXPECT_NE(result.status().toString().find(words), std::string::npos)
          << result.status().toString();
    }
    EXPECT_TRUE(copy.corner_uvs.empty());
  };
  AtlasLayout fewer = layout;
  fewer.slots.pop_back();
  refusedWith(fewer, "squares, the layout has");
  AtlasLayout outside = layout;
  outside.slots[0] = layout.squares_per_side * layout.squares_per_side;
  refusedWith(outside, "outside a grid");
  AtlasLayout other_lattice = layout;
  other_lattice.lattice = glm::u64vec3(kGrid / 2);
  refusedWith(other_lattice, "not on the layout's lattice");
  AtlasLayout too_big = layout;
  too_big.square_texels = layout.texels;
  refusedWith(too_big, "do not fit");
  // Bytes that do not hold the stated count.
  EXPECT_FALSE(decodeAtlasSlots(wire, static_cast<uint32_t>(sent.slots.size() + 1)).isOk());
  std::vector<uint8_t> cut(wire.begin(), wire.begin() + static_cast<long>(wire.size() / 2));
  EXPECT_FALSE(decodeAtlasSlots(cut, static_cast<uint32_t>(sent.slots.size())).isOk());
  EXPECT_EQ(decodeAtlasSlots(wire, 0xffffffffu).status().code(), StatusCode::kTooLarge);
}

// Charts: a square per block of lattice cells and facing axis, the
// triangles projected onto it at a fixed density, so the atlas's size
// follows the surface's area, not its triangle count. Laid out on the
// mesh as the receiver decodes it, the receiver's coordinates are the
// sender's exactly; every corner lies inside its square's gutter.
TEST(AtlasLayout, ChartsFollowTheSurfaceAndTravelAsTheirLayout) {
  Mesh mesh = sphereOnLattice(glm::dvec3(0.0), 0.7);
  auto bytes = encodeDraco(mesh);
  ASSERT_TRUE(bytes.isOk());
  Mesh sent = decodeDraco(bytes->data(), bytes->size()).value();
  Mesh received = sent;
  TextureAtlas charts(chartOptions()), squares(latticeOptions());
  AtlasStats chart_stats, square_stats;
  ASSERT_TRUE(charts.layOut(sent, &chart_stats).isOk());
  Mesh by_squares = mesh;
  ASSERT_TRUE(squares.layOut(by_squares, &square_stats).isOk());
  EXPECT_LT(chart_stats.squares_used * 4, square_stats.squares_used)
      << "a chart holds many triangles";
  const uint32_t chart_texels = 4 * 3 + 2 * kChartGutterTexels;
  EXPECT_EQ(chart_stats.square_texels, chart_texels);
  EXPECT_EQ(chart_stats.texels, chart_stats.squares_per_side * chart_texels);
  const AtlasLayout& layout = charts.layout();
  EXPECT_EQ(layout.chart_cells, 4u);
  EXPECT_DOUBLE_EQ(layout.texel_metres, kSpacing / 3.0);
  ASSERT_TRUE(applyAtlasLayout(received, layout).isOk());
  EXPECT_EQ(received.corner_uvs, sent.corner_uvs) << "the same decoded mesh, the same coordinates";
  for (size_t t = 0; t < sent.triangleCount(); ++t) {
    // All three corners in one square, inside its gutter.
    const glm::dvec2 a = glm::dvec2(sent.corner_uvs[3 * t]) * double(layout.texels);
    const glm::uvec2 square(glm::floor(a / double(chart_texels)));
    for (int k = 0; k < 3; ++k) {
      const glm::dvec2 at = glm::dvec2(sent.corner_uvs[3 * t + k]) * double(layout.texels);
      const glm::dvec2 local = at - glm::dvec2(square) * double(chart_texels);
      EXPECT_GE(local.x, kChartGutterTexels - 1e-4) << "triangle " << t;
      EXPECT_GE(local.y, kChartGutterTexels - 1e-4) << "triangle " << t;
      EXPECT_LE(local.x, chart_texels - kChartGutterTexels + 1e-4) << "triangle " << t;
      EXPECT_LE(local.y, chart_texels - kChartGutterTexels + 1e-4) << "triangle " << t;
    }
  }
  // A layout whose charts make no sense is refused by name.
  AtlasLayout bad = layout;
  bad.texel_metres = 0;
  auto refused = applyAtlasLayout(received, bad);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().toString().find("charts of 4 cells"), std::string::npos);
  AtlasOptions no_size = chartOptions();
  no_size.cell_size = 0;
  Mesh copy = mesh;
  EXPECT_FALSE(TextureAtlas(no_size).layOut(copy).isOk());
}

// Charts are anchored to the lattice (what inter-frame video coding of the
// layers needs): as the surface moves, a point that stays in its chart
// stays on its texels. A vertex on a lattice edge along its chart's axis
// projects onto the same texel in every frame; only charts the surface
// enters or leaves move.
TEST(TextureAtlas, ChartsHoldStillWhereTheSurfaceStaysInThem) {
  TextureAtlas atlas(chartOptions());
  std::map<std::pair<uint64_t, uint64_t>, glm::vec2> last;  // (triangle's keys, corner key) -> uv
  double moved = 0;
  const int frames = 6;
  for (int f = 0; f <= frames; ++f) {
    // A fifth of a voxel a frame, and breathing.
    Mesh mesh = sphereOnLattice(glm::dvec3(0.01 * f, 0.003 * f, 0.0), 0.7 + 0.004 * f);
    AtlasStats stats;
    const auto cells = atlas.layOut(mesh, &stats);
    ASSERT_TRUE(cells.isOk());
    std::map<std::pair<uint64_t, uint64_t>, glm::vec2> now;
    size_t same = 0, compared = 0;
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
      const uint64_t axis = (*cells)[t].chart_axis / 2;
      std::array<uint64_t, 3> keys{};
      for (int k = 0; k < 3; ++k) keys[k] = mesh.vertex_keys[mesh.indices[3 * t + k]];
      const uint64_t triangle = keys[0] ^ (keys[1] * 0x9e3779b97f4a7c15ull) ^ (keys[2] << 17);
      for (int k = 0; k < 3; ++k) {
        if (keys[k] % 3 != axis) continue;  // fractional across the chart
        const auto key = std::make_pair(triangle, keys[k]);
        now[key] = mesh.corner_uvs[3 * t + k];
        const auto before = last.find(key);
        if (before == last.end()) continue;
        ++compared;
        same += glm::length(glm::dvec2(before->second - now[key]) * double(stats.texels)) < 1e-3;
      }
    }
    if (f > 0) {
      ASSERT_FALSE(stats.regridded) << "frame " << f;
      EXPECT_GT(compared, 100u) << "frame " << f;
      EXPECT_EQ(same, compared) << "frame " << f << ": corners on an edge along their chart's "
                                << "axis stay on their texels";
      EXPECT_EQ(stats.squares_moved, stats.squares_used - stats.squares_kept)
          << "frame " << f << ": no kept chart shifts";
      moved += stats.movedFraction() / frames;
    }
    last = std::move(now);
  }
  EXPECT_LT(moved, 0.2);
}

// A chart faces the way the surface around its triangles faces (their
// cell and its face neighbours), not each triangle's own tilt, so a patch
// of faceted surface stays in one chart from frame to frame; and the
// choice is the same in whatever order the triangles arrive (a receiver's
// decoder may reorder them).
TEST(TextureAtlas, AChartFacesTheSurfaceAroundItsTrianglesInAnyOrder) {
  Mesh mesh = sphereOnLattice(glm::dvec3(0.013, -0.02, 0.007), 0.7);
  const auto cells = TextureAtlas(chartOptions()).layOut(mesh);
  ASSERT_TRUE(cells.isOk()) << cells.status().toString();
  const auto corner_keys = [](const Mesh& m, size_t t) {
    std::array<uint64_t, 3> keys{};
    for (int k = 0; k < 3; ++k) keys[k] = m.vertex_keys[m.indices[3 * t + k]];
    std::sort(keys.begin(), keys.end());
    return keys;
  };
  std::map<uint64_t, uint8_t> axis_of_cell;
  std::map<std::array<uint64_t, 3>, uint8_t> axis_of_triangle;
  size_t own_axis_differs = 0;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint8_t code = (*cells)[t].chart_axis;
    // The cell: the lowest lattice point of the triangle's edges, per axis.
    glm::u64vec3 corner(UINT64_MAX);
    for (const uint64_t key : corner_keys(mesh, t)) {
      const uint64_t point = key / 3;
      corner = glm::min(
          corner, glm::u64vec3(point % kGrid, (point / kGrid) % kGrid, point / (kGrid * kGrid)));
    }
    const uint64_t cell = (corner.z * kGrid + corner.y) * kGrid + corner.x;
    EXPECT_EQ(axis_of_cell.try_emplace(cell, code).first->second, code)
        << "triangle " << t << ": its cell's triangles share one chart";
    axis_of_triangle[corner_keys(mesh, t)] = code;
    const glm::dvec3 a(mesh.positions[mesh.indices[3 * t]]),
        b(mesh.positions[mesh.indices[3 * t + 1]]), c(mesh.positions[mesh.indices[3 * t + 2]]);
    const glm::dvec3 own = glm::cross(b - a, c - a);
    const int axis = code / 2;
    EXPECT_GT((code % 2 ? -1.0 : 1.0) * own[axis], 0.0)
        << "triangle " << t << " faces away from its chart";
    const glm::dvec3 size = glm::abs(own);
    own_axis_differs += size[axis] < std::max({size.x, size.y, size.z});
  }
  EXPECT_GT(own_axis_differs, 0u) << "some triangles tilt past 45 degrees from their surface";

  // The same mesh, triangles in reverse order, each starting at its second corner.
  Mesh reordered = mesh;
  const size_t n = mesh.triangleCount();
  for (size_t t = 0; t < n; ++t) {
    for (int k = 0; k < 3; ++k)
      reordered.indices[3 * t + k] = mesh.indices[3 * (n - 1 - t) + (k + 1) % 3];
  }
  const auto again = TextureAtlas(chartOptions()).layOut(reordered);
  ASSERT_TRUE(again.isOk());
  for (size_t t = 0; t < n; ++t) {
    EXPECT_EQ((*again)[t].chart_axis, axis_of_triangle.at(corner_keys(reordered, t)))
        << "triangle " << t << " of the reordered mesh";
  }
}

// A sphere painted by the direction from its centre, seen by a ring of
// cameras: each camera's image is ray traced, so a texel's colour can be
// checked against the paint at its point of the surface.
struct PaintedSphere {
  glm::dvec3 centre{0.0, 0.0, 0.0};
  double radius = 0.7;
  std::vector<Camera> cameras;
  std::vector<Image8> colors, masks;

  static glm::dvec3 paint(const glm::dvec3& direction) { return 127.5 * (direction + 1.0); }

  explicit PaintedSphere(int count) {
    cameras = ringCameras(count, 3.0, 0.6, centre, 96, 96, 50);
    for (const Camera& camera : cameras) {
      Image8 color(camera.width, camera.height, 3), mask(camera.width, camera.height, 1);
      for (uint32_t y = 0; y < camera.height; ++y) {
        for (uint32_t x = 0; x < camera.width; ++x) {
          const glm::dvec3 o = camera.center(), d = camera.rayDirection(x + 0.5, y + 0.5);
          const double b = glm::dot(d, o - centre);
          const double disc = b * b - (glm::dot(o - centre, o - centre) - radius * radius);
          if (disc < 0) continue;
          const glm::dvec3 hit = o + (-b - std::sqrt(disc)) * d;
          const glm::dvec3 c = paint(glm::normalize(hit - centre));
          for (int k = 0; k < 3; ++k) color.at(x, y)[k] = static_cast<uint8_t>(std::lround(c[k]));
          mask.at(x, y)[0] = 255;
        }
      }
      colors.push_back(std::move(color));
      masks.push_back(std::move(mask));
    }
  }
  std::vector<LayerView> views() const {
    std::vector<LayerView> out;
    for (size_t i = 0; i < cameras.size(); ++i) out.push_back({&cameras[i], &colors[i], &masks[i]});
    return out;
  }
};

// The painted sphere's hull laid out in an atlas.
struct LaidOut {
  Mesh mesh;
  TextureAtlas atlas;
  std::optional<std::vector<AtlasCell>> cells;
  explicit LaidOut(const PaintedSphere& scene, const AtlasOptions& options = latticeOptions())
      : mesh(sphereOnLattice(scene.centre, scene.radius)), atlas(options) {
    auto laid = atlas.layOut(mesh);
    EXPECT_TRUE(laid.isOk()) << laid.status().toString();
    if (laid.isOk()) cells = std::move(*laid);
  }
};

// Volino and Hilton 2016 section 3.1: layer l holds the l-th most direct
// camera that sees the point, its colour and its id; fewer cameras than
// layers leave the deeper layers empty; what no camera sees is the hole
// colour.
// Both layouts: a square per pair of triangles, and charts.
class TextureLayers : public ::testing::TestWithParam<bool> {};

TEST_P(TextureLayers, EachLayerHoldsTheNextMostDirectCameraThatSeesThePoint) {
  const PaintedSphere scene(4);
  LaidOut laid(scene, GetParam() ? chartOptions() : latticeOptions());
  const Mesh& mesh = laid.mesh;
  const TextureAtlas& atlas = laid.atlas;
  const auto& cells = laid.cells;
  ASSERT_TRUE(cells.has_value());
  LayerOptions options;
  options.layers = 6;           // more than the 4 cameras
  options.min_score_share = 0;  // the paper's L best
  options.keep_share = 1;       // by rank alone
  auto built = buildTextureLayers(mesh, atlas.texels(), scene.views(), options);
  ASSERT_TRUE(built.isOk()) << built.status().toString();
  ASSERT_EQ(built->layers.size(), 6u);
  EXPECT_GT(built->texels_seen, built->texels_covered / 2);
  EXPECT_LT(built->texels_seen, built->texels_covered) << "the poles face no camera";
  uint64_t checked = 0, holes = 0;
  double error = 0;
  size_t inside = 0;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    // The texel under the triangle's centroid in the atlas, when its centre
    // lies inside the triangle's footprint: it holds a point of triangle t,
    // at the centre's barycentrics.
    std::array<glm::dvec2, 3> uv;
    for (int k = 0; k < 3; ++k)
      uv[k] = glm::dvec2(mesh.corner_uvs[3 * t + k]) * double(atlas.texels());
    const glm::dvec2 at = (uv[0] + uv[1] + uv[2]) / 3.0;
    const uint32_t x = static_cast<uint32_t>(at.x), y = static_cast<uint32_t>(at.y);
    const glm::dvec2 e0 = uv[1] - uv[0], e1 = uv[2] - uv[0],
                     d = glm::dvec2(x + 0.5, y + 0.5) - uv[0];
    const double det = e0.x * e1.y - e1.x * e0.y;
    const double b1 = (d.x * e1.y - e1.x * d.y) / det, b2 = (e0.x * d.y - d.x * e0.y) / det;
    const glm::dvec3 b(1 - b1 - b2, b1, b2);
    if (!(b.x >= 0 && b.y >= 0 && b.z >= 0)) continue;
    ++inside;
    glm::dvec3 point(0.0), normal(0.0);
    for (int k = 0; k < 3; ++k) {
      point += b[k] * glm::dvec3(mesh.positions[mesh.indices[3 * t + k]]);
      normal += b[k] * glm::dvec3(mesh.normals[mesh.indices[3 * t + k]]);
    }
    normal = glm::normalize(normal);
    double previous = 2.0;
    std::set<uint8_t> cameras;
    for (int l = 0; l < 6; ++l) {
      const uint8_t* texel = built->layers[l].at(x, y);
      if (texel[3] == kNoLayerCamera) {
        if (l == 0) {
          ++holes;
          EXPECT_EQ(texel[0], 128);
        }
        // Once a layer is empty, every deeper one is.
        for (int deeper = l; deeper < 6; ++deeper)
          EXPECT_EQ(built->layers[deeper].at(x, y)[3], kNoLayerCamera);
        break;
      }
      ASSERT_LT(texel[3], 4);
      EXPECT_TRUE(cameras.insert(texel[3]).second) << "a camera twice in one texel's layers";
      const Camera& camera = scene.cameras[texel[3]];
      const double facing = glm::dot(normal, glm::normalize(camera.center() - point));
      EXPECT_GT(facing, 0.0);
      EXPECT_LE(facing, previous + 0.02) << "layer " << l << " more direct than the one before";
      previous = facing;
      if (l == 0) {
        const glm::dvec3 want = PaintedSphere::paint(glm::normalize(point - scene.centre));
        error += glm::length(glm::dvec3(texel[0], texel[1], texel[2]) - want) / std::sqrt(3.0);
        ++checked;
      }
    }
    EXPECT_EQ(built->layers[4].at(x, y)[3], kNoLayerCamera) << "a fifth camera of four";
  }
  ASSERT_GT(inside, mesh.triangleCount() / 4);
  ASSERT_GT(checked, inside / 2);
  EXPECT_GT(holes, 0u);
  // The hull is the sphere within a fraction of a voxel: the best camera's
  // colour is the paint at the point within a few levels.
  EXPECT_LT(error / checked, 6.0);
  // Charts fold little of a sphere onto itself.
  EXPECT_LT(built->texels_contested, built->texels_covered / 100);

  // With a share, a deeper layer keeps a point only where its camera faces
  // it at least that share as squarely as the first layer's (no feather
  // maps here, so the score is the cosine); the first layers are the same.
  options.min_score_share = 0.5;
  auto shared = buildTextureLayers(mesh, atlas.texels(), scene.views(), options);
  ASSERT_TRUE(shared.isOk());
  EXPECT_EQ(shared->layers[0].pixels, built->layers[0].pixels);
  uint64_t dropped = 0, kept = 0;
  for (uint32_t y = 0; y < atlas.texels(); ++y) {
    for (uint32_t x = 0; x < atlas.texels(); ++x) {
      for (int l = 1; l < 6; ++l) {
        const uint8_t all = built->layers[l].at(x, y)[3], some = shared->layers[l].at(x, y)[3];
        if (all == kNoLayerCamera) {
          EXPECT_EQ(some, kNoLayerCamera);
          continue;
        }
        if (some == kNoLayerCamera) {
          ++dropped;
          continue;
        }
        ++kept;
        EXPECT_EQ(some, all) << "texel " << x << "," << y << " layer " << l;
      }
    }
  }
  EXPECT_GT(dropped, 0u) << "oblique cameras leave deeper layers";
  EXPECT_GT(kept, 0u) << "cameras nearly as square as the best stay";
}

// With a keep share, a layer takes the camera of the texel to its left, or
// else above it, where that camera also sees the point nearly as well:
// fewer changes of camera along the rows and down the columns, each change
// of the ranking kept only from one of those two neighbours and only to a
// camera the ranking had for that point, the colours still the paint's.
TEST_P(TextureLayers, ALayerKeepsItsNeighboursCameraWhereItSeesThePointNearlyAsWell) {
  const PaintedSphere scene(4);
  LaidOut laid(scene, GetParam() ? chartOptions() : latticeOptions());
  ASSERT_TRUE(laid.cells.has_value());
  const uint32_t texels = laid.atlas.texels();
  LayerOptions options;
  options.layers = 4;
  options.min_score_share = 0;
  options.keep_share = 1;
  auto ranked = buildTextureLayers(laid.mesh, texels, scene.views(), options);
  options.keep_share = 0.5;
  auto kept = buildTextureLayers(laid.mesh, texels, scene.views(), options);
  ASSERT_TRUE(ranked.isOk() && kept.isOk());
  // Camera changes between neighbours dx, dy apart.
  auto changes = [&](const Image8& layer, uint32_t dx, uint32_t dy) {
    size_t n = 0;
    for (uint32_t y = dy; y < texels; ++y)
      for (uint32_t x = dx; x < texels; ++x) {
        const uint8_t a = layer.at(x - dx, y - dy)[3], b = layer.at(x, y)[3];
        n += a != kNoLayerCamera && b != kNoLayerCamera && a != b;
      }
    return n;
  };
  // In charts neighbouring texels are one surface: a quarter fewer changes
  // each way. In squares a square's neighbours are unrelated triangles,
  // where fewer changes come only inside each square: a tenth fewer.
  const bool charts = GetParam();
  size_t kept_changes = 0, ranked_changes = 0;
  for (const auto& [dx, dy] : {std::pair<uint32_t, uint32_t>{1, 0}, {0, 1}}) {
    const size_t k = changes(kept->layers[0], dx, dy), r = changes(ranked->layers[0], dx, dy);
    if (charts) {
      EXPECT_LT(k * 4, r * 3) << k << " against " << r << (dx ? " along rows" : " down columns");
    }
    kept_changes += k;
    ranked_changes += r;
  }
  EXPECT_LT(kept_changes * 10, ranked_changes * 9) << kept_changes << " against " << ranked_changes;
  size_t differ = 0;
  for (uint32_t y = 0; y < texels; ++y) {
    for (uint32_t x = 0; x < texels; ++x) {
      const uint8_t want = ranked->layers[0].at(x, y)[3], got = kept->layers[0].at(x, y)[3];
      ASSERT_EQ(got == kNoLayerCamera, want == kNoLayerCamera) << x << "," << y;
      if (got == want) continue;
      ++differ;
      const bool from_left = x > 0 && got == kept->layers[0].at(x - 1, y)[3];
      const bool from_above = y > 0 && got == kept->layers[0].at(x, y - 1)[3];
      EXPECT_TRUE(from_left || from_above) << "kept from a neighbour, " << x << "," << y;
      bool sees = false;
      for (int l = 1; l < 4; ++l) sees = sees || ranked->layers[l].at(x, y)[3] == got;
      EXPECT_TRUE(sees) << "a camera that sees the point, " << x << "," << y;
      // The paint is the same from every camera: the colour differs by
      // little more than the sampling.
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(kept->layers[0].at(x, y)[c], ranked->layers[0].at(x, y)[c], 40)
            << x << "," << y;
    }
  }
  EXPECT_GT(differ, 0u);
}

// The texels' sources, their cameras and colours, and the fill of the
// texels no camera covers, are the same bytes on one thread and on
// several: the bands of rows meet each triangle in mesh order, the cameras
// are chosen row after row, and the fill reads each level in fixed order.
TEST_P(TextureLayers, OneThreadAndSeveralBuildTheSameBytes) {
  const PaintedSphere scene(4);
  LaidOut laid(scene, GetParam() ? chartOptions() : latticeOptions());
  ASSERT_TRUE(laid.cells.has_value());
  LayerOptions options;
  options.layers = 3;
  auto buildOn = [&](int threads) {
    tbb::task_arena arena(threads);
    return arena.execute(
        [&] { return buildTextureLayers(laid.mesh, laid.atlas.texels(), scene.views(), options); });
  };
  const int cores = std::max(2, tbb::this_task_arena::max_concurrency());
  const auto one = buildOn(1), several = buildOn(cores);
  ASSERT_TRUE(one.isOk() && several.isOk());
  EXPECT_GT(one->texels_seen, 0u);
  EXPECT_EQ(one->texels_covered, several->texels_covered);
  EXPECT_EQ(one->texels_seen, several->texels_seen);
  EXPECT_EQ(one->texels_contested, several->texels_contested);
  ASSERT_EQ(one->layers.size(), several->layers.size());
  // And the video's fill of the texels no camera covers.
  auto filledOn = [](int threads, const Image8& layer) {
    Image8 colour(layer.width, layer.height, 3), camera(layer.width, layer.height, 1);
    for (size_t i = 0; i < size_t{layer.width} * layer.height; ++i) {
      for (int c = 0; c < 3; ++c) colour.pixels[3 * i + c] = layer.pixels[4 * i + c];
      camera.pixels[i] = layer.pixels[4 * i + 3];
    }
    tbb::task_arena(threads).execute([&] { fillUncoveredTexels(colour, camera); });
    return colour;
  };
  for (size_t l = 0; l < one->layers.size(); ++l) {
    EXPECT_TRUE(one->layers[l].pixels == several->layers[l].pixels) << "layer " << l;
    const Image8 filled = filledOn(1, one->layers[l]);
    EXPECT_TRUE(filled.pixels == filledOn(cores, one->layers[l]).pixels) << "filled layer " << l;
    if (l > 0) continue;
    size_t changed = 0;  // the fill wrote the holes
    for (size_t i = 0; i < filled.pixels.size(); ++i)
      changed += filled.pixels[i] != one->layers[l].pixels[i / 3 * 4 + i % 3];
    EXPECT_GT(changed, 0u);
  }
}

// A renderer reads a layer at its nearest texel and the four taps of a
// bilinear sample: for any point of any triangle every one that weighs
// anything is covered.
// The texels no triangle reaches may so take any camera byte: continued
// from above, they leave every covered texel as it was and code in fewer
// bytes.
TEST_P(TextureLayers, EveryTapOfTheSurfaceIsCoveredAndOnlyGuttersTakeTheCameraAbove) {
  const PaintedSphere scene(4);
  LaidOut laid(scene, GetParam() ? chartOptions() : latticeOptions());
  ASSERT_TRUE(laid.cells.has_value());
  LayerOptions options;
  options.layers = 2;
  auto built = buildTextureLayers(laid.mesh, laid.atlas.texels(), scene.views(), options);
  ASSERT_TRUE(built.isOk()) << built.status().toString();
  const int texels = static_cast<int>(built->texels);
  ASSERT_EQ(built->covered.size(), size_t(texels) * texels);
  EXPECT_EQ(static_cast<uint64_t>(std::count(built->covered.begin(), built->covered.end(), 1)),
            built->texels_covered);
  auto covered = [&](int x, int y) {
    x = std::clamp(x, 0, texels - 1);
    y = std::clamp(y, 0, texels - 1);
    return built->covered[size_t(y) * texels + x] != 0;
  };
  const Mesh& mesh = laid.mesh;
  size_t taps = 0;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    for (int i = 0; i <= 4; ++i) {
      for (int j = 0; i + j <= 4; ++j) {
        const float a = i / 4.0f, b = j / 4.0f;
        const glm::vec2 uv = (1 - a - b) * mesh.corner_uvs[3 * t] + a * mesh.corner_uvs[3 * t + 1] +
                             b * mesh.corner_uvs[3 * t + 2];
        const glm::vec2 at = uv * float(texels) - 0.5f;
        const glm::ivec2 base(std::floor(at.x), std::floor(at.y));
        ASSERT_TRUE(covered(int(std::floor(uv.x * texels)), int(std::floor(uv.y * texels))))
            << "triangle " << t;
        for (int k = 0; k < 4; ++k) {
          // A tap of weight 0 (the sample on a texel's centre) adds nothing.
          const glm::vec2 f = at - glm::vec2(base);
          if ((k & 1 ? f.x : 1 - f.x) * (k >> 1 ? f.y : 1 - f.y) == 0) continue;
          ASSERT_TRUE(covered(base.x + (k & 1), base.y + (k >> 1))) << "triangle " << t;
          ++taps;
        }
      }
    }
  }
  EXPECT_GT(taps, 1000u);
  for (const Image8& layer : built->layers) {
    Image8 camera(layer.width, layer.height, 1);
    for (size_t i = 0; i < camera.pixels.size(); ++i) camera.pixels[i] = layer.pixels[4 * i + 3];
    Image8 continued = camera;
    continueCamerasAcrossGutters(continued, built->covered);
    size_t gutters = 0;
    for (size_t i = 0; i < camera.pixels.size(); ++i) {
      if (built->covered[i]) {
        ASSERT_EQ(continued.pixels[i], camera.pixels[i]) << "covered texel " << i;
      } else if (i >= camera.width) {
        ASSERT_EQ(continued.pixels[i], continued.pixels[i - camera.width]) << "gutter texel " << i;
        ++gutters;
      }
    }
    EXPECT_GT(gutters, 0u);
    std::vector<uint8_t> before, after;
    encodePlane(camera, protocol::PlaneKind::kCamera, protocol::Codec::kZstd, before);
    encodePlane(continued, protocol::PlaneKind::kCamera, protocol::Codec::kZstd, after);
    EXPECT_LT(after.size(), before.size());
  }
}

INSTANTIATE_TEST_SUITE_P(Layouts, TextureLayers, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "Charts" : "Squares"; });

TEST(TextureLayersInputs, InputsThatDisagreeAreRefusedByName) {
  const PaintedSphere scene(2);
  LaidOut laid(scene);
  ASSERT_TRUE(laid.cells.has_value());
  auto views = scene.views();
  const Image8 small(10, 10, 3);
  views[1].color = &small;
  auto refused = buildTextureLayers(laid.mesh, laid.atlas.texels(), views);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().toString().find("view 1"), std::string::npos);
  Mesh bare = laid.mesh;
  bare.corner_uvs.pop_back();
  refused = buildTextureLayers(bare, laid.atlas.texels(), scene.views());
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().toString().find("texture coordinates"), std::string::npos);
  // An empty mesh: layers of holes, no error.
  Mesh empty;
  auto none = buildTextureLayers(empty, 64, scene.views());
  ASSERT_TRUE(none.isOk());
  EXPECT_EQ(none->texels_covered, 0u);
}

// The layers' video fills the texels no camera covers from the colours
// around them, leaving the covered ones as they are.
TEST(FillUncoveredTexels, EmptyTexelsTakeTheColourNearestThemAndCoveredOnesKeepTheirs) {
  const glm::u8vec3 red(200, 30, 30), blue(20, 40, 220), hole(128, 128, 128);
  Image8 colour(64, 64, 3), camera(64, 64, 1, kNoLayerCamera);
  for (uint32_t y = 0; y < 64; ++y) {
    for (uint32_t x = 0; x < 64; ++x) {
      const bool left = x < 16, right = x >= 48;
      const glm::u8vec3 c = left ? red : right ? blue : hole;
      for (int k = 0; k < 3; ++k) colour.at(x, y)[k] = c[k];
      if (left || right) camera.at(x, y)[0] = left ? 0 : 1;
    }
  }
  const Image8 before = colour;
  fillUncoveredTexels(colour, camera);
  for (uint32_t y = 0; y < 64; ++y) {
    for (uint32_t x = 0; x < 64; ++x) {
      const glm::u8vec3 got(colour.at(x, y)[0], colour.at(x, y)[1], colour.at(x, y)[2]);
      if (camera.at(x, y)[0] != kNoLayerCamera) {
        ASSERT_EQ(got, glm::u8vec3(before.at(x, y)[0], before.at(x, y)[1], before.at(x, y)[2]))
            << "covered texel " << x << "," << y;
        continue;
      }
      // The hole colour is gone; the nearer side's colour is nearer.
      const glm::dvec3 g(got);
      const double to_red = glm::length(g - glm::dvec3(red)),
                   to_blue = glm::length(g - glm::dvec3(blue));
      ASSERT_NE(got, hole) << x << "," << y;
      if (x < 30) {
        EXPECT_LT(to_red, to_blue) << x << "," << y;
      }
      if (x > 33) {
        EXPECT_LT(to_blue, to_red) << x << "," << y;
      }
    }
  }
  // Next to a side, its colour exactly.
  EXPECT_EQ(colour.at(16, 5)[0], red.x);
  EXPECT_EQ(colour.at(47, 60)[2], blue.z);
  // Nothing covered: nothing to spread, the layer stays as it was.
  Image8 empty(8, 8, 3, 77);
  fillUncoveredTexels(empty, Image8(8, 8, 1, kNoLayerCamera));
  EXPECT_EQ(empty.pixels, Image8(8, 8, 3, 77).pixels);
}

}  // namespace
}  // namespace holofuse
