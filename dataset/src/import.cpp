#include "dataset/import.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "codec/pod_frame_codec.h"
#include "dataset/camera_input.h"
#include "dataset/dataset.h"
#include "dataset/metadata.h"
#include "dataset/record_file.h"
#include "hull/mask_agreement.h"
#include "image/image_io.h"
#include "image/opencv_image.h"
#include "picture_reading.h"
#include "protocol/connection.h"
#include "protocol/messages.h"
#include "segmentation/segmentation.h"

namespace holofuse::dataset {

namespace fs = std::filesystem;

namespace {

// An image file as 8-bit RGB, and its alpha as a mask when it has one.
struct LoadedImage {
  Image8 color;
  std::optional<Image8> alpha_mask;
};

// The subject where value (one channel in [0, 1]) is above threshold,
// without the specks a noisy background leaves: components under 1% of
// the largest.
cv::Mat binaryMask(const cv::Mat& value, double threshold) {
  cv::Mat mask;
  cv::threshold(value, mask, threshold, 255, cv::THRESH_BINARY);
  mask.convertTo(mask, CV_8U);
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8);
  int largest = 0;
  for (int k = 1; k < count; ++k) largest = std::max(largest, stats.at<int>(k, cv::CC_STAT_AREA));
  for (int k = 1; k < count; ++k) {
    if (stats.at<int>(k, cv::CC_STAT_AREA) * 100 < largest) mask.setTo(0, labels == k);
  }
  return mask;
}

StatusOr<LoadedImage> readColor(const std::string& file, const Camera& camera,
                                double mask_threshold) {
  auto m = readAny(file, camera, "image");
  if (!m.isOk()) return m.status();
  LoadedImage out;
  cv::Mat rgb;
  switch (m->channels()) {
    case 1:
      cv::cvtColor(*m, rgb, cv::COLOR_GRAY2RGB);
      break;
    case 3:
      rgb = *m;
      break;
    case 4: {
      // RGBA (NeRF's synthetic sets): alpha is the mask, colour over black.
      std::vector<cv::Mat> channels;
      cv::split(*m, channels);
      const cv::Mat alpha = channels[3];
      channels.pop_back();
      for (cv::Mat& c : channels) c = c.mul(alpha);
      cv::merge(channels, rgb);
      out.alpha_mask = fromMat(binaryMask(alpha, mask_threshold));
      break;
    }
    default:
      return Status(StatusCode::kMalformed,
                    file + ": " + std::to_string(m->channels()) + " channels");
  }
  out.color = fromMat(toEightBit(rgb));
  return out;
}

// A mask file: grey or RGB(A), 1, 8 or 16 bits or float, dark meaning
// background (COLMAP's convention), any colour channel above the
// threshold meaning the subject (ImportOptions::mask_threshold).
StatusOr<Image8> readMask(const std::string& file, const Camera& camera, double threshold) {
  auto m = readAny(file, camera, "mask");
  if (!m.isOk()) return m.status();
  cv::Mat brightest;
  if (m->channels() == 1) {
    brightest = *m;
  } else {
    std::vector<cv::Mat> channels;
    cv::split(*m, channels);
    brightest = cv::max(cv::max(channels[0], channels[1]), channels[2]);  // alpha is not a colour
  }
  return fromMat(binaryMask(brightest, threshold));
}

// Everything about one image of one camera, ready to encode.
struct PreparedView {
  Image8 color, mask;
  bool mask_given = false;
};

// A box around the subject: points of a coarse grid inside the region every
// camera sees that project inside every camera's (dilated) mask; where no
// point does and there are four cameras or more, inside all masks but one,
// so that one camera with a wrong mask is named by its health
// (camera_health.h) instead of failing the import.
struct Box {
  glm::dvec3 min{0.0}, max{0.0};
};

StatusOr<Box> estimateCaptureVolume(const std::vector<Camera>& cameras,
                                    const std::vector<Image8>& masks) {
  // The point nearest to every optical axis (least squares).
  glm::dmat3 a(0.0);
  glm::dvec3 b(0.0);
  for (const auto& c : cameras) {
    const glm::dvec3 d = c.forward(), o = c.center();
    const glm::dmat3 p = glm::dmat3(1.0) - glm::outerProduct(d, d);
    a += p;
    b += p * o;
  }
  if (std::abs(glm::determinant(a)) < 1e-12) {
    return Status(StatusCode::kMalformed,
                  "the cameras' optical axes are parallel: cannot place the capture volume");
  }
  const glm::dvec3 centre = glm::inverse(a) * b;
  // The sphere every camera sees: its radius at the centre's distance.
  double radius = 1e300;
  for (const auto& c : cameras) {
    const double distance = glm::length(c.center() - centre);
    radius = std::min(radius, distance * std::min(c.width / (2.0 * c.fx), c.height / (2.0 * c.fy)));
  }
  radius *= 1.5;  // the subject may reach past what all cameras see at once
  std::vector<cv::Mat> dilated;
  for (const auto& m : masks) {
    cv::Mat d;
    cv::dilate(wrapForReading(m), d, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(9, 9)));
    dilated.push_back(d);
  }
  constexpr int kSteps = 96;
  const double step = 2 * radius / kSteps;
  Box box{glm::dvec3(1e300), glm::dvec3(-1e300)};
  size_t inside = 0;
  const size_t most_misses = cameras.size() >= 4 ? 1 : 0;
  for (size_t allowed = 0; allowed <= most_misses && inside == 0; ++allowed) {
    for (int i = 0; i <= kSteps; ++i) {
      for (int j = 0; j <= kSteps; ++j) {
        for (int k = 0; k <= kSteps; ++k) {
          const glm::dvec3 p = centre - glm::dvec3(radius) + step * glm::dvec3(i, j, k);
          size_t misses = 0;
          for (size_t c = 0; c < cameras.size() && misses <= allowed; ++c) {
            const auto q = cameras[c].project(p);
            const bool seen =
                q && q->x >= 0 && q->y >= 0 && q->x < cameras[c].width &&
                q->y < cameras[c].height &&
                dilated[c].at<uint8_t>(static_cast<int>(q->y), static_cast<int>(q->x)) != 0;
            misses += !seen;
          }
          if (misses > allowed) continue;
          ++inside;
          box.min = glm::min(box.min, p);
          box.max = glm::max(box.max, p);
        }
      }
    }
  }
  if (inside == 0) {
    return Status(StatusCode::kMalformed,
                  "no point near the cameras' common focus projects into every camera's mask: the "
                  "masks or the "
                  "calibration do not agree");
  }
  // Two grid steps of margin: the hull's surface lies inside.
  box.min -= glm::dvec3(2 * step);
  box.max += glm::dvec3(2 * step);
  return box;
}

