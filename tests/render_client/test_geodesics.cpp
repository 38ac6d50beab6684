// The approximate geodesic distance (triangle unfolding, bounded Jacobi
// passes) against distances known exactly: Euclidean on a plane,
// great-circle on a sphere, the exact polyhedral distance on a bumpy closed
// surface; and against edge-graph relaxation. The exact method is checked
// first where the answer is known in closed form (plane, cube).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <tuple>

#include "geometry/marching_cubes.h"
#include "render_client/reference/exact_geodesics.h"
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

std::vector<double> chordLengths(const Mesh& mesh, uint32_t from) {
  std::vector<double> d(mesh.vertexCount());
  for (size_t v = 0; v < d.size(); ++v)
    d[v] = glm::length(glm::dvec3(mesh.positions[v]) - glm::dvec3(mesh.positions[from]));
  return d;
}

// The plane with its middle vertex as the only source.
struct CentredPlane {
  Mesh mesh;
  std::vector<uint8_t> source;
  uint32_t centre;
};
CentredPlane centredPlane(int n, double h) {
  CentredPlane p{plane(n, h), {}, static_cast<uint32_t>((n / 2) * n + n / 2)};
  p.source.assign(p.mesh.vertexCount(), 0);
  p.source[p.centre] = 1;
  return p;
}

struct Errors {
  double mean = 0, worst = 0;
  size_t count = 0;
};

// Relative error against exact distances for the vertices the field
// reaches (within k rings) with min_distance < exact <= radius.
Errors relativeErrors(const std::vector<double>& approx, const std::vector<double>& exact,
                      double min_distance, double radius) {
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
  const double h = 0.1;
  const auto [mesh, source, centre] = centredPlane(41, h);
  const std::vector<double> exact = chordLengths(mesh, centre);
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
  const Mesh mesh = marchingCubes(sampleGrid(
      glm::dvec3(-1.2), 0.08, 31, 31, 31, [&](const glm::dvec3& p) { return r - glm::length(p); }));
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  size_t top = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    if (mesh.positions[v].z > mesh.positions[top].z) top = v;
  }
  source[top] = 1;
  const glm::dvec3 s = glm::normalize(glm::dvec3(mesh.positions[top]));
  std::vector<double> exact(mesh.vertexCount());
  for (size_t v = 0; v < exact.size(); ++v) {
    exact[v] = r * std::acos(std::clamp(glm::dot(glm::normalize(glm::dvec3(mesh.positions[v])), s),
                                        -1.0, 1.0));
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

// The distance diffuses only into the region a camera sees: outside it
// nothing is reached (sources keep 0), inside a path that stays in the
// region is measured as before.
TEST(Geodesics, RegionKeepsTheDistanceToWhatTheCameraSees) {
  const Mesh mesh = plane(31, 0.1);
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  for (uint32_t x = 0; x < 31; ++x) source[x] = 1;  // the row y = 0
  GeodesicOptions everywhere;
  everywhere.max_rings = 40;
  everywhere.iterations = 40;
  GeodesicOptions left = everywhere;
  left.region.assign(mesh.vertexCount(), 0);
  for (uint32_t v = 0; v < mesh.vertexCount(); ++v) left.region[v] = (v % 31) < 15;  // x < 1.5
  const auto full = approximateGeodesic(mesh, source, everywhere);
  const auto part = approximateGeodesic(mesh, source, left);
  for (uint32_t v = 0; v < mesh.vertexCount(); ++v) {
    if (source[v]) {
      EXPECT_EQ(part[v], 0.0);
    } else if (left.region[v]) {
      EXPECT_NEAR(part[v], full[v], 1e-9) << v;  // straight down to the row: inside the region
    } else {
      EXPECT_TRUE(std::isinf(part[v])) << v;
    }
  }
}

// The geodesic radius: what lies within it keeps its unbounded distance,
// what lies beyond stays unreached (gamma 1, as at the radius itself).
TEST(Geodesics, RadiusBoundsTheReachWithoutChangingWhatItReaches) {
  const Mesh mesh = plane(31, 0.1);
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  for (uint32_t x = 0; x < 31; ++x) source[x] = 1;  // one side: distance is the height above it
  GeodesicOptions unbounded;
  unbounded.max_rings = 40;
  unbounded.iterations = 40;
  GeodesicOptions bounded = unbounded;
  bounded.max_distance = 0.75;
  const auto full = approximateGeodesic(mesh, source, unbounded);
  const auto cut = approximateGeodesic(mesh, source, bounded);
  size_t inside = 0, outside = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    ASSERT_TRUE(std::isfinite(full[v]));
    if (full[v] <= bounded.max_distance) {
      EXPECT_DOUBLE_EQ(cut[v], full[v]) << v;
      ++inside;
    } else {
      EXPECT_TRUE(std::isinf(cut[v])) << v << " at " << full[v];
      ++outside;
    }
  }
  EXPECT_GT(inside, 200u);
  EXPECT_GT(outside, 200u);
  const auto gamma = normalizedGeodesic(mesh, cut, bounded.max_rings, bounded.max_distance);
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    EXPECT_NEAR(gamma[v], std::min(1.0, full[v] / bounded.max_distance), 1e-12);
  }
}

