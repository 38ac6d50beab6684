// Readers of real multi-view captures on disk: the holofuse capture JSON,
// COLMAP text models and NeRF-style transforms.json. Each turns a folder
// into a CaptureDescription (cameras in OpenCV axes, world to camera, and
// the image and mask files of every frame) without reading any image; a
// malformed file is named with its line (text) or JSON path.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "common/camera.h"

namespace holofuse::dataset {

struct CaptureCamera {
  std::string name;  // as the source names it (pod ids follow natural name order)
  Camera camera;     // id = pod id; distortion as given (the import undistorts)
  std::optional<std::string> background;  // a plate of the empty scene, if given
};

struct CaptureFrame {
  // Per camera, in CaptureDescription::cameras order.
  std::vector<std::string> images;
  std::vector<std::optional<std::string>> masks;
};

struct CaptureDescription {
  std::string source;  // "colmap /path" and so on, for the dataset's metadata
  std::vector<CaptureCamera> cameras;
  std::vector<CaptureFrame> frames;
  double fps = 10.0;
};

enum class CaptureFormat { kHolofuse, kColmap, kNerf };
// "holofuse", "colmap", "nerf"; nullopt for anything else.
std::optional<CaptureFormat> captureFormatFromName(const std::string& name);
const char* captureFormatNames();  // "holofuse, colmap, nerf"

// Natural order: digit runs compare as numbers ("cam2" < "cam10").
bool naturalLess(const std::string& a, const std::string& b);

// Sorts cameras by natural name order and numbers them 0..N-1 (frames
// follow).
void numberCamerasByName(CaptureDescription& description);

// The capture without the cameras named (by their names in the source),
// the rest numbered 0..N-1 in their order; an error names a camera the
// capture does not have, and lists those it has.
StatusOr<CaptureDescription> withoutCameras(const CaptureDescription& description,
                                            const std::vector<std::string>& names);

// The holofuse capture JSON (docs/datasets.md, "Import real captures"): per camera K,
// distortion, R, t, image size; per frame the image (and optional mask)
// file of each camera.
StatusOr<CaptureDescription> readHolofuseCapture(const std::string& folder);

// COLMAP text: cameras.txt and images.txt at the root, in sparse/ or in
// sparse/0/; images in images/, masks (when present) in masks/<image
// name>.png with zero meaning background. One frame.
StatusOr<CaptureDescription> readColmapCapture(const std::string& folder);

// transforms.json (instant-ngp / nerfstudio / Blender): camera-to-world
// matrices in OpenGL axes (x right, y up, z backwards), converted here to
// OpenCV's (x right, y down, z forwards); intrinsics from fl_x/fl_y/cx/cy
// or camera_angle_x. Each frame entry is one camera of a static capture.
StatusOr<CaptureDescription> readNerfCapture(const std::string& folder);

StatusOr<CaptureDescription> readCapture(const std::string& folder, CaptureFormat format);

}  // namespace holofuse::dataset