std::string formatVec(const glm::dvec3& v) {
  char text[96];
  std::snprintf(text, sizeof(text), "(%.4f, %.4f, %.4f)", v.x, v.y, v.z);
  return text;
}

}  // namespace

std::string agreementText(const ImportSummary& summary) {
  std::string text;
  for (size_t c = 0; c < summary.agreement_pixels_cut.size(); ++c) {
    const std::string name =
        c < summary.camera_names.size() ? summary.camera_names[c] : std::to_string(c);
    // Moves and cuts too small to matter are not news.
    if (c < summary.agreement_shift.size() &&
        std::max(std::abs(summary.agreement_shift[c].first),
                 std::abs(summary.agreement_shift[c].second)) >= 3) {
      char line[200];
      std::snprintf(line, sizeof(line),
                    "camera %zu \"%s\": its first mask sits %+d, %+d px from the other cameras' "
                    "hull (their calibrations disagree by that much there)\n",
                    c, name.c_str(), summary.agreement_shift[c].first,
                    summary.agreement_shift[c].second);
      text += line;
    }
    if (summary.agreement_pixels_cut[c] * 1000 < summary.segmented_pixels[c]) continue;
    char line[256];
    std::snprintf(line, sizeof(line),
                  "camera %zu \"%s\": the other cameras' hull does not explain %.1f%% of its "
                  "segmented mask pixels (in %zu of %zu frames); cut\n",
                  c, name.c_str(),
                  100.0 * static_cast<double>(summary.agreement_pixels_cut[c]) /
                      static_cast<double>(std::max<uint64_t>(1, summary.segmented_pixels[c])),
                  summary.agreement_frames_cut[c], summary.frames);
    text += line;
  }
  return text;
}

