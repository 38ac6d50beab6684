// CPU reference of texture-field stages 3 to 5 and 7 (docs/design.md section 6,
// paper 000 sections 4.2, 4.3 and eq. 4): per-vertex visibility of every
// pod camera, multi-level majority voting in Lab, seam triangles by the
// three rules, and the global visibility score.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "image/image.h"
#include "render_client/reference/depth_map.h"

namespace holofuse::render::reference {

struct PodView {
  Camera camera;
  Image8 color;  // RGB
  Image8 mask;   // grey, non-zero = foreground
  // grey, distance to the silhouette's edge in pixels (the pod's feather
  // map, render::ViewImages::feather); empty: 255 over the whole mask.
  Image8 feather;
};

// Why a vertex is or is not seen by a camera, in test order.
enum class Sight : uint8_t {
  kVisible = 0,
  kBehind,         // behind the camera
  kOutsideImage,   // projects outside the image
  kBackground,     // projects onto the pod's background (mask 0)
  kOccluded,       // behind the camera's depth map
  kDiscontinuity,  // inside the dilated depth discontinuities
};

struct VisibilityOptions {
  DiscontinuityOptions discontinuity;
  double relative_depth_tolerance =
      0.015;  // a vertex this far (relative) behind the depth map is occluded
};

// sights[i][v]: camera i, vertex v.
std::vector<std::vector<Sight>> vertexSights(const Mesh& mesh, const std::vector<PodView>& views,
                                             const VisibilityOptions& options = {});

// CIE Lab (D65) of an sRGB colour, each component divided by 100, so the
// paper's delta = 0.15 is a distance of 15 Lab units.
glm::dvec3 srgbToLab(const uint8_t* rgb);

struct VoteOptions {
  double delta =
      0.15;  // Lab distance (scaled by 1/100) under which two views agree; 0: trust every view
  int levels = 3;  // mip levels searched, coarsest first
};

// trusted[i][v]: camera i's colour at vertex v agrees with at least
// floor(X/2) of the other X-1 views that see v (eq. 3), at some level of
// the mip pyramid searched from coarse to fine (a ghost disagrees at every
// level; a small misregistration agrees at a coarse one). Only defined
// where sights[i][v] is kVisible; false elsewhere.
std::vector<std::vector<uint8_t>> majorityVote(const Mesh& mesh, const std::vector<PodView>& views,
                                               const std::vector<std::vector<Sight>>& sights,
                                               const VoteOptions& options = {});

// V_v^i of the paper: seen (kVisible) and trusted by the vote.
std::vector<std::vector<uint8_t>> finalVisibility(const std::vector<std::vector<Sight>>& sights,
                                                  const std::vector<std::vector<uint8_t>>& trusted);

enum SeamRule : uint8_t {
  kSeamOcclusion = 1,   // some but not all vertices occluded in the dilated depth map
  kSeamVote = 2,        // seen vertices disagree in the vote
  kSeamFieldOfView = 4  // some but not all vertices outside the image or on the background
};

// seams[i][t]: the SeamRule bits that make triangle t a seam for camera i
// (0: not a seam).
std::vector<std::vector<uint8_t>> seamTriangles(const Mesh& mesh,
                                                const std::vector<std::vector<Sight>>& sights,
                                                const std::vector<std::vector<uint8_t>>& trusted);

// g^i: visible vertex count of each view divided by the largest count (the
// dominant view scores 1); all zero when nothing is visible.
std::vector<double> globalVisibility(const std::vector<std::vector<uint8_t>>& visible);

}  // namespace holofuse::render::reference
