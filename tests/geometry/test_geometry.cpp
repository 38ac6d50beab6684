// The camera model, the mesh and marching cubes.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "geometry/camera.h"
#include "geometry/marching_cubes.h"

namespace holofuse {
namespace {

TEST(Camera, ProjectsWhatItsRaysHit) {
  const Camera cam = lookAtCamera(0, {2, 1, 3}, {0, 0.8, 0}, {0, 1, 0}, 320, 240, 50);
  EXPECT_NEAR(glm::length(cam.center() - glm::dvec3(2, 1, 3)), 0.0, 1e-12);
  const glm::dvec3 dir = cam.rayDirection(100.5, 40.25);
  const auto p = cam.project(cam.center() + 2.5 * dir);
  ASSERT_TRUE(p);
  EXPECT_NEAR(p->x, 100.5, 1e-9);
  EXPECT_NEAR(p->y, 40.25, 1e-9);
  // The target projects to the image centre; points behind do not project.
  const auto centre = cam.project({0, 0.8, 0});
  EXPECT_NEAR(centre->x, 160, 1e-9);
  EXPECT_NEAR(centre->y, 120, 1e-9);
  EXPECT_FALSE(cam.project(cam.center() - cam.forward()));
  // Image y grows downwards: a point above the target projects higher.
  EXPECT_LT(cam.project({0, 1.2, 0})->y, 120);
}

TEST(Camera, CalibrationRoundTripIsExact) {
  Camera cam = lookAtCamera(5, {1, 2, 3}, {0, 1, 0}, {0, 1, 0}, 640, 480, 60);
  cam.skew = 0.5;
  cam.distortion = {0.1, 0.01, 0, 0, 0};
  const Camera back = fromCalibration(toCalibration(cam));
  EXPECT_EQ(back.id, 5u);
  EXPECT_EQ(back.rotation, cam.rotation);
  EXPECT_EQ(back.translation, cam.translation);
  EXPECT_EQ(back.skew, 0.5);
  EXPECT_EQ(back.distortion, cam.distortion);
}

// Every edge of a closed, consistently oriented surface is used exactly
// twice, once in each direction.
void expectClosedAndOriented(const Mesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (size_t t = 0; t < mesh.indices.size(); t += 3) {
    for (int k = 0; k < 3; ++k) directed[{mesh.indices[t + k], mesh.indices[t + (k + 1) % 3]}]++;
  }
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1) << "edge used twice in one direction";
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u) << "boundary edge";
  }
}

TEST(MarchingCubes, DerivedCaseTableIsComplementaryAndSized) {
  const auto& table = marchingCubesCaseTable();
  EXPECT_TRUE(table[0].empty());
  EXPECT_TRUE(table[255].empty());
  EXPECT_EQ(table[1].size(), 3u);  // one corner cut off: one triangle
  EXPECT_EQ(table[3].size(), 6u);  // one edge cut off: a quad
  for (int c = 1; c < 255; ++c) EXPECT_FALSE(table[c].empty()) << c;
}

TEST(MarchingCubes, SphereIsClosedOrientedOutwardAndAccurate) {
  const double r = 0.4;
  const auto grid = sampleGrid({-0.5, -0.5, -0.5}, 0.05, 21, 21, 21,
                               [&](const glm::dvec3& p) { return r - glm::length(p); });
  const Mesh mesh = marchingCubes(grid);
  ASSERT_GT(mesh.triangleCount(), 100u);
  expectClosedAndOriented(mesh);
  double max_error = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    const glm::dvec3 p(mesh.positions[v]);
    max_error = std::max(max_error, std::abs(glm::length(p) - r));
    EXPECT_GT(glm::dot(glm::dvec3(mesh.normals[v]), glm::normalize(p)), 0.9);
  }
  EXPECT_LT(max_error, 0.01);  // linear placement on a 5 cm grid
  EXPECT_EQ(mesh.vertex_keys.size(), mesh.vertexCount());
}

