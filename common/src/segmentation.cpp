#include "common/segmentation.h"

#include <opencv2/imgproc.hpp>

#include "common/opencv_image.h"

namespace holofuse {

Image8 segmentForeground(const Image8& frame, const Image8& plate,
                         const SegmentationOptions& options) {
  Image8 mask(frame.width, frame.height, 1);
  cv::Mat diff;
  cv::absdiff(wrapForReading(frame), wrapForReading(plate), diff);
  cv::Mat total;
  cv::transform(diff, total, cv::Matx13f(1, 1, 1));
  cv::Mat out = wrap(mask);
  cv::threshold(total, total, options.threshold, 255, cv::THRESH_BINARY);
  total.convertTo(out, CV_8U);
  if (options.cleanup_radius > 0) {
    const int k = 2 * options.cleanup_radius + 1;
    const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k));
    cv::morphologyEx(out, out, cv::MORPH_OPEN, kernel);
    cv::morphologyEx(out, out, cv::MORPH_CLOSE, kernel);
  }
  return mask;
}

Image8 featherMap(const Image8& mask) {
  Image8 feather(mask.width, mask.height, 1);
  cv::Mat distance;
  cv::distanceTransform(wrapForReading(mask), distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  distance.convertTo(wrap(feather), CV_8U);  // saturates at 255
  return feather;
}

}  // namespace holofuse