// The surface of the cube [-1, 1]^3, each face an m x m grid (m even, so
// face centres are vertices), welded along the edges.
Mesh cube(int m) {
  Mesh mesh;
  std::map<std::tuple<long, long, long>, uint32_t> index_of;
  auto vertex = [&](const glm::dvec3& p) {
    const auto key =
        std::make_tuple(std::lround(p.x * 1e6), std::lround(p.y * 1e6), std::lround(p.z * 1e6));
    const auto [it, added] = index_of.emplace(key, static_cast<uint32_t>(mesh.positions.size()));
    if (added) mesh.positions.emplace_back(p);
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis) {
    for (double side : {-1.0, 1.0}) {
      for (int j = 0; j < m; ++j) {
        for (int i = 0; i < m; ++i) {
          auto at = [&](int u, int v) {
            glm::dvec3 p;
            p[axis] = side;
            p[(axis + 1) % 3] = -1.0 + 2.0 * u / m;
            p[(axis + 2) % 3] = -1.0 + 2.0 * v / m;
            return vertex(p);
          };
          const uint32_t a = at(i, j), b = at(i + 1, j), c = at(i, j + 1), d = at(i + 1, j + 1);
          for (uint32_t k : {a, b, d, a, d, c}) mesh.indices.push_back(k);
        }
      }
    }
  }
  computeVertexNormals(mesh);
  return mesh;
}

TEST(ExactGeodesics, PlaneIsEuclidean) {
  const auto [mesh, source, centre] = centredPlane(31, 0.1);
  const auto exact = exactGeodesic(mesh, source, 1.2);
  const auto euclid = chordLengths(mesh, centre);
  size_t checked = 0;
  for (size_t v = 0; v < exact.size(); ++v) {
    if (euclid[v] > 1.2) {
      EXPECT_TRUE(std::isinf(exact[v])) << "beyond the bound";
      continue;
    }
    ASSERT_NEAR(exact[v], euclid[v], 1e-9) << "vertex " << v;
    ++checked;
  }
  EXPECT_GT(checked, 400u);
}

TEST(ExactGeodesics, CubeFollowsTheUnfoldingAcrossEdges) {
  // Source at the centre of the face z = 1. A point (1, y, z) on the face
  // x = 1 lies, unfolded across their common edge, at (2 - z, y): no other
  // way round is shorter for |y| <= 1.
  const Mesh mesh = cube(16);
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  uint32_t top = 0;
  for (uint32_t v = 0; v < mesh.vertexCount(); ++v) {
    if (glm::length(glm::dvec3(mesh.positions[v]) - glm::dvec3(0, 0, 1)) < 1e-9) top = v;
  }
  source[top] = 1;
  const auto bend = bendVertices(mesh);
  EXPECT_EQ(std::count(bend.begin(), bend.end(), 1), 0)
      << "a cube has no saddles: corners have 3 pi / 2";
  const auto exact = exactGeodesic(mesh, source, 10.0);
  size_t checked = 0;
  for (size_t v = 0; v < exact.size(); ++v) {
    const glm::dvec3 p(mesh.positions[v]);
    if (std::abs(p.x - 1.0) > 1e-9) continue;
    ASSERT_NEAR(exact[v], std::hypot(2.0 - p.z, p.y), 1e-9)
        << "at " << p.x << " " << p.y << " " << p.z;
    ++checked;
  }
  EXPECT_EQ(checked, 17u * 17u);
}

