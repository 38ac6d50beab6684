#include "geometry/mesh.h"

#include <algorithm>
#include <limits>

namespace holofuse {

void computeVertexNormals(Mesh& mesh) {
  std::vector<glm::dvec3> sum(mesh.positions.size(), glm::dvec3(0.0));
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
    const glm::dvec3 pa(mesh.positions[a]), pb(mesh.positions[b]), pc(mesh.positions[c]);
    // The cross product's length is twice the area: area weighting for free.
    const glm::dvec3 n = glm::cross(pb - pa, pc - pa);
    sum[a] += n;
    sum[b] += n;
    sum[c] += n;
  }
  mesh.normals.resize(mesh.positions.size());
  for (size_t v = 0; v < sum.size(); ++v) {
    const double len = glm::length(sum[v]);
    mesh.normals[v] = len > 0 ? glm::vec3(sum[v] / len) : glm::vec3(0.0f);
  }
}

Bounds meshBounds(const Mesh& mesh) {
  Bounds b;
  if (mesh.positions.empty()) return b;
  b.min = glm::vec3(std::numeric_limits<float>::max());
  b.max = glm::vec3(std::numeric_limits<float>::lowest());
  for (const auto& p : mesh.positions) {
    b.min = glm::min(b.min, p);
    b.max = glm::max(b.max, p);
  }
  return b;
}

double meanEdgeLength(const Mesh& mesh) {
  double sum = 0;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    for (size_t k = 0; k < 3; ++k) {
      sum += glm::length(glm::dvec3(mesh.positions[mesh.indices[t + k]]) -
                         glm::dvec3(mesh.positions[mesh.indices[t + (k + 1) % 3]]));
    }
  }
  const size_t edges = mesh.indices.size() / 3 * 3;
  return edges ? sum / static_cast<double>(edges) : 0.0;
}

}  // namespace holofuse