Image8 segmentByBrightness(const Image8& color, const ImportOptions& options) {
  std::vector<cv::Mat> channels;
  cv::split(wrapForReading(color), channels);
  cv::Mat brightness = cv::max(cv::max(channels[0], channels[1]), channels[2]);
  cv::Mat mask;
  const int type = options.dark_subject ? cv::THRESH_BINARY_INV : cv::THRESH_BINARY;
  if (options.threshold) {
    cv::threshold(brightness, mask, *options.threshold * 255.0, 255, type);
  } else {
    cv::threshold(brightness, mask, 0, 255, type | cv::THRESH_OTSU);
  }
  cv::morphologyEx(mask, mask, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3)));
  if (options.close_px > 0) {
    const int k = 2 * options.close_px + 1;
    cv::morphologyEx(mask, mask, cv::MORPH_CLOSE,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k)));
  }
  // The subject is the largest connected component, holes filled.
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8);
  int best = 0, best_area = 0;
  for (int l = 1; l < count; ++l) {
    if (stats.at<int>(l, cv::CC_STAT_AREA) > best_area) {
      best_area = stats.at<int>(l, cv::CC_STAT_AREA);
      best = l;
    }
  }
  cv::Mat subject = best > 0 ? (labels == best) : cv::Mat::zeros(mask.size(), CV_8UC1);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(subject.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  cv::Mat filled = cv::Mat::zeros(mask.size(), CV_8UC1);
  cv::drawContours(filled, contours, -1, cv::Scalar(255), cv::FILLED);
  return fromMat(filled);
}

