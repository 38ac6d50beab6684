#include "hull/mask_agreement.h"

#include <opencv2/imgproc.hpp>

#include "common/depth_raster.h"
#include "common/opencv_image.h"

namespace holofuse::hull {

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
    // Distance of each pixel to the others' hull: the pixels off it, to
    // the nearest on it.
    cv::Mat off_hull, distance_to_hull;
    cv::threshold(wrapForReading(out.others_hull), off_hull, 0, 255, cv::THRESH_BINARY_INV);
    cv::distanceTransform(off_hull, distance_to_hull, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    cv::Mat cut = cv::Mat::zeros(distance_to_hull.size(), CV_8UC1);
    for (int y = 0; y < cut.rows; ++y) {
      const float* d = distance_to_hull.ptr<float>(y);
      uint8_t* row = out.mask.pixels.data() + static_cast<size_t>(y) * out.mask.width;
      uint8_t* cut_row = cut.ptr<uint8_t>(y);
      for (int x = 0; x < cut.cols; ++x) {
        if (row[x] == 0 || d[x] <= out.margin_px) continue;
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
