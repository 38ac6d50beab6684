// The approximate geodesic distance (triangle unfolding, bounded Jacobi
// passes) against distances known exactly: Euclidean on a plane,
// great-circle on a sphere; and against edge-graph relaxation.
#include <gtest/gtest.h>

#include <cmath>

#include "common/marching_cubes.h"
#include "render_client/reference/geodesics.h"

namespace holofuse::render::reference {
namespace {

// A flat regular grid of n x n vertices with spacing h, every square cut
// along the same diagonal.
Mesh plane(int n, double h) {
  Mesh mesh;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) mesh.positions.emplace_back(x * h, y * h, 0.0);
  }
  for (int y = 0; y + 1 < n; ++y) {
    for (int x = 0; x + 1 < n; ++x) {
      const uint32_t a = y * n + x, b = a + 1, c = a + n, d = c + 1;
      for (uint32_t i : {a, b, d, a, d, c}) mesh.indices.push_back(i);
    }
  }
  computeVertexNormals(mesh);
  return mesh;
}

struct Errors {
  double mean = 0, worst = 0;
  size_t count = 0;
};

// Relative error against exact distances for the vertices the field
// reaches (within k rings) with min_distance < exact <= radius.
Errors relativeErrors(const std::vector<double>& approx, const std::vector<double>& exact, double min_distance,
                      double radius) {
  Errors e;
  for (size_t v = 0; v < exact.size(); ++v) {
    if (!(exact[v] > min_distance && exact[v] <= radius) || !std::isfinite(approx[v])) continue;
    const double r = std::abs(approx[v] - exact[v]) / exact[v];
    e.mean += r;
    e.worst = std::max(e.worst, r);
    ++e.count;
  }
  if (e.count) e.mean /= static_cast<double>(e.count);
  return e;
}

TEST(Geodesics, UnfoldingIsExactForAStraightLineThroughATriangle) {
  // Source at (0, -1); a at (0,0), b at (1,0), c at (0.5, 1): the line from
  // the source to c crosses ab, so the distance is |c - s|.
  const double da = 1.0, db = std::sqrt(2.0);
  const double d = unfoldedDistance(1.0, std::hypot(0.5, 1.0), std::hypot(0.5, 1.0), da, db);
  EXPECT_NEAR(d, std::hypot(0.5, 2.0), 1e-12);
  // One side unknown: the way round through the known end.
  EXPECT_DOUBLE_EQ(unfoldedDistance(1.0, 2.0, 3.0, 0.5, INFINITY), 2.5);
  EXPECT_TRUE(std::isinf(unfoldedDistance(1.0, 2.0, 3.0, INFINITY, INFINITY)));
  // A degenerate (flat) triangle falls back to edges, never NaN.
  EXPECT_DOUBLE_EQ(unfoldedDistance(2.0, 1.0, 1.0, 1.0, 1.0), 2.0);
}