namespace {

// What import checks before any work: cameras and frames there, no more
// cameras than the loop serves, an image per camera in every frame, and
// every file named present (the images are checked when read; a missing
// one later still leaves no dataset behind).
Status checkCapture(const CaptureDescription& capture, const std::string& out_dir) {
  if (capture.cameras.empty() || capture.frames.empty()) {
    return Status(StatusCode::kMalformed, capture.source + ": no camera or no frame to import");
  }
  if (capture.cameras.size() > protocol::kMaxCameras) {
    return Status(StatusCode::kTooLarge,
                  capture.source + ": " + std::to_string(capture.cameras.size()) +
                      " cameras; the loop serves at most " + std::to_string(protocol::kMaxCameras));
  }
  if (fs::exists(out_dir) && !(fs::is_directory(out_dir) && fs::is_empty(out_dir))) {
    return Status(StatusCode::kIoError, out_dir + ": exists and is not empty; choose a new folder");
  }
  // Every file named must exist before any work (the images are checked
  // when read; a missing one later still leaves no dataset behind).
  for (size_t f = 0; f < capture.frames.size(); ++f) {
    const CaptureFrame& frame = capture.frames[f];
    if (frame.images.size() != capture.cameras.size()) {
      return Status(StatusCode::kMalformed,
                    capture.source + ": frame " + std::to_string(f) + " has " +
                        std::to_string(frame.images.size()) + " images for " +
                        std::to_string(capture.cameras.size()) + " cameras");
    }
    // A video frame's file is the video (its frames are checked as read).
    auto fileOf = [](const std::string& name) {
      const auto frame = parseVideoFrameName(name);
      return frame ? frame->video : name;
    };
    for (size_t c = 0; c < frame.images.size(); ++c) {
      if (!fs::exists(fileOf(frame.images[c]))) {
        return Status(StatusCode::kIoError, frame.images[c] + ": image of camera \"" +
                                                capture.cameras[c].name + "\" in frame " +
                                                std::to_string(f) + " is missing");
      }
      if (frame.masks[c] && !fs::exists(fileOf(*frame.masks[c]))) {
        return Status(StatusCode::kIoError, *frame.masks[c] + ": mask file is missing");
      }
    }
  }
  return Status::ok();
}

// One camera's view of frame f: its colour undistorted, its mask the
// capture's, the picture's alpha, or segmented (against the plate, with
// its previous mask for the hysteresis, else by brightness).
StatusOr<PreparedView> prepareView(const CaptureDescription& capture, size_t f, size_t c,
                                   const ImportOptions& options,
                                   const std::optional<Undistortion>& undistort,
                                   const std::optional<BackgroundModel>& plate,
                                   const Image8& previous_mask) {
  const CaptureFrame& frame = capture.frames[f];
  auto color = readColor(frame.images[c], capture.cameras[c].camera, options.mask_threshold);
  if (!color.isOk()) return color.status();
  PreparedView view;
  std::optional<Image8> mask;
  if (frame.masks[c]) {
    auto read = readMask(*frame.masks[c], capture.cameras[c].camera, options.mask_threshold);
    if (!read.isOk()) return read.status();
    mask = std::move(*read);
  } else if (color->alpha_mask) {
    mask = std::move(color->alpha_mask);
  }
  view.mask_given = mask.has_value();
  view.color = undistort ? undistort->apply(color->color) : std::move(color->color);
  if (mask) {
    view.mask = undistort ? undistort->apply(*mask, true) : std::move(*mask);
  } else if (plate) {
    view.mask =
        plate->segment(view.color, nullptr, previous_mask.empty() ? nullptr : &previous_mask);
  } else {
    view.mask = segmentByBrightness(view.color, options);
  }
  return view;
}

// A camera whose first mask is empty, or almost all of its picture, is
// named, since the hull will carve with it (a plate of another camera, a
// camera that moved since its plate, one that sees only background).
void warnOnFirstMasks(const CaptureDescription& capture, const std::vector<PreparedView>& first,
                      const std::vector<std::optional<BackgroundModel>>& plates,
                      std::vector<std::string>& warnings) {
  for (size_t c = 0; c < first.size(); ++c) {
    if (first[c].mask_given) continue;
    const double share = static_cast<double>(std::count(first[c].mask.pixels.begin(),
                                                        first[c].mask.pixels.end(), 255)) /
                         static_cast<double>(first[c].mask.pixels.size());
    const std::string who = "camera \"" + capture.cameras[c].name + "\"";
    if (share < 0.001) {
      warnings.push_back(who +
                         ": its first frame's mask is empty: it sees only background, or "
                         "the subject is out of its view");
    } else if (share > 0.9 && plates[c]) {
      char text[64];
      std::snprintf(text, sizeof(text), "%.0f%%", 100 * share);
      warnings.push_back(who + ": " + text +
                         " of its first frame differs from its plate: is the plate "
                         "another camera's, or did the camera move?");
    }
  }
}

// How the masks were made, for the dataset's metadata.
std::string segmentationText(const ImportOptions& options) {
  char segmentation[160];
  std::snprintf(segmentation, sizeof(segmentation),
                "masks from the source; otherwise background plates, else brightness %s%s, close "
                "%d px, largest "
                "component",
                options.threshold ? ("> " + std::to_string(*options.threshold)).c_str() : "by Otsu",
                options.dark_subject ? " (dark subject)" : "", options.close_px);
  return segmentation;
}

// One frame's views, all cameras prepared: the segmented masks counted,
// cut to what the others' hull explains (agree), then held for the next
// frame's hysteresis; what was cut goes in the summary.
void agreeAcrossTheRig(const std::vector<Camera>& cameras, bool agree,
                       const hull::HullOptions& hull_options, const std::vector<bool>& judged,
                       std::vector<PreparedView>& frame_views, std::vector<Image8>& previous_masks,
                       ImportSummary& summary) {
  for (size_t c = 0; c < cameras.size(); ++c) {
    if (!frame_views[c].mask_given)
      summary.segmented_pixels[c] += static_cast<uint64_t>(std::count(
          frame_views[c].mask.pixels.begin(), frame_views[c].mask.pixels.end(), uint8_t{255}));
  }
  if (agree) {
    std::vector<hull::HullView> views;
    for (size_t c = 0; c < cameras.size(); ++c)
      views.push_back({cameras[c], frame_views[c].mask, featherMap(frame_views[c].mask)});
    auto agreed = hull::agreeAcrossCameras(views, hull_options, {}, judged);
    const bool first_frame = previous_masks[0].empty();
    for (size_t c = 0; c < cameras.size(); ++c) {
      if (first_frame) summary.agreement_shift[c] = {agreed[c].shift.x, agreed[c].shift.y};
      if (agreed[c].pixels_removed == 0) continue;
      summary.agreement_pixels_cut[c] += agreed[c].pixels_removed;
      ++summary.agreement_frames_cut[c];
      frame_views[c].mask = std::move(agreed[c].mask);
    }
  }
  for (size_t c = 0; c < cameras.size(); ++c) previous_masks[c] = frame_views[c].mask;
}

// The dataset's record file in folder, with its metadata and every
// camera's calibration written: the frames follow.
StatusOr<RecordWriter> openDataset(const std::string& folder, const DatasetMetadata& metadata,
                                   const std::vector<Camera>& cameras) {
  auto writer = RecordWriter::create(
      (fs::path(folder) / kDatasetPodsFile).string(),
      static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                std::chrono::system_clock::now().time_since_epoch())
                                .count()));
  if (!writer.isOk()) return writer.status();
  Status s = writer->append(RecordKind::kDatasetInfo, kServerStream, 0, 0,
                            encodeDatasetMetadata(metadata));
  if (!s.isOk()) return s;
  for (const auto& camera : cameras) {
    const protocol::OutgoingFrame calibration =
        protocol::encodeOutgoing(toCalibration(camera), protocol::nextSequence());
    s = writer->append(RecordKind::kCalibration, camera.id, 0, 0, calibration);
    if (!s.isOk()) return s;
  }
  return writer;
}

