// Whether each camera of a capture agrees with the rest: how much of its
// frame its mask covers, how well its mask matches the silhouette of the
// hull carved from the other cameras alone, and how well the other
// cameras' masks match that hull. A camera whose mask is too large
// (stored through a lossy step) carves nothing and disagrees with the
// others' hull; one whose mask is too small or misplaced carves away what
// the others see, so that without it they agree far better. Either spoils
// every view; this names it, so that a person looks at it, or leaves it
// out at import (--exclude-cameras).
#pragma once

#include <string>
#include <vector>

#include "hull/visual_hull.h"
#include "metrics/health_over_time.h"

namespace holofuse::dataset {

struct CameraHealth {
  double coverage = 0;  // share of the frame inside the mask
  // IoU of the mask with the silhouette of the hull carved from every other
  // camera; negative: not measured (fewer than 3 cameras).
  double agreement = -1;
  // Mean IoU of every other camera's mask with that same hull (carved
  // without this camera); negative: not measured.
  double others_agreement = -1;
  std::string concern;  // empty, or what sets the camera apart from the rest
};

// A mask covering at least this share of its frame carves nothing.
inline constexpr double kFullFrameCoverage = 0.9;
// Agreement this far below the cameras' median, or the others' agreement
// without a camera this far above theirs, sets the camera apart.
inline constexpr double kAgreementGap = 0.25;

// One entry per view, in views' order; the hulls carved with options.
std::vector<CameraHealth> cameraHealth(const std::vector<hull::HullView>& views,
                                       const hull::HullOptions& options);

// Summarises each frame's health (frame_ids[k]: per_frame[k], cameraHealth
// of that frame) into each camera's min and median agreement, the frames
// where it was set apart from the rest, and a concern.
HealthOverTime summariseHealthOverTime(const std::vector<uint64_t>& frame_ids,
                                       const std::vector<std::vector<CameraHealth>>& per_frame);

// The table for people, and a CHECK line per camera set apart.
std::string healthOverTimeText(const std::vector<std::string>& names, const HealthOverTime& health,
                               size_t frames_in_dataset);

// A table of the cameras' health for people (names in views' order), then
// one line per camera with a concern, saying what to do about it.
std::string cameraHealthText(const std::vector<std::string>& names,
                             const std::vector<CameraHealth>& health,
                             const std::string& inspect_command);

}  // namespace holofuse::dataset
