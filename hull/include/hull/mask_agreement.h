// Masks that agree across the rig. A camera alone cannot tell the subject
// from anything else that differs from its plate (a stand set down after
// the plate, a light, a wall edge the camera shook against); the other
// cameras can: a piece of one camera's mask that the others' visual hull
// does not project onto meets no other camera's foreground inside the
// capture volume, so it is not the subject.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "hull/visual_hull.h"
#include "image/image.h"

namespace holofuse::hull {

struct AgreementOptions {
  // Slack for calibration, pixels: a mask pixel this close to where the
  // others' hull projects stays. One voxel of the others' hull, as this
  // camera sees it at the capture volume's centre, is added to it.
  double margin_px = 3;
  // The others' hull is carved at this multiple of the hull's voxel: it
  // only has to say where the subject is, not its exact outline.
  double voxel_scale = 2.0;
  // The others' hull is first moved, by up to this many pixels, to where
  // it best overlaps the mask (a calibration's error moves a camera's
  // picture; the cut then judges the shape, not the offset).
  int search_px = 12;
};

// What agreement did to one camera's mask.
struct MaskAgreement {
  Image8 mask;  // the mask without what the others reject
  // Where the others' hull projects in this camera (255), before the margin.
  Image8 others_hull;
  double margin_px = 0;  // the slack it was given
  // How far the others' hull was moved to overlap the mask best, pixels:
  // this camera's calibration against the others'.
  glm::ivec2 shift{0, 0};
  uint32_t pieces_removed = 0;  // connected pieces of what was cut
  uint64_t pixels_removed = 0;
};

// Where mesh covers camera's picture (255), 0 elsewhere.
Image8 silhouetteOf(const Mesh& mesh, const Camera& camera);

// Each view's mask cut to where the hull of the other views projects,
// grown by the margin: a pixel farther than that from it is a ray that
// meets no other camera's foreground inside the capture volume (a piece
// that touches the subject in the picture, as a prop behind an arm, is cut
// where it leaves the subject). With fewer than three views there is no "others' hull" that
// says anything about a camera, and the masks come back as they are.
// `judged` (by index, default all) names the views whose masks may be
// cut: masks given by the source are the truth and only help judge.
std::vector<MaskAgreement> agreeAcrossCameras(const std::vector<HullView>& views,
                                              const HullOptions& options,
                                              const AgreementOptions& agreement = {},
                                              const std::vector<bool>& judged = {});

}  // namespace holofuse::hull
