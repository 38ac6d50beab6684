#include "capture_parse.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "image/image_io.h"

namespace holofuse::dataset::capture {

Status malformed(const std::string& where, const std::string& what) {
  return Status(StatusCode::kMalformed, where + ": " + what);
}

StatusOr<nlohmann::json> readJson(const fs::path& file) {
  std::ifstream in(file);
  if (!in) return Status(StatusCode::kIoError, file.string() + ": cannot open");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    const size_t at = std::min(e.byte == 0 ? 0 : e.byte - 1, text.size());
    const size_t line =
        1 + static_cast<size_t>(
                std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    const size_t line_start = text.rfind('\n', at == 0 ? 0 : at - 1);
    const size_t column = line_start == std::string::npos ? at + 1 : at - line_start;
    return malformed(file.string() + ":" + std::to_string(line) + ":" + std::to_string(column),
                     "not valid JSON (" + std::string(e.what()) + ")");
  } catch (const nlohmann::json::exception& e) {
    // Well-formed text the parser still refuses: a number past a double's
    // range (found by fuzzing).
    return malformed(file.string(), "not valid JSON (" + std::string(e.what()) + ")");
  }
}

StatusOr<double> number(const nlohmann::json& object, const std::string& key,
                        const std::string& where) {
  if (!object.is_object() || !object.contains(key))
    return malformed(where, "missing \"" + key + "\"");
  if (!object[key].is_number()) return malformed(where + "." + key, "expected a number");
  return object[key].get<double>();
}

StatusOr<std::vector<double>> numbers(const nlohmann::json& value, size_t count,
                                      const std::string& where) {
  std::vector<double> out;
  auto flat = [&](const nlohmann::json& v, auto&& self) -> bool {
    if (v.is_number()) {
      out.push_back(v.get<double>());
      return true;
    }
    if (!v.is_array()) return false;
    for (const auto& e : v) {
      if (!self(e, self)) return false;
    }
    return true;
  };
  if (!flat(value, flat) || out.size() != count) {
    return malformed(where, "expected " + std::to_string(count) + " numbers");
  }
  for (double x : out) {
    if (!std::isfinite(x)) return malformed(where, "holds a value that is not finite");
  }
  return out;
}

Status checkCamera(const Camera& c, const std::string& where) {
  if (c.width == 0 || c.height == 0 || c.width > 16384 || c.height > 16384) {
    return malformed(where, "image size " + std::to_string(c.width) + "x" +
                                std::to_string(c.height) + " outside 1..16384");
  }
  if (!(c.fx > 0) || !(c.fy > 0) || !std::isfinite(c.cx) || !std::isfinite(c.cy) ||
      !std::isfinite(c.skew)) {
    return malformed(where, "focal lengths must be positive and every intrinsic finite");
  }
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(c.translation[k])) return malformed(where, "t is not finite");
  }
  const glm::dmat3 should_be_identity = glm::transpose(c.rotation) * c.rotation;
  double error = std::abs(glm::determinant(c.rotation) - 1.0);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) error += std::abs(should_be_identity[i][j] - (i == j ? 1.0 : 0.0));
  }
  if (!(error < 1e-3)) return malformed(where, "R is not a rotation (orthonormal, determinant 1)");
  return Status::ok();
}

uint32_t imageSide(double value) {
  if (!(value >= 0)) return 0;
  return static_cast<uint32_t>(std::min(value, 16385.0));
}

glm::dmat3 rowMajor(const std::vector<double>& m) {
  glm::dmat3 r;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) r[col][row] = m[static_cast<size_t>(3 * row + col)];
  }
  return r;
}

Status intrinsicsFromK(const std::vector<double>& k, Camera& c, const std::string& where) {
  if (k.size() != 9 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) {
    return malformed(where, "expected K = [[fx, skew, cx], [0, fy, cy], [0, 0, 1]]");
  }
  c.fx = k[0];
  c.skew = k[1];
  c.cx = k[2];
  c.fy = k[4];
  c.cy = k[5];
  return Status::ok();
}

void pixelCentresFromZero(Camera& c) {
  c.cx += 0.5;
  c.cy += 0.5;
}

std::string relativeTo(const fs::path& folder, const std::string& file) {
  const fs::path p(file);
  return p.is_absolute() ? p.string() : (folder / p).lexically_normal().string();
}

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

bool parseDouble(const std::string& text, double& value) {
  char* end = nullptr;
  value = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && std::isfinite(value);
}