TEST(Geodesics, PlaneMatchesEuclideanWithinTwoPercentAndBeatsTheEdgeGraph) {
  const int n = 41;
  const double h = 0.1;
  const Mesh mesh = plane(n, h);
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  const uint32_t centre = (n / 2) * n + n / 2;
  source[centre] = 1;
  std::vector<double> exact(mesh.vertexCount());
  for (size_t v = 0; v < exact.size(); ++v) {
    exact[v] = glm::length(glm::dvec3(mesh.positions[v]) - glm::dvec3(mesh.positions[centre]));
  }
  const double radius = 15 * h;  // k = 15 rings reach at most this far
  const Errors graph = relativeErrors(edgeGraphDistance(mesh, source), exact, 0.0, radius);
  // Fewer passes reach less far: K is the reach, the error stays small.
  double previous_coverage = 0.0;
  for (int passes : {5, 10, 20, 40}) {
    GeodesicOptions options;
    options.iterations = passes;
    const auto d = approximateGeodesic(mesh, source, options);
    const Errors e = relativeErrors(d, exact, 0.0, radius);
    // Every vertex within 7 grid steps is within k = 15 rings whatever the
    // direction: that disc is the bounded radius every K must end up covering.
    size_t inside = 0, reached = 0;
    for (size_t v = 0; v < exact.size(); ++v) {
      if (exact[v] > 7 * h + 1e-9) continue;
      ++inside;
      reached += std::isfinite(d[v]);
    }
    const double coverage = static_cast<double>(reached) / static_cast<double>(inside);
    RecordProperty("plane_K" + std::to_string(passes) + "_coverage", std::to_string(coverage));
    RecordProperty("plane_K" + std::to_string(passes) + "_mean_error", std::to_string(e.mean));
    RecordProperty("plane_K" + std::to_string(passes) + "_worst_error", std::to_string(e.worst));
    EXPECT_GE(coverage, previous_coverage);
    previous_coverage = coverage;
    EXPECT_LT(e.mean, 0.02) << "K = " << passes;
    if (passes >= 20) {
      EXPECT_DOUBLE_EQ(coverage, 1.0);
      EXPECT_LT(e.mean, graph.mean / 4) << "unfolding must beat edge-graph relaxation";
    }
  }
  RecordProperty("plane_edge_graph_mean_error", std::to_string(graph.mean));
  RecordProperty("plane_edge_graph_worst_error", std::to_string(graph.worst));
  EXPECT_GT(graph.mean, 0.05) << "the edge graph of a regular grid is known to be far off";
}

TEST(Geodesics, SphereMatchesGreatCircleWithinTwoPercent) {
  const double r = 1.0;
  const Mesh mesh = marchingCubes(sampleGrid(glm::dvec3(-1.2), 0.08, 31, 31, 31,
                                             [&](const glm::dvec3& p) { return r - glm::length(p); }));
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  size_t top = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    if (mesh.positions[v].z > mesh.positions[top].z) top = v;
  }
  source[top] = 1;
  const glm::dvec3 s = glm::normalize(glm::dvec3(mesh.positions[top]));
  std::vector<double> exact(mesh.vertexCount());
  for (size_t v = 0; v < exact.size(); ++v) {
    exact[v] = r * std::acos(std::clamp(glm::dot(glm::normalize(glm::dvec3(mesh.positions[v])), s), -1.0, 1.0));
  }
  const Errors approx = relativeErrors(approximateGeodesic(mesh, source), exact, 0.15, 0.7);
  const Errors graph = relativeErrors(edgeGraphDistance(mesh, source), exact, 0.15, 0.7);
  RecordProperty("sphere_mean_error", std::to_string(approx.mean));
  RecordProperty("sphere_edge_graph_mean_error", std::to_string(graph.mean));
  ASSERT_GT(approx.count, 50u);
  EXPECT_LT(approx.mean, 0.02);
  EXPECT_LT(approx.mean, graph.mean);
}

TEST(Geodesics, RingsBoundTheReachAndNormalisationMapsToOne) {
  const Mesh mesh = plane(31, 0.1);
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  source[0] = 1;  // a corner
  GeodesicOptions options;
  options.max_rings = 5;
  options.iterations = 20;
  const auto d = approximateGeodesic(mesh, source, options);
  EXPECT_TRUE(std::isinf(d[mesh.vertexCount() - 1])) << "the far corner is out of reach";
  EXPECT_TRUE(std::isfinite(d[1]));
  const auto gamma = normalizedGeodesic(mesh, d, options.max_rings);
  EXPECT_DOUBLE_EQ(gamma[0], 0.0);
  EXPECT_DOUBLE_EQ(gamma[mesh.vertexCount() - 1], 1.0);
  for (double g : gamma) ASSERT_TRUE(g >= 0.0 && g <= 1.0);
  // Deterministic: the same input gives the same bits.
  EXPECT_EQ(approximateGeodesic(mesh, source, options), d);
}

}  // namespace
}  // namespace holofuse::render::reference
