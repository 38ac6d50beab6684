// Photo-consistency refinement of the visual hull (issue 18, item 6): a
// visual hull is a superset of the subject, so each vertex may move inward
// along its normal to where the two or three cameras that face it best
// agree on its colour (the idea of photo hulls: Kutulakos and Seitz 2000,
// space carving by photo-consistency). The search never leaves the
// silhouettes: a candidate that projects outside any camera's mask ends it.
#pragma once

#include <vector>

#include "geometry/mesh.h"
#include "hull/visual_hull.h"
#include "image/image.h"

namespace holofuse::fusion {

struct PhotoRefineOptions {
  // How far inward a vertex may move, in voxels of the hull it refines
  // (0: no refinement). Four: on the temple and the synthetic scenes the
  // gain grows to about there (docs/photo-refinement.md) and the hull's
  // error with a few cameras is several voxels.
  double depth_voxels = 0;
  double voxel_size = 0.02;   // metres, the hull's voxel
  int steps = 8;              // candidates between 0 and max_depth
  int views = 3;              // cameras compared per vertex, the best facing
  double min_facing = 0.3;    // cos of the largest angle between normal and camera
  int smoothing_passes = 3;   // neighbour averages of the offsets
  int silhouette_rounds = 4;  // restorations of vertices that left a mask pixel bare
};

struct PhotoRefineStats {
  size_t vertices_moved = 0;
  int silhouette_rounds =
      0;  // checks run (the last found nothing bare unless the hull came back whole)
  size_t vertices_restored = 0;  // put back: moving them bared a silhouette pixel
  double mean_offset = 0;        // metres, over every vertex
};

// views[i].camera and .mask as carved; colors[i]: camera i's whole RGB
// image. Returns the mesh with moved vertices and fresh normals; the
// triangles, their order and the vertex keys are the hull's.
Mesh refineByPhotoConsistency(const Mesh& hull, const std::vector<hull::HullView>& views,
                              const std::vector<Image8>& colors, const PhotoRefineOptions& options,
                              PhotoRefineStats* stats = nullptr);

}  // namespace holofuse::fusion