StatusOr<std::vector<std::pair<size_t, std::string>>> contentLines(const fs::path& file) {
  std::ifstream in(file);
  if (!in) return Status(StatusCode::kIoError, file.string() + ": cannot open");
  std::vector<std::pair<size_t, std::string>> lines;
  std::string line;
  for (size_t n = 1; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    lines.emplace_back(n, line);
  }
  return lines;
}

bool isImageFile(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" ||
         ext == ".bmp" || ext == ".exr" || ext == ".pgm" || ext == ".ppm";
}

std::vector<fs::path> imagesIn(const fs::path& folder) {
  std::vector<fs::path> out;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_regular_file() && isImageFile(entry.path())) out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end(), [](const fs::path& a, const fs::path& b) {
    return naturalLess(a.filename().string(), b.filename().string());
  });
  return out;
}

StatusOr<std::pair<uint32_t, uint32_t>> imageSize(const fs::path& file) {
  if (const auto frame = parseVideoFrameName(file.string())) {
    cv::VideoCapture reader(frame->video);
    const double w = reader.isOpened() ? reader.get(cv::CAP_PROP_FRAME_WIDTH) : 0.0,
                 h = reader.isOpened() ? reader.get(cv::CAP_PROP_FRAME_HEIGHT) : 0.0;
    if (!(w >= 1 && h >= 1))
      return Status(StatusCode::kIoError, frame->video + ": cannot read the video");
    return std::make_pair(imageSide(w), imageSide(h));
  }
  return readImageSize(file.string());
}

std::optional<std::string> maskFor(const fs::path& image,
                                   const std::vector<fs::path>& mask_folders) {
  const std::string name = image.filename().string(), stem = image.stem().string();
  for (const fs::path& folder : mask_folders) {
    for (const std::string& candidate : {name, stem + ".png", name + ".png"}) {
      const fs::path mask = folder / candidate;
      if (fs::is_regular_file(mask)) return mask.string();
    }
  }
  return std::nullopt;
}

CameraImages videoImages(const std::string& video, const std::optional<std::string>& mask_video) {
  // Every frame's time stamp, by demuxing the whole video once (a
  // container's frame count is an estimate); a frame that will not decode
  // is named at import.
  CameraImages out;
  cv::VideoCapture reader(video);
  if (reader.isOpened()) out.stated_fps = reader.get(cv::CAP_PROP_FPS);
  while (reader.isOpened() && reader.grab())
    out.times_s.push_back(reader.get(cv::CAP_PROP_POS_MSEC) / 1000.0);
  for (size_t f = 0; f < out.times_s.size(); ++f) {
    out.images.push_back(videoFrameName(video, f));
    out.masks.push_back(mask_video ? std::optional(videoFrameName(*mask_video, f)) : std::nullopt);
  }
  return out;
}

CameraImages cameraImages(const fs::path& root, const std::string& name,
                          const std::vector<fs::path>& mask_roots) {
  CameraImages out;
  if (fs::is_directory(root / name)) {
    std::vector<fs::path> mask_folders;
    for (const fs::path& m : mask_roots) mask_folders.push_back(m / name);
    for (const fs::path& image : imagesIn(root / name)) {
      out.images.push_back(image.string());
      out.masks.push_back(maskFor(image, mask_folders));
    }
    return out;
  }
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(root, error)) {
    const fs::path& video = entry.path();
    if (!entry.is_regular_file() || video.stem().string() != name || !isVideoFile(video.string()))
      continue;
    std::optional<std::string> mask_video;
    for (const fs::path& m : mask_roots) {
      const fs::path candidate = m / video.filename();
      if (fs::is_regular_file(candidate)) mask_video = candidate.string();
    }
    out = videoImages(video.string(), mask_video);
    return out;
  }
  for (const fs::path& image : imagesIn(root)) {
    if (image.stem().string() != name) continue;
    out.images.push_back(image.string());
    out.masks.push_back(maskFor(image, mask_roots));
    break;
  }
  return out;
}

