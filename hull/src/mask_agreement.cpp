#include "hull/mask_agreement.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "geometry/depth_raster.h"
#include "image/opencv_image.h"

namespace holofuse::hull {

namespace {

// A mask pixel this close to the others' hull touches the subject.
constexpr float kTouching = 1.5f;

// IoU of mask with silhouette moved by (dx, dy), inside box.
double shiftedIoU(const cv::Mat& mask, const cv::Mat& silhouette, const cv::Rect& box, int dx,
                  int dy) {
  size_t both = 0, either = 0;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const uint8_t* m = mask.ptr<uint8_t>(y);
    const int sy = y - dy;
    const uint8_t* s = sy >= 0 && sy < silhouette.rows ? silhouette.ptr<uint8_t>(sy) : nullptr;
    for (int x = box.x; x < box.x + box.width; ++x) {
      const int sx = x - dx;
      const bool in_mask = m[x] != 0;
      const bool in_hull = s != nullptr && sx >= 0 && sx < silhouette.cols && s[sx] != 0;
      both += in_mask && in_hull;
      either += in_mask || in_hull;
    }
  }
  return either ? static_cast<double>(both) / static_cast<double>(either) : 0.0;
}

// The move of the silhouette, within range pixels, that best overlaps the
// mask: a calibration's error shows in a camera mostly as its picture
// moved. A prop in the mask lies off the silhouette however it moves, so
// it does not pull the move. Every third pixel, then every pixel near the
// best.
cv::Point bestShift(const cv::Mat& mask, const cv::Mat& silhouette, int range) {
  cv::Mat both;
  cv::bitwise_or(mask, silhouette, both);
  cv::Rect box = cv::boundingRect(both);
  if (box.empty()) return {0, 0};
  box = cv::Rect(box.x - range, box.y - range, box.width + 2 * range, box.height + 2 * range) &
        cv::Rect(0, 0, mask.cols, mask.rows);
  cv::Point best(0, 0);
  double best_iou = shiftedIoU(mask, silhouette, box, 0, 0);
  auto search = [&](cv::Point centre, int reach, int step) {
    const cv::Point from = centre;
    for (int dy = -reach; dy <= reach; dy += step) {
      for (int dx = -reach; dx <= reach; dx += step) {
        const cv::Point at(from.x + dx, from.y + dy);
        if (std::abs(at.x) > range || std::abs(at.y) > range) continue;
        const double iou = shiftedIoU(mask, silhouette, box, at.x, at.y);
        if (iou > best_iou + 1e-9) {
          best_iou = iou;
          best = at;
        }
      }
    }
  };
  search({0, 0}, range - range % 3, 3);
  search(best, 2, 1);
  return best;
}

}  // namespace

Image8 silhouetteOf(const Mesh& mesh, const Camera& camera) {
  const DepthMap depth = rasterizeDepth(mesh, camera);
  Image8 out(camera.width, camera.height, 1);
  for (size_t i = 0; i < depth.depth.size(); ++i)
    out.pixels[i] = depth.depth[i] != kNoDepth ? 255 : 0;
  return out;
}

