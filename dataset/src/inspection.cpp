#include "dataset/inspection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "codec/image_codec.h"
#include "dataset/camera_health.h"
#include "dataset/dataset.h"
#include "hull/mask_agreement.h"
#include "hull/visual_hull.h"
#include "image/image_io.h"
#include "metrics/geometry_metrics.h"

namespace holofuse::dataset {

namespace {

std::string utcTime(uint64_t unix_ns) {
  const std::time_t seconds = static_cast<std::time_t>(unix_ns / 1000000000ull);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M:%S UTC", &tm);
  return text;
}

std::string megabytes(uint64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f MB", static_cast<double>(bytes) / 1e6);
  return text;
}

// One file's findings; worsens the verdict.
Status verifyFile(const std::string& file, VerifyReport& report) {
  auto reader = RecordReader::open(file);
  if (!reader.isOk()) return reader.status();
  const RecordScan& scan = reader->scan();
  std::string& t = report.text;
  t += file + ": recording format " + std::to_string(scan.format_major) + "." +
       std::to_string(scan.format_minor) + ", created " + utcTime(scan.created_unix_ns) + ", " +
       std::to_string(scan.file_size) + " bytes\n";
  if (scan.index_found) {
    t += "  index: in place, " + std::to_string(reader->records().size()) + " records\n";
  } else {
    t += "  index: " + scan.index_note +
         "; rebuilt by scanning: " + std::to_string(reader->records().size()) + " whole records\n";
  }
  std::map<std::string, size_t> kinds;
  std::set<uint32_t> streams;
  for (const auto& r : reader->records()) {
    ++kinds[recordKindName(r.kind)];
    if (r.stream != kServerStream) streams.insert(r.stream);
  }
  std::string kind_text;
  for (const auto& [name, n] : kinds)
    kind_text += (kind_text.empty() ? "" : ", ") + std::to_string(n) + " " + name;
  t += "  records: " + (kind_text.empty() ? std::string("none") : kind_text) +
       (streams.empty() ? "" : " from " + std::to_string(streams.size()) + " camera(s)") + "\n";
  const Status checked = reader->verifyAll();
  if (checked.isOk()) {
    t += "  checked: every record's CRC32C matches\n";
  } else {
    t += "  CORRUPT: " + checked.message() + "\n";
    report.verdict = VerifyVerdict::kCorrupt;
  }
  if (scan.tail_problem) {
    t += std::string(scan.tail_incomplete ? "  incomplete tail: " : "  CORRUPT: ") +
         *scan.tail_problem + "\n";
    if (!scan.tail_incomplete) {
      report.verdict = VerifyVerdict::kCorrupt;
    } else if (report.verdict == VerifyVerdict::kClean) {
      report.verdict = VerifyVerdict::kIncompleteTail;
    }
  }
  return Status::ok();
}

// A camera's tile: the image, dimmed where its mask says background, and
// the hull's silhouette border drawn over it.
cv::Mat tile(const Image8& color, const Image8& mask, const Image8& hull_mask,
             const std::string& label, bool marked) {
  cv::Mat image(static_cast<int>(color.height), static_cast<int>(color.width), CV_8UC3,
                const_cast<uint8_t*>(color.pixels.data()));
  cv::Mat out = image.clone();
  for (uint32_t i = 0; i < color.width * color.height; ++i) {
    if (mask.pixels[i] != 0) continue;
    for (int c = 0; c < 3; ++c)
      out.data[3 * i + static_cast<uint32_t>(c)] =
          static_cast<uint8_t>(out.data[3 * i + static_cast<uint32_t>(c)] / 3);
  }
  cv::Mat hull(static_cast<int>(hull_mask.height), static_cast<int>(hull_mask.width), CV_8UC1,
               const_cast<uint8_t*>(hull_mask.pixels.data()));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(hull.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::drawContours(out, contours, -1, cv::Scalar(255, 0, 255), 1);  // RGB order: magenta
  cv::putText(out, label, cv::Point(6, 18), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 0),
              1, cv::LINE_AA);
  if (marked) {  // a camera set apart from the rest (camera_health.h): a red frame, and why
    const int border = std::max(3, out.cols / 60);
    cv::rectangle(out, cv::Rect(0, 0, out.cols, out.rows), cv::Scalar(255, 0, 0), 2 * border);
    cv::putText(out, "CHECK", cv::Point(6, out.rows - 10), cv::FONT_HERSHEY_SIMPLEX, 0.8,
                cv::Scalar(255, 0, 0), 2, cv::LINE_AA);
  }
  return out;
}

}  // namespace

hull::HullOptions hullOptionsFor(const Dataset& dataset, double fallback_voxel) {
  hull::HullOptions options;
  options.voxel_size = fallback_voxel;
  if (const auto& m = dataset.metadata(); m && m->voxel_size > 0) {
    hull::setCaptureVolume(options, m->volume_min, m->volume_max);
    options.voxel_size = m->voxel_size;
  }
  return options;
}

StatusOr<VerifyReport> verifyDataset(const std::string& dir) {
  namespace fs = std::filesystem;
  VerifyReport report;
  const std::string pods =
      fs::is_directory(dir) ? (fs::path(dir) / kDatasetPodsFile).string() : dir;
  if (!fs::exists(pods)) {
    return Status(StatusCode::kIoError,
                  dir + ": not a holofuse dataset (no " + kDatasetPodsFile + " in it)");
  }
  HOLOFUSE_RETURN_IF_ERROR(verifyFile(pods, report));
  const fs::path fused = fs::path(dir) / kDatasetFusedFile;
  if (fs::is_directory(dir) && fs::exists(fused))
    HOLOFUSE_RETURN_IF_ERROR(verifyFile(fused.string(), report));
  switch (report.verdict) {
    case VerifyVerdict::kClean:
      report.text += "verdict: OK\n";
      break;
    case VerifyVerdict::kIncompleteTail:
      report.text +=
          "verdict: OK but for an incomplete tail (a recorder stopped mid-write); every whole "
          "record reads\n";
      break;
    case VerifyVerdict::kCorrupt:
      report.text += "verdict: CORRUPT\n";
      break;
  }
  return report;
}

std::vector<uint64_t> wholeFrames(const Dataset& dataset) {
  // A camera that repeats an id counts once.
  std::map<uint64_t, std::set<uint32_t>> cameras_per_id;
  for (const auto& [id, cam] : dataset.cameras()) {
    for (const auto& r : cam.frames) cameras_per_id[r.frame_id].insert(id);
  }
  std::vector<uint64_t> ids;
  for (const auto& [id, holders] : cameras_per_id) {
    if (holders.size() == dataset.cameras().size()) ids.push_back(id);
  }
  return ids;
}

StatusOr<uint64_t> firstWholeFrame(const Dataset& dataset, const std::string& dir) {
  const std::vector<uint64_t> ids = wholeFrames(dataset);
  if (ids.empty())
    return Status(StatusCode::kMalformed, dir + ": no frame id is held by every camera");
  return ids.front();
}

StatusOr<FrameViews> readFrameViews(const Dataset& dataset, const std::string& dir,
                                    uint64_t frame_id) {
  FrameViews out;
  out.frame_id = frame_id;
  for (const auto& [id, cam] : dataset.cameras()) {
    auto calibration = dataset.readCalibration(id);
    if (!calibration.isOk()) return calibration.status();
    const Camera camera = fromCalibration(*calibration);
    const auto record = std::find_if(cam.frames.begin(), cam.frames.end(),
                                     [&](const RecordInfo& r) { return r.frame_id == frame_id; });
    if (record == cam.frames.end()) {
      return Status(StatusCode::kMalformed, dir + ": camera " + std::to_string(id) +
                                                " lacks frame " + std::to_string(frame_id));
    }
    auto frame = dataset.readFrame(*record);
    if (!frame.isOk()) return frame.status();
    auto decoded = decodePodImages(*frame, camera);
    if (!decoded.isOk()) {
      return Status(decoded.status().code(), dir + ": camera " + std::to_string(id) + " frame " +
                                                 std::to_string(frame_id) + ": " +
                                                 decoded.status().message());
    }
    out.cameras.push_back(camera);
    out.images.push_back(std::move(*decoded));
  }
  return out;
}

StatusOr<DatasetSummary> describeDataset(const std::string& dir, const std::string& sheet_png,
                                         double voxel_size, size_t health_frames) {
  auto dataset = Dataset::open(dir);
  if (!dataset.isOk()) return dataset.status();
  DatasetSummary summary;
  std::string& t = summary.text;
  const auto& scan = dataset->records().scan();
  const double seconds = static_cast<double>(dataset->lastTimeNs() - dataset->firstTimeNs()) / 1e9;
  char duration[32];
  std::snprintf(duration, sizeof(duration), "%.1f s", seconds);
  t += dir + ": " + std::to_string(dataset->cameras().size()) + " camera(s), " +
       std::to_string(dataset->frameIds()) + " frame(s) over " + duration + ", format " +
       std::to_string(scan.format_major) + "." + std::to_string(scan.format_minor) + ", recorded " +
       utcTime(scan.created_unix_ns) + "\n";
  if (scan.tail_problem) t += "note: " + *scan.tail_problem + "\n";

  auto frame_id = firstWholeFrame(*dataset, dir);
  if (!frame_id.isOk()) return frame_id.status();
  summary.inspected_frame_id = *frame_id;
  auto frame = readFrameViews(*dataset, dir, *frame_id);
  if (!frame.isOk()) return frame.status();
  std::vector<hull::HullView> views;
  const std::vector<PodImagesFull>& images = frame->images;
  for (size_t i = 0; i < frame->cameras.size(); ++i) {
    const Camera& camera = frame->cameras[i];
    const auto& cam = dataset->cameras().at(camera.id);
    CameraSummary c;
    c.id = camera.id;
    c.frames = cam.frames.size();
    c.megabytes = static_cast<double>(cam.frame_bytes) / 1e6;
    c.width = camera.width;
    c.height = camera.height;
    static const char* const kPlaneNames[] = {"colour", "mask", "feather"};
    for (size_t p = 0; p < images[i].codecs.size(); ++p) {
      c.codecs += (c.codecs.empty() ? "" : ", ") + std::string(p < 3 ? kPlaneNames[p] : "plane") +
                  " " + imageCodecName(images[i].codecs[p]);
    }
    views.push_back({camera, images[i].mask, images[i].feather});
    summary.cameras.push_back(c);
  }
  hull::HullOptions hull_options = hullOptionsFor(*dataset, hull::HullOptions{}.voxel_size);
  if (voxel_size > 0) hull_options.voxel_size = voxel_size;
  voxel_size = hull_options.voxel_size;
  const Mesh hull = hull::carveVisualHull(views, hull_options);
  char voxel_text[32];
  std::snprintf(voxel_text, sizeof(voxel_text), "%.2f mm", voxel_size * 1000);
  t += "frame " + std::to_string(*frame_id) + ": visual hull of " +
       std::to_string(hull.triangleCount()) + " triangles at " + voxel_text + " voxels";
  if (const auto& m = dataset->metadata()) t += " (" + m->source + ")";
  t += "\n";
  t += "camera  size        frames   data       silhouette IoU  codecs\n";
  const std::vector<CameraHealth> health = cameraHealth(views, hull_options);
  std::vector<cv::Mat> tiles;
  for (size_t i = 0; i < views.size(); ++i) {
    CameraSummary& c = summary.cameras[i];
    c.health = health[i];
    c.silhouette_iou = metrics::silhouetteIoU(hull, views[i].camera, views[i].mask);
    char line[256];
    std::snprintf(line, sizeof(line), "%-7u %4ux%-7u %-8zu %-10s %-15.3f %s\n", c.id, c.width,
                  c.height, c.frames, megabytes(static_cast<uint64_t>(c.megabytes * 1e6)).c_str(),
                  c.silhouette_iou, c.codecs.c_str());
    t += line;
    char label[64];
    std::snprintf(label, sizeof(label), "camera %u  IoU %.3f", c.id, c.silhouette_iou);
    tiles.push_back(tile(images[i].color, images[i].mask, hull::silhouetteOf(hull, views[i].camera),
                         label, !health[i].concern.empty()));
  }
  std::vector<std::string> names;
  for (const CameraSummary& c : summary.cameras) {
    const auto& m = dataset->metadata();
    names.push_back(m && c.id < m->camera_names.size() ? m->camera_names[c.id]
                                                       : "camera " + std::to_string(c.id));
  }
  t += cameraHealthText(names, health, "the contact sheet " + sheet_png);
  // Health over time: frames spread evenly through the dataset.
  const std::vector<uint64_t> whole = wholeFrames(*dataset);
  const size_t measured = health_frames == 0 ? whole.size() : std::min(health_frames, whole.size());
  if (measured > 1) {
    std::vector<uint64_t> ids;
    std::vector<std::vector<CameraHealth>> per_frame;
    for (size_t k = 0; k < measured; ++k) {
      const uint64_t id = whole[k * (whole.size() - 1) / std::max<size_t>(1, measured - 1)];
      if (!ids.empty() && ids.back() == id) continue;
      auto views_k = readFrameViews(*dataset, dir, id);
      if (!views_k.isOk()) return views_k.status();
      std::vector<hull::HullView> frame_views;
      for (size_t i = 0; i < views_k->cameras.size(); ++i)
        frame_views.push_back(
            {views_k->cameras[i], views_k->images[i].mask, views_k->images[i].feather});
      ids.push_back(id);
      per_frame.push_back(cameraHealth(frame_views, hull_options));
    }
    summary.health_over_time = summariseHealthOverTime(ids, per_frame);
    t += healthOverTimeText(names, summary.health_over_time, whole.size());
  }
  // The sheet: tiles scaled to one height, in rows of up to four.
  const int tile_height = 240;
  const int columns = static_cast<int>(std::min<size_t>(4, tiles.size()));
  std::vector<cv::Mat> rows, row;
  int max_width = 0;
  for (size_t i = 0; i < tiles.size(); ++i) {
    cv::Mat scaled;
    const double s = static_cast<double>(tile_height) / tiles[i].rows;
    cv::resize(tiles[i], scaled,
               cv::Size(std::max(1, static_cast<int>(tiles[i].cols * s)), tile_height), 0, 0,
               cv::INTER_AREA);
    row.push_back(scaled);
    if (static_cast<int>(row.size()) == columns || i + 1 == tiles.size()) {
      cv::Mat joined;
      cv::hconcat(row, joined);
      max_width = std::max(max_width, joined.cols);
      rows.push_back(joined);
      row.clear();
    }
  }
  for (auto& r : rows) {
    if (r.cols < max_width)
      cv::copyMakeBorder(r, r, 0, 0, 0, max_width - r.cols, cv::BORDER_CONSTANT,
                         cv::Scalar(0, 0, 0));
  }
  cv::Mat sheet;
  cv::vconcat(rows, sheet);
  Image8 png;
  png.width = static_cast<uint32_t>(sheet.cols);
  png.height = static_cast<uint32_t>(sheet.rows);
  png.channels = 3;
  png.pixels.assign(sheet.data, sheet.data + sheet.total() * 3);
  HOLOFUSE_RETURN_IF_ERROR(writeImage(sheet_png, png));
  t +=
      "contact sheet (image, mask dimmed outside, hull silhouette in magenta): " + sheet_png + "\n";
  return summary;
}

}  // namespace holofuse::dataset