TEST(MarchingCubes, AmbiguousCheckerFieldStillGivesAClosedSurface) {
  // A field whose sign alternates like a 3-D checkerboard exercises every
  // ambiguous face; the outer layer is outside so the result must close.
  const auto grid = sampleGrid({0, 0, 0}, 1.0, 8, 8, 8, [](const glm::dvec3& p) {
    if (p.x == 0 || p.y == 0 || p.z == 0 || p.x == 7 || p.y == 7 || p.z == 7) return -1.0;
    return ((static_cast<int>(p.x + p.y + p.z) & 1) ? 1.0 : -1.0) * (0.5 + 0.1 * p.x);
  });
  expectClosedAndOriented(marchingCubes(grid));
}

// Marching cubes as one scan of the whole grid, vertices numbered as the
// cubes first reach them: what the marcher's slabs, marched side by side
// and joined, must give vertex for vertex. Edge e runs along axis e / 4
// from the (e % 4)-th corner whose bit for that axis is 0 (the case
// table's numbering).
Mesh marchedInOneScan(const ScalarGrid& grid) {
  Mesh mesh;
  std::map<uint64_t, uint32_t> vertex_of_edge;
  for (int z = 0; z + 1 < grid.nz; ++z) {
    for (int y = 0; y + 1 < grid.ny; ++y) {
      for (int x = 0; x + 1 < grid.nx; ++x) {
        int config = 0;
        for (int c = 0; c < 8; ++c) {
          if (grid.at(x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1)) > 0.0f) config |= 1 << c;
        }
        for (int e : marchingCubesCaseTable()[config]) {
          const int axis = e / 4;
          int base = -1;
          for (int c = 0, k = 0; c < 8; ++c) {
            if (c & (1 << axis)) continue;
            if (k++ == e % 4) base = c;
          }
          const glm::ivec3 b(x + (base & 1), y + ((base >> 1) & 1), z + ((base >> 2) & 1));
          const uint64_t key =
              ((static_cast<uint64_t>(b.z) * grid.ny + b.y) * grid.nx + b.x) * 3 + axis;
          auto [it, inserted] =
              vertex_of_edge.try_emplace(key, static_cast<uint32_t>(mesh.positions.size()));
          if (inserted) {
            mesh.positions.emplace_back(grid.point(b.x, b.y, b.z));  // where is not compared
            mesh.vertex_keys.push_back(key);
          }
          mesh.indices.push_back(it->second);
        }
      }
    }
  }
  return mesh;
}

TEST(MarchingCubes, SlabsJoinedGiveTheWholeScansMeshVertexForVertex) {
  // A blob tall enough for many slabs, crossing every slab boundary, and
  // thin layers (3 and 5 planes) where the last slab is short.
  for (const int nz : {3, 5, 23, 40}) {
    // The tallest grid holds the whole blob (a closed surface); the others
    // cut it.
    const double z0 = nz == 40 ? -1.0 : -0.5;
    const auto grid = sampleGrid({-0.5, -0.5, z0}, 0.05, 21, 19, nz, [&](const glm::dvec3& p) {
      return 0.35 - glm::length(p * glm::dvec3(1.0, 1.3, 0.6)) + 0.05 * std::sin(9 * p.x);
    });
    const Mesh mesh = marchingCubes(grid);
    const Mesh scan = marchedInOneScan(grid);
    ASSERT_GT(scan.triangleCount(), 0u) << nz;
    EXPECT_EQ(mesh.vertex_keys, scan.vertex_keys) << nz << " planes";
    EXPECT_EQ(mesh.indices, scan.indices) << nz << " planes";
    if (nz == 40) expectClosedAndOriented(mesh);
  }
}

// One right triangle with legs 3 and 4 (edges 3, 4, 5) and one with legs 1
// and 1 (1, 1, sqrt 2): six edges in all.
TEST(Mesh, MeanEdgeLengthCountsEveryTrianglesEdges) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {3, 0, 0}, {0, 4, 0}, {10, 0, 0}, {11, 0, 0}, {10, 1, 0}};
  mesh.indices = {0, 1, 2, 3, 4, 5};
  EXPECT_NEAR(meanEdgeLength(mesh), (3 + 4 + 5 + 1 + 1 + std::sqrt(2.0)) / 6, 1e-6);
  EXPECT_EQ(meanEdgeLength(Mesh{}), 0.0);
}

}  // namespace
}  // namespace holofuse
