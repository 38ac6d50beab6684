// Iso-surface extraction from a scalar grid by marching cubes. The case
// table is derived at start-up by tracing the surface across the cube faces
// (ambiguous faces keep inside corners apart), so neighbouring cubes always
// agree and the surface is closed where the field is.
#pragma once

#include <cstdint>
#include <functional>
#include <glm/glm.hpp>
#include <vector>

#include "geometry/mesh.h"

namespace holofuse {

struct ScalarGrid {
  int nx = 0, ny = 0, nz = 0;  // grid points per axis
  glm::dvec3 origin{0.0};      // world position of point (0,0,0)
  double spacing = 1.0;        // distance between neighbouring points
  std::vector<float> values;   // nx*ny*nz, x fastest; > 0 means inside

  float at(int x, int y, int z) const { return values[(static_cast<size_t>(z) * ny + y) * nx + x]; }
  glm::dvec3 point(int x, int y, int z) const { return origin + spacing * glm::dvec3(x, y, z); }
};

// Samples f at every grid point.
ScalarGrid sampleGrid(const glm::dvec3& origin, double spacing, int nx, int ny, int nz,
                      const std::function<double(const glm::dvec3&)>& f);

// Triangles where the field crosses zero, oriented with normals pointing to
// the outside (decreasing values). Vertices are shared between cubes and
// keyed by the grid edge they sit on; vertex normals are area weighted.
Mesh marchingCubes(const ScalarGrid& grid);

// The derived case table, for tests: for each of the 256 corner sign
// configurations, triangles as triples of cube edge ids (0..11).
const std::vector<std::vector<int>>& marchingCubesCaseTable();

}  // namespace holofuse
