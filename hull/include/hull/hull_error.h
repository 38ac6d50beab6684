// The error target of the visual hull (docs/design.md section 5: resolution is
// the accuracy knob; a user sets either a voxel size or an error). An exact
// visual hull projects onto every silhouette it was carved from: each
// silhouette ray touches it. What the outlines disagree by is therefore the
// grid's error (plus any disagreement among the silhouettes themselves),
// and it is measurable in every frame, without a true surface.
#pragma once

#include <vector>

#include "geometry/mesh.h"
#include "hull/visual_hull.h"

namespace holofuse::hull {

struct SilhouetteError {
  // Symmetric mean distance between the outline of the mesh seen from a
  // camera and the outline of that camera's mask, averaged over the cameras.
  double mean_px = 0;
  double mean_m = 0;   // each camera's pixels in metres at the subject's median depth
  double worst_m = 0;  // the camera that disagrees most
  bool valid = false;  // false: no camera saw both outlines
};

SilhouetteError silhouetteError(const Mesh& mesh, const std::vector<HullView>& views);

// The finest voxel the error search goes down to, and the step between
// tries.
constexpr double kFinestVoxel = 0.004;
constexpr double kVoxelStep = 0.75;

struct HullForTarget {
  Mesh mesh;
  double voxel_size = 0;
  SilhouetteError error;
  bool met = false;  // false: the silhouettes disagree by more than the target (see below)
  int carves = 0;
};

// A finer voxel that lowers the error by less than this fraction means the
// rest is the silhouettes' own disagreement (calibration, segmentation):
// refining further only costs time.
constexpr double kUsefulImprovement = 0.1;

// Carves at options.voxel_size, then at voxels kVoxelStep finer each time,
// until the silhouette error is within target_m: the coarsest hull that
// meets the target. It stops unmet at kFinestVoxel, or where a finer voxel
// stopped helping (and returns the coarser hull).
HullForTarget carveToErrorTarget(const std::vector<HullView>& views, const HullOptions& options,
                                 double target_m, HullStats* stats = nullptr);

// Follows an error target from frame to frame with one carve per frame: a
// finer voxel for the next frame when the last one missed the target, a
// coarser one when it beat the target by far, but not back to a voxel that
// missed in the last kMissMemory frames (the error is not linear in the
// voxel, and a controller without that memory swings between two voxels).
class VoxelController {
 public:
  VoxelController(double target_m, double start_voxel, double coarsest_voxel);
  double voxel() const { return voxel_; }
  // Returns true when the voxel changed.
  bool observe(const SilhouetteError& error);
  // True after a finer voxel stopped helping: the target is out of reach
  // and the voxel stays at the coarser one for kMissMemory frames.
  bool unreachable() const { return floor_voxel_ > 0; }
  static constexpr int kMissMemory = 300;

 private:
  double target_m_, voxel_, coarsest_, finest_;
  double missed_voxel_ = 0;  // the finest voxel that missed lately; 0: none
  int since_miss_ = 0;
  double refined_from_ = 0, refined_from_error_ = 0;  // the last refinement after a miss
  double floor_voxel_ = 0;                            // where refining stopped helping; 0: none
  int since_floor_ = 0;
};

}  // namespace holofuse::hull