namespace {

StatusOr<std::vector<CaptureFrame>> framesByIndex(const std::vector<CaptureCamera>& cameras,
                                                  const std::vector<CameraImages>& images,
                                                  const std::string& where) {
  const size_t count = images[0].images.size();
  for (size_t c = 0; c < cameras.size(); ++c) {
    if (images[c].images.size() != count) {
      return malformed(where, "camera \"" + cameras[c].name + "\" has " +
                                  std::to_string(images[c].images.size()) + " frames, camera \"" +
                                  cameras[0].name + "\" has " + std::to_string(count) +
                                  " (frames are matched by index)");
    }
  }
  std::vector<CaptureFrame> frames(count);
  for (size_t f = 0; f < count; ++f) {
    for (size_t c = 0; c < cameras.size(); ++c) {
      frames[f].images.push_back(images[c].images[f]);
      frames[f].masks.push_back(images[c].masks[f]);
    }
  }
  return frames;
}

// The median gap between a video's frames; 0 for fewer than two.
double frameInterval(const std::vector<double>& times) {
  if (times.size() < 2) return 0.0;
  std::vector<double> gaps;
  for (size_t f = 1; f < times.size(); ++f) gaps.push_back(times[f] - times[f - 1]);
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2),
                   gaps.end());
  return gaps[gaps.size() / 2];
}

std::string seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f s", s);
  return text;
}

StatusOr<MatchedFrames> framesByTime(const std::vector<CaptureCamera>& cameras,
                                     const std::vector<CameraImages>& images,
                                     const std::string& where) {
  size_t slowest = 0;
  for (size_t c = 1; c < cameras.size(); ++c) {
    if (frameInterval(images[c].times_s) > frameInterval(images[slowest].times_s)) slowest = c;
  }
  const std::vector<double>& times = images[slowest].times_s;
  const double interval = frameInterval(times);
  // With one frame each there is nothing to match but the one.
  const double tolerance = interval > 0 ? interval / 2 : std::numeric_limits<double>::infinity();
  MatchedFrames out;
  // The stated rate where the container has one: its time stamps are
  // rounded (Matroska's to milliseconds).
  const double stated = images[slowest].stated_fps;
  if (stated > 0 && stated <= 1000) {
    out.fps = stated;
  } else if (interval > 0) {
    out.fps = 1.0 / interval;
  }
  std::vector<std::string> dropped;
  for (const double t : times) {
    CaptureFrame frame;
    for (size_t c = 0; c < cameras.size(); ++c) {
      const std::vector<double>& own = images[c].times_s;
      const auto after = std::lower_bound(own.begin(), own.end(), t);
      size_t nearest = static_cast<size_t>(after - own.begin());
      if (after == own.end() || (after != own.begin() && t - *(after - 1) < *after - t)) --nearest;
      if (std::abs(own[nearest] - t) > tolerance) {
        if (dropped.size() < 3) {
          dropped.push_back(seconds(t) + " (camera \"" + cameras[c].name + "\", " +
                            parseVideoFrameName(images[c].images[0])->video +
                            ", has no frame within " + seconds(tolerance) + ")");
        } else if (dropped.size() == 3) {
          dropped.push_back("...");
        }
        frame.images.clear();
        break;
      }
      frame.images.push_back(images[c].images[nearest]);
      frame.masks.push_back(images[c].masks[nearest]);
    }
    if (!frame.images.empty()) out.frames.push_back(std::move(frame));
  }
  if (out.frames.empty()) {
    return malformed(where, "no time of camera \"" + cameras[slowest].name +
                                "\"'s video has a frame of every other camera within " +
                                seconds(tolerance) + ": " + dropped.front());
  }
  out.matching = "frames matched by the videos' timestamps to camera \"" + cameras[slowest].name +
                 "\"'s" +
                 (out.fps ? " (" + std::to_string(static_cast<int>(std::lround(*out.fps))) + " fps)"
                          : std::string());
  const size_t lost = times.size() - out.frames.size();
  if (lost > 0) {
    out.matching += "; " + std::to_string(lost) + " of its " + std::to_string(times.size()) +
                    " times dropped, where a camera has no frame: ";
    for (size_t k = 0; k < dropped.size(); ++k) out.matching += (k ? ", " : "") + dropped[k];
  }
  return out;
}

}  // namespace

StatusOr<MatchedFrames> matchFrames(const std::vector<CaptureCamera>& cameras,
                                    const std::vector<CameraImages>& images,
                                    const std::string& where) {
  if (cameras.empty()) return malformed(where, "holds no camera");
  bool videos = true;
  for (size_t c = 0; c < cameras.size(); ++c) {
    if (images[c].images.empty()) {
      return malformed(where, "camera \"" + cameras[c].name + "\" has no image");
    }
    videos = videos && images[c].times_s.size() == images[c].images.size();
  }
  if (videos) return framesByTime(cameras, images, where);
  auto frames = framesByIndex(cameras, images, where);
  if (!frames.isOk()) return frames.status();
  return MatchedFrames{std::move(*frames), "frames matched by index", std::nullopt};
}

}  // namespace holofuse::dataset::capture
