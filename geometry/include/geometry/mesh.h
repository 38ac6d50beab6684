// Triangle mesh shared by the hull, the codecs and the renderer.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

namespace holofuse {

struct Mesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // per vertex, unit length (or zero)
  std::vector<uint32_t> indices;   // three per triangle, counter-clockwise seen from outside
  // Identity of each vertex across frames where the extractor gives one
  // (marching cubes: the grid edge it sits on); empty otherwise.
  std::vector<uint64_t> vertex_keys;
  // Texture coordinates per triangle corner (three per triangle, in the
  // order of indices, [0,1] from the texture's top-left) where the mesh
  // carries a texture atlas (texture/texture_atlas.h); empty otherwise.
  // Per corner, not per vertex: a vertex's triangles lie apart in an atlas.
  std::vector<glm::vec2> corner_uvs;

  size_t vertexCount() const { return positions.size(); }
  size_t triangleCount() const { return indices.size() / 3; }
};

// Area-weighted vertex normals from the triangles.
void computeVertexNormals(Mesh& mesh);

struct Bounds {
  glm::vec3 min{0.0f}, max{0.0f};
};
Bounds meshBounds(const Mesh& mesh);

// Mean length of the triangles' edges (an edge shared by two triangles
// counts twice), in double precision; 0 without triangles.
double meanEdgeLength(const Mesh& mesh);

}  // namespace holofuse
