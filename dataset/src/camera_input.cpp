#include "dataset/camera_input.h"

#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "image/image_io.h"
#include "image/opencv_image.h"
#include "picture_reading.h"

namespace holofuse::dataset {

namespace fs = std::filesystem;

namespace {

// The videos an import reads, each open at the frame it reads next: the
// import goes through each camera's frames in order, so each read is the
// next one and seeks are rare.
class VideoFrames {
 public:
  StatusOr<cv::Mat> read(const VideoFrameName& frame, const char* what) {
    auto& open = open_[frame.video];
    if (!open.reader.isOpened()) {
      if (!fs::exists(frame.video))
        return Status(StatusCode::kIoError, frame.video + ": " + what + " video is missing");
      if (!open.reader.open(frame.video))
        return Status(StatusCode::kMalformed, frame.video + ": cannot open the " + what + " video");
      open.next = 0;
    }
    if (open.next != frame.index)
      open.reader.set(cv::CAP_PROP_POS_FRAMES, static_cast<double>(frame.index));
    cv::Mat m;
    if (!open.reader.read(m) || m.empty()) {
      return Status(StatusCode::kMalformed, frame.video + ": frame " + std::to_string(frame.index) +
                                                " of the " + what + " video cannot be decoded");
    }
    open.next = frame.index + 1;
    return m;
  }
  void close() { open_.clear(); }

 private:
  struct Open {
    cv::VideoCapture reader;
    size_t next = 0;
  };
  std::map<std::string, Open> open_;
};

VideoFrames& videoFrames() {
  static VideoFrames frames;
  return frames;
}

}  // namespace

StatusOr<cv::Mat> readAny(const std::string& file, const Camera& camera, const char* what) {
  cv::Mat m;
  if (const auto frame = parseVideoFrameName(file)) {
    auto decoded = videoFrames().read(*frame, what);
    if (!decoded.isOk()) return decoded.status();
    if (decoded->channels() == 3) cv::cvtColor(*decoded, *decoded, cv::COLOR_BGR2RGB);
    decoded->convertTo(m, CV_32F, decoded->depth() == CV_16U ? 1.0 / 65535.0 : 1.0 / 255.0);
  } else {
    if (!fs::exists(file))
      return Status(StatusCode::kIoError, file + ": " + what + " file is missing");
    auto stored = readImageValues(file);
    if (!stored.isOk()) {
      std::string reason = stored.status().message();  // "<file>: <why>"
      if (reason.rfind(file + ": ", 0) == 0) reason.erase(0, file.size() + 2);
      return Status(StatusCode::kMalformed,
                    file + ": cannot decode the " + std::string(what) + " (" + reason + ")");
    }
    if (stored->channels > 4) {
      return Status(StatusCode::kMalformed, file + ": " + std::to_string(stored->channels) +
                                                " channels (grey, RGB or RGBA are read)");
    }
    m = cv::Mat(static_cast<int>(stored->height), static_cast<int>(stored->width),
                CV_32FC(static_cast<int>(stored->channels)), stored->values.data())
            .clone();
  }
  if (m.empty())
    return Status(StatusCode::kMalformed, file + ": cannot decode the " + std::string(what));
  if (m.cols != static_cast<int>(camera.width) || m.rows != static_cast<int>(camera.height)) {
    return Status(StatusCode::kMalformed,
                  file + ": the " + std::string(what) + " is " + std::to_string(m.cols) + "x" +
                      std::to_string(m.rows) + ", the calibration of camera " +
                      std::to_string(camera.id) + " says " + std::to_string(camera.width) + "x" +
                      std::to_string(camera.height));
  }
  return m;
}

void closeVideos() { videoFrames().close(); }

cv::Mat toEightBit(const cv::Mat& values) {
  cv::Mat out;
  values.convertTo(out, CV_8U, 255.0);
  return out;
}

std::optional<Undistortion> Undistortion::of(const Camera& c) {
  bool any = false;
  for (double k : c.distortion) any = any || k != 0.0;
  if (!any) return std::nullopt;
  Camera pinhole = c;
  pinhole.distortion.clear();
  Undistortion u;
  u.width_ = c.width;
  u.height_ = c.height;
  u.map_x_.resize(static_cast<size_t>(c.width) * c.height);
  u.map_y_.resize(u.map_x_.size());
  // A point on the ray through each destination pixel centre, projected
  // with the distortion: the source position.
  for (uint32_t y = 0; y < c.height; ++y) {
    for (uint32_t x = 0; x < c.width; ++x) {
      const glm::dvec3 world = pinhole.center() + pinhole.rayDirection(x + 0.5, y + 0.5);
      const auto p = c.project(world);
      const size_t i = static_cast<size_t>(y) * c.width + x;
      u.map_x_[i] = p ? static_cast<float>(p->x - 0.5) : -1.0f;
      u.map_y_[i] = p ? static_cast<float>(p->y - 0.5) : -1.0f;
    }
  }
  return u;
}

Image8 Undistortion::apply(const Image8& image, bool nearest) const {
  const cv::Mat map_x(static_cast<int>(height_), static_cast<int>(width_), CV_32FC1,
                      const_cast<float*>(map_x_.data()));
  const cv::Mat map_y(static_cast<int>(height_), static_cast<int>(width_), CV_32FC1,
                      const_cast<float*>(map_y_.data()));
  cv::Mat out;
  cv::remap(wrapForReading(image), out, map_x, map_y,
            nearest ? cv::INTER_NEAREST : cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
  return fromMat(out);
}

SegmentationOptions realCameraSegmentation() {
  SegmentationOptions options;
  options.noise = 4;
  return options;
}

StatusOr<BackgroundModel> readPlate(const std::string& file, const CaptureCamera& camera,
                                    const std::optional<Undistortion>& undistort) {
  const SegmentationOptions options = realCameraSegmentation();
  auto asRgb = [&](cv::Mat values) {
    if (values.channels() == 1) cv::cvtColor(values, values, cv::COLOR_GRAY2RGB);
    if (values.channels() == 4) cv::cvtColor(values, values, cv::COLOR_RGBA2RGB);
    Image8 rgb = fromMat(toEightBit(values));
    return undistort ? undistort->apply(rgb) : rgb;
  };
  const std::string who = "the plate of camera \"" + camera.name + "\"";
  if (!isVideoFile(file)) {
    auto still = readAny(file, camera.camera, "plate");
    if (!still.isOk()) return Status(still.status().code(), who + ": " + still.status().message());
    return BackgroundModel(asRgb(*still), options);
  }
  if (!fs::exists(file)) return Status(StatusCode::kIoError, file + ": " + who + " is missing");
  std::vector<Image8> frames;
  for (size_t f = 0; f < kMostPlateFrames; ++f) {
    const std::string name = videoFrameName(file, f);
    auto frame = readAny(name, camera.camera, "plate");
    if (!frame.isOk()) {
      // The end of the video, or a frame that is wrong.
      if (frame.status().message().find("the plate is ") != std::string::npos)
        return Status(frame.status().code(), who + ": " + frame.status().message());
      break;
    }
    frames.push_back(asRgb(*frame));
  }
  if (frames.size() < kFewestPlateFrames) {
    return Status(StatusCode::kMalformed,
                  file + ": " + who + " is a video of " + std::to_string(frames.size()) +
                      " frames; a plate video needs at least " +
                      std::to_string(kFewestPlateFrames) + " (or give a still picture)");
  }
  auto model = BackgroundModel::fromFrames(frames, options);
  if (!model.isOk()) return Status(model.status().code(), who + ": " + model.status().message());
  return model;
}

}  // namespace holofuse::dataset
