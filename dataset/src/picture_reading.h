// Pictures and video frames as the import and the camera pod read them:
// float values in [0, 1], R, G, B(, A) order, checked against the camera's
// size (private to holofuse_dataset_tools).
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "base/status.h"
#include "geometry/camera.h"

namespace holofuse::dataset {

// A picture file (through OpenImageIO: 8- or 16-bit PNG, TIFF, JPEG,
// OpenEXR...) or a video frame ("<video>#<index>"); `what` names it in
// errors ("image", "mask", "plate").
StatusOr<cv::Mat> readAny(const std::string& file, const Camera& camera, const char* what);

// Closes the videos readAny opened.
void closeVideos();

// Float values in [0, 1] as 8-bit, rounded.
cv::Mat toEightBit(const cv::Mat& values);

}  // namespace holofuse::dataset
