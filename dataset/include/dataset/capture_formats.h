// Readers of real multi-view captures on disk: the holofuse capture JSON,
// COLMAP models (text or binary), NeRF-style transforms.json, OpenCV
// FileStorage calibrations, 3x4 projection matrices, Middlebury's
// *_par.txt and CMU Panoptic's calibration JSON. Each turns a folder into
// a CaptureDescription (cameras in OpenCV axes, world to camera, pixel
// centres at +0.5, and the image and mask files of every frame); a
// malformed file is named with its line (text), byte (binary) or JSON
// path.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "geometry/camera.h"

namespace holofuse::dataset {

struct CaptureCamera {
  std::string name;  // as the source names it (pod ids follow natural name order)
  Camera camera;     // id = pod id; distortion as given (the import undistorts)
  std::optional<std::string> background;  // a plate of the empty scene, if given
  std::string split;  // the source's split ("train", "val", "test"), if it has them
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
  // How the cameras' images were paired into frames, for the person
  // importing: by index, or by the videos' timestamps with what was
  // dropped; empty for formats that list their frames.
  std::string frame_matching;
};

enum class CaptureFormat {
  kHolofuse,
  kColmap,
  kNerf,
  kOpencv,
  kProjections,
  kMiddlebury,
  kPanoptic
};
// "holofuse", "colmap", "nerf", "opencv", "projections", "middlebury",
// "panoptic"; nullopt for anything else.
std::optional<CaptureFormat> captureFormatFromName(const std::string& name);
const char* captureFormatNames();  // the names above, comma separated

// A frame of a video file as a CaptureFrame names it: "<video>#<index>"
// (0-based); the import decodes it with OpenCV's video reader (FFmpeg).
std::string videoFrameName(const std::string& video, size_t index);
struct VideoFrameName {
  std::string video;
  size_t index = 0;
};
// nullopt for a name that is not a video file's frame.
std::optional<VideoFrameName> parseVideoFrameName(const std::string& name);
bool isVideoFile(const std::string& path);  // by extension: mp4, avi, mkv, mov, webm

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

// COLMAP: cameras.txt and images.txt, or cameras.bin and images.bin, at
// the root, in sparse/ or in sparse/0/; images in images/, masks (when
// present) in masks/<image name>.png with zero meaning background. One
// frame.
StatusOr<CaptureDescription> readColmapCapture(const std::string& folder);

// transforms.json (instant-ngp / nerfstudio / Blender): camera-to-world
// matrices in OpenGL axes (x right, y up, z backwards), converted here to
// OpenCV's (x right, y down, z forwards); intrinsics from fl_x/fl_y/cx/cy
// or camera_angle_x. Each frame entry is one camera of a static capture.
StatusOr<CaptureDescription> readNerfCapture(const std::string& folder);

// OpenCV FileStorage (YAML, XML or JSON), in either layout rigs use:
// intri.yml and extri.yml (EasyMocap, ZJU-MoCap: "names", then K_<name>,
// dist_<name>, and Rot_<name> or the Rodrigues R_<name>, T_<name>), or one
// file per camera (camera_matrix, distortion_coefficients, R, T, optional
// image_width and image_height). Images in images/<name>/ (one per frame)
// or images/<name>.<ext>; masks likewise under masks/, mask/ or
// mask_cihp/.
StatusOr<CaptureDescription> readOpencvCapture(const std::string& folder);

// One 3x4 projection matrix P per image (the ETH course's `.pa`, `.P`, DTU's
// pos_NNN.txt), decomposed into K, R and t; pixel = (u/w, v/w) with the
// first pixel's centre at 0. Images beside the matrices or in images/,
// with the matrix file's stem or, for pos_NNN, the one image numbered NNN.
StatusOr<CaptureDescription> readProjectionCapture(const std::string& folder);

// Middlebury multi-view's <name>_par.txt: a count, then per image its file
// name, K (9 numbers), R (9) and t (3); images beside it.
StatusOr<CaptureDescription> readMiddleburyCapture(const std::string& folder);

// CMU Panoptic's calibration_<sequence>.json: per camera its name, type,
// resolution, K, distCoef, R and t. Cameras whose images are present
// (<type>Imgs/<name>/, one per frame, or images/<name>/) are kept.
StatusOr<CaptureDescription> readPanopticCapture(const std::string& folder);

// P = K [R | t] from a row-major 3x4 P by RQ decomposition of its left 3x3
// (Hartley and Zisserman, "Multiple View Geometry", 2004, section 6.2.4):
// K upper triangular with positive focal lengths and K33 = 1, R a
// rotation (determinant +1); P's scale and sign are free, so a P with a
// negative scale is negated first. Refused, naming `where`: a value that
// is not finite, or a singular left 3x3. Width and height are left 0.
StatusOr<Camera> cameraFromProjection(const std::array<double, 12>& p, const std::string& where);

StatusOr<CaptureDescription> readCapture(const std::string& folder, CaptureFormat format);

}  // namespace holofuse::dataset
