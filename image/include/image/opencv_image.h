// Image8 seen as a cv::Mat (no copy) and back, for the OpenCV code of the
// segmentation and the importers.
#pragma once

#include <opencv2/core.hpp>

#include "image/image.h"

namespace holofuse {

// The image's own pixels; writing through the Mat writes the image.
inline cv::Mat wrap(Image8& image) {
  return cv::Mat(static_cast<int>(image.height), static_cast<int>(image.width),
                 CV_8UC(static_cast<int>(image.channels)), image.pixels.data());
}

// For reading only: OpenCV has no const Mat header over foreign memory.
inline cv::Mat wrapForReading(const Image8& image) { return wrap(const_cast<Image8&>(image)); }

// A copy of an 8-bit Mat of 1 to 4 channels.
inline Image8 fromMat(const cv::Mat& m) {
  Image8 out(static_cast<uint32_t>(m.cols), static_cast<uint32_t>(m.rows),
             static_cast<uint32_t>(m.channels()));
  cv::Mat target = wrap(out);
  m.copyTo(target);
  return out;
}

}  // namespace holofuse
