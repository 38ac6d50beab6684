#include "hull/hull_error.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "geometry/depth_raster.h"

namespace holofuse::hull {
namespace {

// 0 on the outline of `inside` (a pixel inside with a 4-neighbour outside,
// or on the image's edge), 255 elsewhere: the input of a distance transform
// to the outline.
cv::Mat outlineOf(const cv::Mat& inside) {
  cv::Mat outline(inside.size(), CV_8UC1, cv::Scalar(255));
  for (int y = 0; y < inside.rows; ++y) {
    for (int x = 0; x < inside.cols; ++x) {
      if (!inside.at<uint8_t>(y, x)) continue;
      const bool edge = x == 0 || y == 0 || x + 1 == inside.cols || y + 1 == inside.rows ||
                        !inside.at<uint8_t>(y, x - 1) || !inside.at<uint8_t>(y, x + 1) ||
                        !inside.at<uint8_t>(y - 1, x) || !inside.at<uint8_t>(y + 1, x);
      if (edge) outline.at<uint8_t>(y, x) = 0;
    }
  }
  return outline;
}

// Mean over the outline pixels of `from` of the distance to the outline of
// `to`; adds to sum and count.
void accumulate(const cv::Mat& from_outline, const cv::Mat& to_distance, double& sum,
                size_t& count) {
  for (int y = 0; y < from_outline.rows; ++y) {
    for (int x = 0; x < from_outline.cols; ++x) {
      if (from_outline.at<uint8_t>(y, x) != 0) continue;
      sum += to_distance.at<float>(y, x);
      ++count;
    }
  }
}

}  // namespace

SilhouetteError silhouetteError(const Mesh& mesh, const std::vector<HullView>& views) {
  SilhouetteError result;
  double sum_px = 0, sum_m = 0;
  size_t cameras = 0;
  for (const HullView& view : views) {
    const Camera& camera = view.camera;
    if (view.mask.width != camera.width || view.mask.height != camera.height) continue;
    const DepthMap depth = rasterizeDepth(mesh, camera);
    const int w = static_cast<int>(camera.width), h = static_cast<int>(camera.height);
    cv::Mat hull(h, w, CV_8UC1, cv::Scalar(0)), mask(h, w, CV_8UC1, cv::Scalar(0));
    std::vector<double> depths;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        if (depth.depth[i] != kNoDepth) {
          hull.at<uint8_t>(y, x) = 1;
          depths.push_back(depth.depth[i]);
        }
        mask.at<uint8_t>(y, x) = view.mask.pixels[i] != 0;
      }
    }
    if (depths.empty() || cv::countNonZero(mask) == 0) continue;
    const cv::Mat hull_outline = outlineOf(hull), mask_outline = outlineOf(mask);
    cv::Mat to_hull, to_mask;
    cv::distanceTransform(hull_outline, to_hull, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    cv::distanceTransform(mask_outline, to_mask, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    double sum = 0;
    size_t count = 0;
    accumulate(hull_outline, to_mask, sum, count);
    accumulate(mask_outline, to_hull, sum, count);
    const double px = sum / static_cast<double>(count);
    // A pixel at depth z spans z / f metres.
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    const double metres_per_px = depths[depths.size() / 2] / (0.5 * (camera.fx + camera.fy));
    sum_px += px;
    sum_m += px * metres_per_px;
    result.worst_m = std::max(result.worst_m, px * metres_per_px);
    ++cameras;
  }
  if (cameras == 0) return result;
  result.mean_px = sum_px / static_cast<double>(cameras);
  result.mean_m = sum_m / static_cast<double>(cameras);
  result.valid = std::isfinite(result.mean_m);
  return result;
}

HullForTarget carveToErrorTarget(const std::vector<HullView>& views, const HullOptions& options,
                                 double target_m, HullStats* stats) {
  HullForTarget best;
  HullStats best_stats;
  HullOptions tried = options;
  int carves = 0;
  for (;;) {
    HullStats tried_stats;
    Mesh mesh = carveVisualHull(views, tried, &tried_stats);
    const SilhouetteError error = silhouetteError(mesh, views);
    ++carves;
    if (carves > 1 && error.valid && best.error.valid &&
        error.mean_m > (1 - kUsefulImprovement) * best.error.mean_m) {
      break;  // finer stopped helping: keep the coarser hull
    }
    best.mesh = std::move(mesh);
    best.voxel_size = tried.voxel_size;
    best.error = error;
    best_stats = tried_stats;
    best.met = error.valid && error.mean_m <= target_m;
    if (best.met || !error.valid || tried.voxel_size <= kFinestVoxel * 1.0001) break;
    tried.voxel_size = std::max(kFinestVoxel, tried.voxel_size * kVoxelStep);
  }
  best.carves = carves;
  if (stats) *stats = best_stats;
  return best;
}

VoxelController::VoxelController(double target_m, double start_voxel, double coarsest_voxel)
    : target_m_(target_m),
      voxel_(start_voxel),
      coarsest_(std::max(coarsest_voxel, start_voxel)),
      finest_(std::min(kFinestVoxel, start_voxel)) {}

bool VoxelController::observe(const SilhouetteError& error) {
  if (!error.valid || !(target_m_ > 0)) return false;
  const double before = voxel_;
  if (++since_miss_ > kMissMemory)
    missed_voxel_ = 0;  // the subject may have changed: try coarser again
  if (floor_voxel_ > 0 && ++since_floor_ > kMissMemory) floor_voxel_ = 0;
  if (error.mean_m > target_m_) {
    missed_voxel_ = missed_voxel_ > 0 ? std::min(missed_voxel_, voxel_) : voxel_;
    since_miss_ = 0;
    if (refined_from_ > 0 && error.mean_m > (1 - kUsefulImprovement) * refined_from_error_) {
      // The last refinement did not help: the silhouettes disagree by more
      // than the target. Back to the coarser voxel, and stay there.
      floor_voxel_ = refined_from_;
      since_floor_ = 0;
      voxel_ = refined_from_;
      refined_from_ = 0;
    } else if (floor_voxel_ == 0) {
      refined_from_ = voxel_;
      refined_from_error_ = error.mean_m;
      voxel_ = std::max(finest_, voxel_ * kVoxelStep);
    }
  } else if (error.mean_m < 0.5 * target_m_) {
    const double coarser = std::min(coarsest_, voxel_ / kVoxelStep);
    if (missed_voxel_ == 0 || coarser < missed_voxel_ * 0.999) voxel_ = coarser;
    refined_from_ = 0;
  } else {
    refined_from_ = 0;
  }
  return voxel_ != before;
}

}  // namespace holofuse::hull
