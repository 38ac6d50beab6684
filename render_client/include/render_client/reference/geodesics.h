// Stage 6 of docs/design.md section 6 (paper 000 section 4.4): distance over the
// surface from a camera's seam vertices, bounded to k triangle rings and K
// Jacobi iterations. Each update unfolds a triangle into the plane and
// measures the straight line from the virtual source (the point at the two
// known distances from the opposite edge's ends) to the vertex, so a
// distance is a surface distance, not a path along edges. Each vertex keeps
// the source its distance comes from, and the unfolding is used only when
// both ends measure from the same source (else the way round through an
// end). The same update runs on the GPU; this is its double-precision
// reference. render::reference::exactGeodesic is the yardstick.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.h"

namespace holofuse::render::reference {

struct GeodesicOptions {
  int max_rings = 15;   // k: vertices more triangle rings away than this stay unreached
  int iterations = 20;  // K: Jacobi passes
  // Distances beyond this stay unreached (0: no bound): gamma of eq. 4 is 1
  // from the normalising distance on, so nothing past it needs computing.
  double max_distance = 0.0;
  // Only these vertices receive a distance (empty: all): paper 000 section
  // 4.4 diffuses from a camera's seams towards the triangles it sees, so
  // the renderer passes the vertices the camera sees. Sources always have 0.
  std::vector<uint8_t> region;
};

// Per-vertex distance from the sources; +infinity where not reached.
// Deterministic: every pass reads only the previous pass's distances.
std::vector<double> approximateGeodesic(const Mesh& mesh, const std::vector<uint8_t>& is_source,
                                        const GeodesicOptions& options = {});

// The distance along mesh edges (Dijkstra): what relaxing an edge graph
// gives, for comparison.
std::vector<double> edgeGraphDistance(const Mesh& mesh, const std::vector<uint8_t>& is_source);

// The distance at c through triangle (a, b, c) given the distances at a and
// b (either may be infinite): the unfolded straight line when it crosses
// edge ab, else the shorter way round through a or b.
double unfoldedDistance(double ab, double ac, double bc, double da, double db);

// gamma of eq. 4: distance / max_distance, clamped to [0, 1]; 1 where the
// seams are out of reach. max_distance <= 0 picks max_rings mean edge
// lengths.
std::vector<double> normalizedGeodesic(const Mesh& mesh, const std::vector<double>& distance,
                                       int max_rings, double max_distance = 0.0);

}  // namespace holofuse::render::reference