std::vector<MaskAgreement> agreeAcrossCameras(const std::vector<HullView>& views,
                                              const HullOptions& options,
                                              const AgreementOptions& agreement,
                                              const std::vector<bool>& judged) {
  std::vector<MaskAgreement> result(views.size());
  for (size_t j = 0; j < views.size(); ++j) result[j].mask = views[j].mask;
  if (views.size() < 3) return result;
  HullOptions coarse = options;
  coarse.voxel_size = std::min(kMaxVoxel, options.voxel_size * agreement.voxel_scale);
  const glm::dvec3 centre = 0.5 * (options.volume_min + options.volume_max);
  for (size_t j = 0; j < views.size(); ++j) {
    if (!judged.empty() && !judged[j]) continue;
    std::vector<HullView> others = views;
    others.erase(others.begin() + static_cast<std::ptrdiff_t>(j));
    MaskAgreement& out = result[j];
    const Camera& camera = views[j].camera;
    out.others_hull = silhouetteOf(carveVisualHull(others, coarse), camera);
    const double distance = std::max(1e-6, glm::length(camera.center() - centre));
    out.margin_px =
        agreement.margin_px + coarse.voxel_size * std::max(camera.fx, camera.fy) / distance;
    // The others' hull moved to where it best overlaps this mask.
    const cv::Mat mask = wrapForReading(views[j].mask);
    cv::Mat hull = wrapForReading(out.others_hull);
    const cv::Point shift = bestShift(mask, hull, agreement.search_px);
    out.shift = glm::ivec2(shift.x, shift.y);
    if (shift != cv::Point(0, 0)) {
      const cv::Mat move = (cv::Mat_<double>(2, 3) << 1, 0, shift.x, 0, 1, shift.y);
      cv::warpAffine(hull.clone(), hull, move, hull.size(), cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                     cv::Scalar(0));
    }
    // Distance of each pixel to the (moved) hull: off it, to the nearest
    // pixel on it.
    cv::Mat off_hull, distance_to_hull;
    cv::threshold(hull, off_hull, 0, 255, cv::THRESH_BINARY_INV);
    cv::distanceTransform(off_hull, distance_to_hull, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    // Off the hull by more than the margin: cut. Off it by more than
    // kTouching and within the margin of a prop: the prop reaching in
    // towards the subject, cut too. Along the rest of the outline the
    // margin's band stays.
    cv::Mat far = cv::Mat::zeros(distance_to_hull.size(), CV_8UC1);
    cv::Mat off = far.clone();
    for (int y = 0; y < far.rows; ++y) {
      const float* d = distance_to_hull.ptr<float>(y);
      const uint8_t* m = mask.ptr<uint8_t>(y);
      for (int x = 0; x < far.cols; ++x) {
        if (m[x] == 0 || d[x] <= kTouching) continue;
        off.at<uint8_t>(y, x) = 255;
        if (d[x] > out.margin_px) far.at<uint8_t>(y, x) = 255;
      }
    }
    // Only a piece that reaches twice the margin off the hull is a prop
    // to follow in; a sliver along the outline just past the margin is
    // the subject where the calibrations disagree more than the move.
    cv::Mat labels;
    const int pieces = cv::connectedComponents(far, labels, 8, CV_32S);
    std::vector<float> reach(static_cast<size_t>(pieces), 0.0f);
    for (int y = 0; y < far.rows; ++y) {
      const int32_t* label = labels.ptr<int32_t>(y);
      const float* d = distance_to_hull.ptr<float>(y);
      for (int x = 0; x < far.cols; ++x)
        if (label[x] != 0)
          reach[static_cast<size_t>(label[x])] =
              std::max(reach[static_cast<size_t>(label[x])], d[x]);
    }
    cv::Mat not_prop(far.size(), CV_8UC1, cv::Scalar(255)), distance_to_prop;
    for (int y = 0; y < far.rows; ++y) {
      const int32_t* label = labels.ptr<int32_t>(y);
      for (int x = 0; x < far.cols; ++x)
        if (label[x] != 0 && reach[static_cast<size_t>(label[x])] >= 2 * out.margin_px)
          not_prop.at<uint8_t>(y, x) = 0;
    }
    cv::distanceTransform(not_prop, distance_to_prop, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    cv::Mat cut = cv::Mat::zeros(distance_to_hull.size(), CV_8UC1);
    for (int y = 0; y < cut.rows; ++y) {
      const float* to_prop = distance_to_prop.ptr<float>(y);
      const uint8_t* off_row = off.ptr<uint8_t>(y);
      const uint8_t* far_row = far.ptr<uint8_t>(y);
      uint8_t* row = out.mask.pixels.data() + static_cast<size_t>(y) * out.mask.width;
      uint8_t* cut_row = cut.ptr<uint8_t>(y);
      for (int x = 0; x < cut.cols; ++x) {
        if (off_row[x] == 0 || (far_row[x] == 0 && to_prop[x] > out.margin_px)) continue;
        row[x] = 0;
        cut_row[x] = 255;
        ++out.pixels_removed;
      }
    }
    if (out.pixels_removed > 0) {
      cv::Mat labels;
      out.pieces_removed = static_cast<uint32_t>(cv::connectedComponents(cut, labels, 8) - 1);
    }
  }
  return result;
}

}  // namespace holofuse::hull