// The dataset's description: its source, the capture volume, the voxel a
// replay carves with, its cameras' names.
DatasetMetadata metadataOf(const CaptureDescription& capture, const ImportOptions& options,
                           const Box& box) {
  const glm::dvec3 extent = box.max - box.min;
  DatasetMetadata metadata;
  metadata.source = capture.source;
  metadata.volume_min = box.min;
  metadata.volume_max = box.max;
  // Within what the server accepts (--voxel 0.0001..0.5 m): captures in
  // other units (COLMAP's are arbitrary) still carve.
  metadata.voxel_size = std::clamp(
      options.voxel_size.value_or(std::max({extent.x, extent.y, extent.z}) / 96.0), 0.0001, 0.5);
  metadata.still = capture.frames.size() == 1;
  for (const auto& c : capture.cameras) metadata.camera_names.push_back(c.name);
  const bool split = std::any_of(capture.cameras.begin(), capture.cameras.end(),
                                 [](const CaptureCamera& c) { return !c.split.empty(); });
  for (const auto& c : capture.cameras)
    if (split) metadata.camera_splits.push_back(c.split);
  return metadata;
}

}  // namespace

StatusOr<ImportSummary> importCapture(const CaptureDescription& source,
                                      const std::string& out_folder, const ImportOptions& options,
                                      const std::function<void(const ImportProgress&)>& progress) {
  // Whichever way the import ends, the videos it opened are closed.
  struct CloseVideos {
    ~CloseVideos() { closeVideos(); }
  } close_videos;
  const auto start = std::chrono::steady_clock::now();
  if (!(options.mask_threshold > 0 && options.mask_threshold < 1)) {
    return Status(StatusCode::kMalformed, "mask threshold " +
                                              std::to_string(options.mask_threshold) +
                                              ": expected a share of the range in (0, 1)");
  }
  HOLOFUSE_ASSIGN_OR_RETURN(const CaptureDescription capture,
                            withoutCameras(source, options.exclude_cameras));
  // "out/" and "out" are the same folder; the temporary one sits beside it.
  fs::path normal = fs::path(out_folder).lexically_normal();
  if (normal.filename().empty()) normal = normal.parent_path();
  const std::string out_dir = normal.string();
  if (out_dir.empty() || out_dir == "." || out_dir == "/") {
    return Status(StatusCode::kIoError, out_folder + ": not a folder to create a dataset in");
  }
  HOLOFUSE_RETURN_IF_ERROR(checkCapture(capture, out_dir));
  std::vector<Camera> cameras;
  std::vector<std::optional<Undistortion>> undistort;
  std::vector<std::optional<BackgroundModel>> plates;
  for (const auto& c : capture.cameras) {
    undistort.push_back(Undistortion::of(c.camera));
    Camera pinhole = c.camera;
    pinhole.distortion.clear();
    cameras.push_back(pinhole);
    if (c.background) {
      auto plate = readPlate(*c.background, c, undistort.back());
      if (!plate.isOk()) return plate.status();
      plates.push_back(std::move(*plate));
    } else {
      plates.push_back(std::nullopt);
    }
  }

  ImportSummary summary;
  summary.cameras = cameras.size();
  summary.frames = capture.frames.size();
  ImportProgress status;
  status.total = capture.cameras.size() * capture.frames.size();
  // Each camera's mask of the frame before: the segmenter's hysteresis.
  std::vector<Image8> previous_masks(cameras.size());
  auto prepare = [&](size_t f, size_t c) {
    return prepareView(capture, f, c, options, undistort[c], plates[c], previous_masks[c]);
  };

  // The first frame decides the capture volume, written before any frame.
  std::vector<PreparedView> first;
  std::vector<Image8> first_masks;
  for (size_t c = 0; c < cameras.size(); ++c) {
    auto view = prepare(0, c);
    if (!view.isOk()) return view.status();
    first_masks.push_back(view->mask);
    first.push_back(std::move(*view));
  }
  summary.agreement_pixels_cut.assign(cameras.size(), 0);
  summary.agreement_frames_cut.assign(cameras.size(), 0);
  summary.segmented_pixels.assign(cameras.size(), 0);
  summary.agreement_shift.assign(cameras.size(), {0, 0});
  warnOnFirstMasks(capture, first, plates, summary.warnings);
  auto box = estimateCaptureVolume(cameras, first_masks);
  if (!box.isOk())
    return Status(box.status().code(), capture.source + ": " + box.status().message());
  DatasetMetadata metadata = metadataOf(capture, options, *box);
  summary.volume = "min " + formatVec(box->min) + " max " + formatVec(box->max) + ", voxel " +
                   std::to_string(metadata.voxel_size);
  // The rig's agreement and the cameras' health, in the volume and at the
  // voxel a replay carves with.
  hull::HullOptions hull_options;
  hull::setCaptureVolume(hull_options, box->min, box->max);
  hull_options.voxel_size = metadata.voxel_size;
  std::vector<bool> judged(cameras.size());
  size_t segmented_cameras = 0;
  for (size_t c = 0; c < cameras.size(); ++c) {
    judged[c] = !first[c].mask_given;
    segmented_cameras += judged[c];
  }
  const bool agree = options.rig_agreement && cameras.size() >= 3 && segmented_cameras > 0;
  auto agreeOnFrame = [&](std::vector<PreparedView>& frame_views) {
    agreeAcrossTheRig(cameras, agree, hull_options, judged, frame_views, previous_masks, summary);
  };
  metadata.segmentation = segmentationText(options);
  if (agree) metadata.segmentation += "; segmented masks cut to the other cameras' hull";
  agreeOnFrame(first);
  std::vector<hull::HullView> first_views;
  for (size_t c = 0; c < cameras.size(); ++c)
    first_views.push_back({cameras[c], first[c].mask, featherMap(first[c].mask)});
  summary.health = cameraHealth(first_views, hull_options);
  summary.camera_names = metadata.camera_names;

  // Written under a temporary name, renamed when whole.
  const std::string partial = out_dir + ".partial-" + std::to_string(::getpid());
  fs::remove_all(partial);
  std::error_code error;
  fs::create_directories(partial, error);
  if (error)
    return Status(StatusCode::kIoError, partial + ": cannot create (" + error.message() + ")");
  auto fail = [&](const Status& s) -> Status {
    fs::remove_all(partial);
    return s;
  };
  auto writer = openDataset(partial, metadata, cameras);
  if (!writer.isOk()) return fail(writer.status());
  Status s = Status::ok();
  const uint64_t interval_ns = static_cast<uint64_t>(1e9 / capture.fps);
  for (size_t f = 0; f < capture.frames.size(); ++f) {
    std::vector<PreparedView> frame_views;
    if (f == 0) {
      frame_views = std::move(first);
    } else {
      for (size_t c = 0; c < cameras.size(); ++c) {
        auto prepared = prepare(f, c);
        if (!prepared.isOk()) return fail(prepared.status());
        frame_views.push_back(std::move(*prepared));
      }
      agreeOnFrame(frame_views);
    }
    for (size_t c = 0; c < cameras.size(); ++c) {
      PreparedView& view = frame_views[c];
      (view.mask_given ? summary.masks_given : summary.masks_segmented) += 1;
      const Image8 feather = featherMap(view.mask);
      std::vector<protocol::StageStamp> stamps;
      const protocol::OutgoingFrame frame =
          encodePodFrame({f + 1, 0, &view.color, &view.mask, &feather}, stamps, cameras[c].id,
                         PodEncoding{protocol::Codec::kLz4PlanarDelta, options.crop_margin});
      s = writer->append(RecordKind::kPodFrame, cameras[c].id, f + 1, f * interval_ns, frame);
      if (!s.isOk()) return fail(s);
      ++status.done;
      status.megabytes = static_cast<double>(writer->bytes()) / 1e6;
      status.seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (progress) progress(status);
    }
  }
  s = writer->close();
  if (!s.isOk()) return fail(s);
  summary.megabytes = status.megabytes;
  if (fs::exists(out_dir)) fs::remove(out_dir);  // empty, checked above
  fs::rename(partial, out_dir, error);
  if (error)
    return fail(
        Status(StatusCode::kIoError,
               out_dir + ": cannot move the finished dataset there (" + error.message() + ")"));
  return summary;
}

}  // namespace holofuse::dataset
