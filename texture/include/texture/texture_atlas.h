// A per-frame texture atlas for a mesh that changes every frame: a square
// texture cut into a grid of squares, two triangles to a square, each
// triangle's UVs an inner triangle inset from its half of the square so
// bilinear sampling never reaches a neighbour (Dong and Hollerer 2017,
// section 3.1, eq. 1 and Algorithms 1 and 2).
//
// The paper numbers triangles in mesh order; a visual hull's triangles
// change every frame, so here a square belongs to a patch of surface: the
// lattice cell its triangles come from (their vertex keys). A cell keeps its
// square from frame to frame while the grid's size holds, so a layer's
// texels stay in place where the surface does (what video coding of the
// layers, Volino and Hilton 2016 section 4.2.2, profits from).
#pragma once

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <span>
#include <unordered_map>
#include <vector>

#include "base/status.h"
#include "geometry/mesh.h"

namespace holofuse {

// The sides an atlas takes, texels.
inline constexpr uint32_t kMinAtlasTexels = 64, kMaxAtlasTexels = 16384;

struct AtlasOptions {
  uint32_t texels = 1024;      // side of the square texture
  uint32_t max_texels = 4096;  // it doubles up to this when its squares get too small
  // A square of fewer texels leaves the odd inner triangle under two texels
  // a side (innerTriangleTexels); at least 6.
  uint32_t min_square_texels = 6;
  // Spare squares when the grid is laid out anew, so a growing surface does
  // not regrid the next frame.
  double headroom = 1.25;
  // The capture volume's key lattice (hull::keyLattice); zero when vertex
  // keys are absent or not lattice edges: then squares follow triangle
  // order, as in the paper, and nothing is kept between frames.
  glm::u64vec3 lattice{0};
  // Charts instead of a square per pair of triangles: 0 for the paper's
  // squares; n for a square per block of n^3 lattice cells and dominant
  // axis of the triangles' normals, the triangles projected onto the
  // square orthographically at texels_per_cell texels a lattice cell (the
  // texel density is a knob, not a consequence of the triangle count).
  // Needs the lattice and cell_size (the lattice's spacing, metres).
  uint32_t chart_cells = 0;
  double texels_per_cell = 3.0;
  double cell_size = 0.0;
  // A triangle's chart faces the dominant axis of the normal summed over
  // its lattice cell and the cell's six face neighbours; false: of its own
  // normal (protocol 1.5 to 1.11 receivers lay charts out so).
  bool charts_face_surface_around = true;
};

// Texels between a chart's projected triangles and its square's edge: two
// charts' footprints stay further apart than a bilinear sample reaches.
inline constexpr uint32_t kChartGutterTexels = 2;

struct AtlasStats {
  uint32_t texels = 0;            // side of the texture this frame
  uint32_t squares_per_side = 0;  // the grid's size (eq. 1 with headroom)
  uint32_t square_texels = 0;     // side of one square, texels
  uint32_t squares_used = 0;
  uint32_t squares_kept = 0;  // holding the same patch of surface, in the same place, as last frame
  // New, in another slot, or (charts) showing their surface half a texel
  // or more from where they did: the texels a video coder cannot predict
  // from the same place in the frame before.
  uint32_t squares_moved = 0;
  bool regridded = false;  // the grid changed size: nothing is kept
  double keptFraction() const { return squares_used ? double(squares_kept) / squares_used : 0.0; }
  double movedFraction() const { return squares_used ? double(squares_moved) / squares_used : 0.0; }
};

// What a receiver needs to lay the same mesh out again from its vertex
// keys (applyAtlasLayout), so that texture coordinates need not travel:
// the grid, the key lattice, and each square's slot in the grid, squares in
// ascending key order.
struct AtlasLayout {
  uint32_t texels = 0, squares_per_side = 0, square_texels = 0;
  glm::u64vec3 lattice{0};
  std::vector<uint32_t> slots;
  uint32_t chart_cells = 0;                // AtlasOptions::chart_cells
  double texel_metres = 0;                 // charts: metres of surface a texel spans
  bool charts_face_surface_around = true;  // AtlasOptions::charts_face_surface_around
  bool keyed() const { return lattice.x > 0 && lattice.y > 0 && lattice.z > 0; }
};

// Where one triangle lies in the atlas: its square's top-left texel and
// which half (even: top-left, odd: bottom-right, Algorithm 1).
struct AtlasCell {
  uint32_t x = 0, y = 0;  // texels
  bool odd = false;
  // Charts: the axis the triangle is projected along, 2 * axis (x 0, y 1,
  // z 2) plus 1 where the surface faces down it; 0 without charts.
  uint8_t chart_axis = 0;
};

class TextureAtlas {
 public:
  explicit TextureAtlas(const AtlasOptions& options = {});

  // Lays the mesh's triangles out: fills mesh.corner_uvs (three per
  // triangle, the inner triangle of Algorithm 2, in [0,1]) and returns where
  // each triangle lies. Refused by name, leaving the mesh untouched, when
  // its triangles need more squares than max_texels holds.
  StatusOr<std::vector<AtlasCell>> layOut(Mesh& mesh, AtlasStats* stats = nullptr);

  uint32_t texels() const { return texels_; }
  uint32_t squareTexels() const { return square_texels_; }
  // The last layOut's layout; not keyed (lattice zero) when the mesh's
  // vertex keys were not the lattice's, and then its squares cannot be
  // found again from the keys.
  const AtlasLayout& layout() const { return layout_; }

 private:
  AtlasOptions options_;
  uint32_t texels_ = 0;
  uint32_t squares_per_side_ = 0;
  uint32_t square_texels_ = 0;
  std::unordered_map<uint64_t, uint32_t> slot_of_key_;  // last frame's squares
  std::unordered_map<uint64_t, glm::dvec2> anchors_;    // last frame's charts' corners, metres
  AtlasLayout layout_;
};

// The layout a sender's TextureAtlas::layOut gave this mesh, applied to the
// mesh as received (Draco may reorder triangles and vertices; the vertex
// keys name the same squares): fills mesh.corner_uvs and returns the cells.
// Refused by name when the keys do not make the layout's squares or the
// layout does not fit its atlas.
StatusOr<std::vector<AtlasCell>> applyAtlasLayout(Mesh& mesh, const AtlasLayout& layout);

// The slots on the wire: each the difference from the one before, zigzag,
// LEB128 (seven bits a byte), LZ4 (a kept layout is long runs of +1).
// decode takes untrusted bytes and the count the message states.
std::vector<uint8_t> encodeAtlasSlots(const std::vector<uint32_t>& slots);
StatusOr<std::vector<uint32_t>> decodeAtlasSlots(std::span<const uint8_t> bytes, uint32_t count);

// Corners of a triangle's inner triangle (Algorithm 2, the odd one a texel
// further from the diagonal for bilinear sampling), in texels from the
// atlas's top-left corner.
std::array<glm::dvec2, 3> innerTriangleTexels(const AtlasCell& cell, uint32_t square_texels);

}  // namespace holofuse
