// Carrying the temporal field across meshes, and its behaviour in time
// (paper 000 eq. 5): a viewpoint jump fades in, never snaps.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <numeric>
#include <random>

#include "geometry/marching_cubes.h"
#include "render_client/reference/texture_fields.h"
#include "render_client/temporal_carry.h"

namespace holofuse::render {
namespace {

Mesh blob(double radius, glm::dvec3 centre) {
  return marchingCubes(sampleGrid(glm::dvec3(-1.0), 0.05, 41, 41, 41, [&](const glm::dvec3& p) {
    return radius - glm::length(p - centre);
  }));
}

TEST(TemporalCarry, SameKeysFollowTheVertexWhateverTheOrder) {
  const Mesh a = blob(0.5, glm::dvec3(0.0));
  // The same surface with its vertices shuffled (as Draco reorders them).
  std::vector<uint32_t> order(a.vertexCount());
  std::iota(order.begin(), order.end(), 0u);
  std::shuffle(order.begin(), order.end(), std::mt19937(7));
  Mesh b;
  for (uint32_t v : order) {
    b.positions.push_back(a.positions[v]);
    b.vertex_keys.push_back(a.vertex_keys[v]);
  }
  const CarryMap map = carryAcross(a, b, 0.1);
  EXPECT_EQ(map.by_key, b.vertexCount());
  for (size_t v = 0; v < b.vertexCount(); ++v)
    EXPECT_EQ(map.previous[v], static_cast<int32_t>(order[v]));
}

TEST(TemporalCarry, MovedSurfaceFallsBackToTheNearestVertexAndNewSurfaceStartsFresh) {
  const Mesh a = blob(0.4, glm::dvec3(0.0));
  Mesh b = blob(0.4, glm::dvec3(0.012, 0.0, 0.0));  // moved by a quarter voxel: other edges
  b.vertex_keys.clear();                            // as if the extractor gave no identity
  const CarryMap map = carryAcross(a, b, 0.1);
  EXPECT_EQ(map.by_nearest, b.vertexCount());
  for (size_t v = 0; v < b.vertexCount(); ++v) {
    ASSERT_GE(map.previous[v], 0);
    EXPECT_LT(glm::length(glm::dvec3(a.positions[map.previous[v]]) - glm::dvec3(b.positions[v])),
              0.05);
  }
  const Mesh far = blob(0.2, glm::dvec3(0.7, 0.0, 0.0));  // a surface where there was none
  const CarryMap fresh = carryAcross(a, far, 0.05);
  EXPECT_EQ(fresh.fresh, far.vertexCount());
  const std::vector<std::vector<double>> previous(1, std::vector<double>(a.vertexCount(), 0.25));
  const std::vector<std::vector<double>> target(1, std::vector<double>(far.vertexCount(), 0.75));
  const auto carried = carryField(previous, fresh, target);
  EXPECT_DOUBLE_EQ(carried[0][0], 0.75)
      << "new surface takes the target, it does not fade in from zero";
}

// The grid search finds what comparing every pair finds: the nearest
// previous vertex within the distance (ties to the lower index), also for
// points outside the previous surface's box, never a vertex with a NaN
// position.
TEST(TemporalCarry, NearestMatchesTheExhaustiveSearch) {
  std::mt19937 random(11);
  std::uniform_real_distribution<float> coordinate(-0.3f, 0.3f);
  Mesh previous, next;
  for (int v = 0; v < 800; ++v)
    previous.positions.emplace_back(coordinate(random), coordinate(random), coordinate(random));
  previous.positions[5] = glm::vec3(std::numeric_limits<float>::quiet_NaN());
  for (int v = 0; v < 400; ++v) {
    next.positions.emplace_back(1.3f * coordinate(random), 1.3f * coordinate(random),
                                1.3f * coordinate(random));
  }
  next.positions.push_back(previous.positions[7]);  // at distance 0
  const double max_distance = 0.04;
  const CarryMap map = carryAcross(previous, next, max_distance);
  size_t found = 0;
  for (size_t v = 0; v < next.vertexCount(); ++v) {
    int32_t best = -1;
    double best_d2 = max_distance * max_distance;
    for (size_t w = 0; w < previous.vertexCount(); ++w) {
      const glm::dvec3 d = glm::dvec3(previous.positions[w]) - glm::dvec3(next.positions[v]);
      const double d2 = glm::dot(d, d);
      if (d2 < best_d2) {
        best_d2 = d2;
        best = static_cast<int32_t>(w);
      }
    }
    EXPECT_EQ(map.previous[v], best) << "vertex " << v;
    found += best >= 0;
  }
  EXPECT_EQ(map.previous.back(), 7);
  EXPECT_GT(found, 50u);
  EXPECT_LT(found, next.vertexCount() - 50)
      << "some lie farther than the distance from every previous vertex";
  EXPECT_EQ(map.by_nearest, found);
}

// Occlusion is not smoothed: a camera that stops seeing a vertex leaves its
// field in the same frame (its carried weight would sample the occluder),
// and fades in from nothing when it sees the vertex again.
TEST(TemporalField, ACameraThatNoLongerSeesAVertexLeavesAtOnceAndFadesBackIn) {
  reference::Field temporal = {{0.6}, {0.4}};
  const reference::Field target = {{0.6}, {0.0}};
  const double lambda = reference::temporalLambda(0.05, 1.0 / 30.0);
  reference::temporalUpdate(temporal, target, lambda, {{1}, {0}});
  EXPECT_DOUBLE_EQ(temporal[1][0], 0.0) << "camera 1 is occluded now";
  EXPECT_NEAR(temporal[0][0], 0.6, 1e-12);
  const reference::Field back = {{0.6}, {0.4}};
  reference::temporalUpdate(temporal, back, lambda, {{1}, {1}});
  EXPECT_NEAR(temporal[1][0], 0.05 * 0.4, 1e-12) << "fades back in, no snap";
  // Without visibility every camera is smoothed (eq. 5 as written).
  reference::Field plain = {{0.6}, {0.4}};
  reference::temporalUpdate(plain, target, lambda);
  EXPECT_NEAR(plain[1][0], 0.95 * 0.4, 1e-12);
}

TEST(TemporalField, AViewpointJumpFadesInAtTheSameSpeedAtAnyFrameRate) {
  // After a jump the target switches from camera 0 to camera 1. With
  // lambda 0.05 at 30 fps the weight of camera 1 after one frame is 5%, and
  // after one second 1 - 0.95^30 = 78.5%, at 30 fps or 12 fps alike.
  for (double fps : {30.0, 12.0}) {
    reference::Field temporal = {{1.0}, {0.0}};
    const reference::Field target = {{0.0}, {1.0}};
    const double lambda = reference::temporalLambda(0.05, 1.0 / fps);
    reference::temporalUpdate(temporal, target, lambda);
    if (fps == 30.0) {
      EXPECT_NEAR(temporal[1][0], 0.05, 1e-12) << "first frame after the jump";
    }
    for (int k = 1; k < static_cast<int>(fps); ++k)
      reference::temporalUpdate(temporal, target, lambda);
    EXPECT_NEAR(temporal[1][0], 1 - std::pow(0.95, 30), 1e-9) << fps;
    EXPECT_LT(temporal[1][0], 0.9) << "no snap";
  }
}

}  // namespace
}  // namespace holofuse::render
