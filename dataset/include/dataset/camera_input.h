// A real camera's pictures before segmentation, the same in the import and
// in a live camera pod: its lens distortion undone to the pinhole the
// loop works with, and its plate (the empty room) read as a background
// model.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "dataset/capture_formats.h"
#include "geometry/camera.h"
#include "image/image.h"
#include "segmentation/segmentation.h"

namespace holofuse::dataset {

// Pinhole remap: for each pixel of the undistorted image (same K, skew
// included), where Camera::project's distortion model puts it in the
// source.
class Undistortion {
 public:
  // nullopt for a camera without distortion.
  static std::optional<Undistortion> of(const Camera& camera);
  // Colour bilinear; masks nearest.
  Image8 apply(const Image8& image, bool nearest = false) const;

 private:
  uint32_t width_ = 0, height_ = 0;
  std::vector<float> map_x_, map_y_;
};

// The fewest frames a plate video needs, and the most it is learnt from.
inline constexpr size_t kFewestPlateFrames = 3, kMostPlateFrames = 60;

// A camera's plate as a background model: a still picture, or the frames
// of a plate video (each undistorted). An error names the camera and what
// is wrong (missing, another size than its calibration, too short).
StatusOr<BackgroundModel> readPlate(const std::string& file, const CaptureCamera& camera,
                                    const std::optional<Undistortion>& undistort);

// The segmentation options for real sensors: JPEG blocks and real noise
// need a higher floor than the synthetic pods.
SegmentationOptions realCameraSegmentation();

}  // namespace holofuse::dataset
