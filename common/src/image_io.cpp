#include "common/image_io.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace holofuse {

Status writePng(const std::string& path, const Image8& image) {
  if (image.empty() || (image.channels != 1 && image.channels != 3 && image.channels != 4)) {
    return {StatusCode::kMalformed,
            path + ": cannot write an image with " + std::to_string(image.channels) + " channels"};
  }
  const cv::Mat mat(static_cast<int>(image.height), static_cast<int>(image.width),
                    CV_8UC(image.channels), const_cast<uint8_t*>(image.pixels.data()));
  // OpenCV stores blue first. The reordered copy gets its own storage: an
  // output Mat that shares the caller's pixels would be swapped in place.
  cv::Mat ordered;
  if (image.channels == 1) ordered = mat;
  if (image.channels == 3) cv::cvtColor(mat, ordered, cv::COLOR_RGB2BGR);
  if (image.channels == 4) cv::cvtColor(mat, ordered, cv::COLOR_RGBA2BGRA);
  bool written = false;
  try {
    written = cv::imwrite(path, ordered, {cv::IMWRITE_PNG_COMPRESSION, 1});
  } catch (const cv::Exception& e) {
    return {StatusCode::kIoError, path + ": " + e.what()};
  }
  if (!written) return {StatusCode::kIoError, path + ": could not be written"};
  return Status::ok();
}

StatusOr<Image8> readPng(const std::string& path) {
  cv::Mat stored;
  try {
    stored = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return Status(StatusCode::kIoError, path + ": " + e.what());
  }
  if (stored.empty()) return Status(StatusCode::kIoError, path + ": missing, or not an image");
  if (stored.depth() != CV_8U || stored.channels() == 2 || stored.channels() > 4) {
    return Status(StatusCode::kMalformed, path + ": not an 8-bit grey, RGB or RGBA image");
  }
  cv::Mat ordered;
  if (stored.channels() == 1) ordered = stored;
  if (stored.channels() == 3) cv::cvtColor(stored, ordered, cv::COLOR_BGR2RGB);
  if (stored.channels() == 4) cv::cvtColor(stored, ordered, cv::COLOR_BGRA2RGBA);
  Image8 image(static_cast<uint32_t>(ordered.cols), static_cast<uint32_t>(ordered.rows),
               static_cast<uint32_t>(ordered.channels()));
  cv::Mat target(ordered.rows, ordered.cols, ordered.type(), image.pixels.data());
  ordered.copyTo(target);
  return image;
}

}  // namespace holofuse