// r = 1 + bumps: a closed surface with saddles, where shortest paths bend
// at vertices and no formula gives the distance.
Mesh bumpySphere() {
  return marchingCubes(sampleGrid(glm::dvec3(-1.4), 0.08, 36, 36, 36, [](const glm::dvec3& p) {
    return 1.0 + 0.12 * std::sin(5 * p.x) * std::sin(5 * p.y) * std::sin(5 * p.z) - glm::length(p);
  }));
}

TEST(ExactGeodesics, BumpySurfaceLiesBetweenChordAndEdgeGraph) {
  const Mesh mesh = bumpySphere();
  const auto bend = bendVertices(mesh);
  EXPECT_GT(std::count(bend.begin(), bend.end(), 1), 100) << "the bumps make saddles";
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  source[0] = 1;
  const auto exact = exactGeodesic(mesh, source, 1.5);
  const auto graph = edgeGraphDistance(mesh, source);
  const auto chord = chordLengths(mesh, 0);
  size_t checked = 0;
  for (size_t v = 0; v < exact.size(); ++v) {
    if (!std::isfinite(exact[v])) continue;
    // Any path along edges is a surface path; no surface path beats the chord.
    ASSERT_LE(exact[v], graph[v] * (1 + 1e-12)) << v;
    ASSERT_GE(exact[v], chord[v] * (1 - 1e-12)) << v;
    ++checked;
  }
  EXPECT_GT(checked, 300u);
}

TEST(Geodesics, BumpySurfaceErrorAgainstExactFallsWithK) {
  // Seam-like sources: the vertices along a band around the surface, as the
  // seams of a camera are. Errors are measured within the bounded radius
  // (k = 15 mean edges) and away from the sources' first ring.
  const Mesh mesh = bumpySphere();
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  for (size_t v = 0; v < mesh.vertexCount(); ++v)
    source[v] = std::abs(mesh.positions[v].z - 0.3f) < 0.03f;
  ASSERT_GT(std::count(source.begin(), source.end(), 1), 20);
  const double mean_edge = meanEdgeLength(mesh);
  const double radius = 15 * mean_edge;
  const auto exact = exactGeodesic(mesh, source, radius);
  const Errors graph = relativeErrors(edgeGraphDistance(mesh, source), exact, mean_edge, radius);
  RecordProperty("bumpy_mean_edge", std::to_string(mean_edge));
  RecordProperty("bumpy_edge_graph_mean_error", std::to_string(graph.mean));
  double previous_coverage = 0.0;
  for (int passes : {5, 10, 15, 20, 30}) {
    GeodesicOptions options;
    options.iterations = passes;
    const auto d = approximateGeodesic(mesh, source, options);
    const Errors e = relativeErrors(d, exact, mean_edge, radius);
    size_t inside = 0, reached = 0;
    for (size_t v = 0; v < exact.size(); ++v) {
      if (!(exact[v] <= radius)) continue;
      ++inside;
      reached += std::isfinite(d[v]);
    }
    const double coverage = static_cast<double>(reached) / static_cast<double>(inside);
    const std::string key = "bumpy_K" + std::to_string(passes);
    RecordProperty(key + "_mean_error", std::to_string(e.mean));
    RecordProperty(key + "_worst_error", std::to_string(e.worst));
    RecordProperty(key + "_coverage", std::to_string(coverage));
    std::printf(
        "K = %2d: mean relative error %.3f%%, worst %.2f%%, reached %zu of %zu vertices within the "
        "radius\n",
        passes, 100 * e.mean, 100 * e.worst, reached, inside);
    EXPECT_GE(coverage, previous_coverage) << "more passes reach at least as far, K = " << passes;
    previous_coverage = coverage;
    if (passes >= 15) {
      EXPECT_LT(e.mean, 0.02) << "K = " << passes;
      EXPECT_LT(e.mean, graph.mean) << "unfolding must beat the edge graph";
    }
  }
  std::printf("edge graph: mean relative error %.2f%%\n", 100 * graph.mean);
}

}  // namespace
}  // namespace holofuse::render::reference
