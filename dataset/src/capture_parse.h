// What every capture reader shares: messages that name the file and line
// or JSON path, checked numbers and cameras, and the layouts of images on
// disk (one image per camera, or one folder of frames per camera, with
// masks in a folder beside). Private to dataset/src.
#pragma once

#include <array>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "base/status.h"
#include "dataset/capture_formats.h"

namespace holofuse::dataset::capture {

namespace fs = std::filesystem;

Status malformed(const std::string& where, const std::string& what);

// JSON from a file; a syntax error is named with its line and column.
StatusOr<nlohmann::json> readJson(const fs::path& file);

// A number at a JSON path, or a message naming the path.
StatusOr<double> number(const nlohmann::json& object, const std::string& key,
                        const std::string& where);
// `count` finite numbers from a JSON value, nested arrays flattened.
StatusOr<std::vector<double>> numbers(const nlohmann::json& value, size_t count,
                                      const std::string& where);

// Image size in 1..16384, positive focal lengths, finite intrinsics, R a
// rotation (orthonormal, determinant +1).
Status checkCamera(const Camera& c, const std::string& where);

// An image side from an untrusted number: out-of-range values become 0 or
// 16385 (refused by checkCamera) instead of an undefined conversion.
uint32_t imageSide(double value);

glm::dmat3 rowMajor(const std::vector<double>& m);

// fx, skew, cx, fy, cy from a row-major K, which must be upper triangular
// with K33 = 1.
Status intrinsicsFromK(const std::vector<double>& k, Camera& c, const std::string& where);

// Calibrations made with OpenCV (and most rigs' own tools) put the centre
// of the first pixel at 0; holofuse, like COLMAP, at 0.5.
void pixelCentresFromZero(Camera& c);

std::string relativeTo(const fs::path& folder, const std::string& file);

std::vector<std::string> words(const std::string& line);
bool parseDouble(const std::string& text, double& value);

// The lines of a text file that are neither blank nor '#' comments, with
// their line numbers from 1.
StatusOr<std::vector<std::pair<size_t, std::string>>> contentLines(const fs::path& file);

bool isImageFile(const fs::path& file);

// The image files of a folder in natural name order.
std::vector<fs::path> imagesIn(const fs::path& folder);

// Width and height from an image file's header.
StatusOr<std::pair<uint32_t, uint32_t>> imageSize(const fs::path& file);

// One camera's images, one per frame, and the mask of each where one is
// stored.
struct CameraImages {
  std::vector<std::string> images;
  std::vector<std::optional<std::string>> masks;
  // A video's frames: each one's presentation time in seconds, as the
  // container stamps it; empty for image files.
  std::vector<double> times_s;
  double stated_fps = 0;  // the video's frame rate as its container states it; 0: none
};

// The mask of `image` in any of `mask_folders`: the same file name, the
// same stem as PNG, or COLMAP's `<image name>.png`.
std::optional<std::string> maskFor(const fs::path& image,
                                   const std::vector<fs::path>& mask_folders);

// A video's frames (masks the frames of mask_video, when given), each with
// its time stamp; empty when the video cannot be read.
CameraImages videoImages(const std::string& video, const std::optional<std::string>& mask_video);

// A camera's images under `root`: the folder root/<name>/ of frames (masks
// in <mask root>/<name>/), a video root/<name>.mp4 (or .avi, .mkv, .mov,
// .webm; masks a video of the same name in a mask root), or one image
// root/<name>.<ext> (masks in the mask roots); empty when there is none.
CameraImages cameraImages(const fs::path& root, const std::string& name,
                          const std::vector<fs::path>& mask_roots);

// The capture's frames from each camera's images, and how they were
// matched (CaptureDescription::frame_matching). Where every camera is a
// video, by the videos' timestamps: the frames of the camera with the
// lowest rate set the times, each other camera contributes its frame
// nearest in time, and a time where some camera has none within half a
// frame interval is dropped and reported by camera and video; the
// capture's rate is that camera's. Otherwise by index: every camera must
// hold the same number, or the message names the camera that differs.
struct MatchedFrames {
  std::vector<CaptureFrame> frames;
  std::string matching;
  std::optional<double> fps;
};
StatusOr<MatchedFrames> matchFrames(const std::vector<CaptureCamera>& cameras,
                                    const std::vector<CameraImages>& images,
                                    const std::string& where);

}  // namespace holofuse::dataset::capture
