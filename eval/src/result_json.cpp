#include "result_json.h"

namespace holofuse::eval {

using metrics::ErrorRegion;
using metrics::errorRegionName;
using metrics::kErrorRegionCount;
using metrics::psnrFromMse;

nlohmann::json sceneResultJson(const SceneResult& scene) {
  nlohmann::json s;
  s["stresses"] = scene.stresses;
  s["cameras"] = scene.cameras;
  s["view_jump_degrees"] = scene.view_jump_degrees;
  if (scene.novel_view_degrees != 0) s["novel_view_degrees"] = scene.novel_view_degrees;
  if (scene.camera_kept) s["camera_kept"] = true;
  s["hull_ms"] = scene.hull_ms;
  s["codec_ms"] = scene.codec_ms;
  s["hull_ms_p95"] = scene.hull_ms_p95;
  s["refine_ms"] = scene.refine_ms;
  s["refine_ms_p95"] = scene.refine_ms_p95;
  s["codec_ms_p95"] = scene.codec_ms_p95;
  for (const auto& [stage, ms] : scene.codec_stage_ms) {
    s["codec_stages_ms"][stage] = {{"p50", ms}, {"p95", scene.codec_stage_ms_p95.at(stage)}};
  }
  s["triangles"] = scene.triangles;
  s["bytes_per_frame"] = scene.bytes_per_frame;
  s["feather_bytes_per_frame"] = scene.feather_bytes_per_frame;
  s["pod_link_bytes_per_frame"] = scene.pod_link_bytes_per_frame;
  s["hull"] = {{"chamfer_mm", measuredJson(scene.chamfer_mm)},
               {"silhouette_iou", scene.silhouette_iou},
               {"cells_visited", scene.cells_visited},
               {"voxel_mm", scene.voxel_mm},
               {"silhouette_error_mm", measuredJson(scene.silhouette_error_mm)},
               {"dense_grid_points", scene.dense_grid_points}};
  if (!scene.mask_iou.empty()) {
    s["segmentation"] = {{"mask_iou", scene.mask_iou},
                         {"mask_iou_agreed", scene.mask_iou_agreed},
                         {"shadow_taken", measuredJson(scene.shadow_taken)}};
  }
  if (scene.montage_agreement.measured) {
    s["montage_agreement"] = {
        {"differing_pixel_share", scene.montage_agreement.differing_share},
        {"holoportation_error_share_there", scene.montage_agreement.holoportation_error_share},
        {"psnr_gain_bound_db", scene.montage_agreement.gain_bound_db}};
  }
  for (const auto& [mode, m] : scene.modes) {
    s["modes"][mode] = {{"rmse_percent", m.rmse_percent},
                        {"psnr_db", m.psnr_db},
                        {"ssim", m.ssim},
                        {"flicker", measuredJson(m.flicker)},
                        {"seam_visibility", measuredJson(m.seam_visibility)},
                        {"images", m.images},
                        {"ms_per_new_mesh", m.ms_per_new_mesh},
                        {"ms_per_new_mesh_p95", m.ms_per_new_mesh_p95},
                        {"client_bytes_per_frame", m.client_bytes_per_frame},
                        {"layers_ms", m.layers_ms},
                        {"layer_video_ms", m.layer_video_ms},
                        {"mesh_bytes_per_frame", m.mesh_bytes_per_frame},
                        {"layer_colour_bytes_per_frame", m.layer_colour_bytes_per_frame},
                        {"layer_camera_bytes_per_frame", m.layer_camera_bytes_per_frame},
                        {"atlas_moved", measuredJson(m.atlas_moved)},
                        {"gpu_passes_ms", m.gpu_passes_ms}};
    for (size_t r = 0; r < kErrorRegionCount; ++r) {
      const double samples = 3.0 * static_cast<double>(m.regions.pixels[r]);
      const double mse = samples > 0 ? m.regions.squared_error[r] / samples : 0.0;
      s["modes"][mode]["regions"][errorRegionName(static_cast<ErrorRegion>(r))] = {
          {"pixels", m.regions.pixels[r]},
          {"squared_error", m.regions.squared_error[r]},
          {"psnr_db", samples > 0 ? nlohmann::json(psnrFromMse(mse)) : nlohmann::json(nullptr)}};
    }
    const auto shares = regionSharesAgainstNormal(scene.modes, mode);
    if (!shares.empty()) s["modes"][mode]["share_of_difference_from_normal"] = shares;
  }
  return s;
}

SceneResult sceneResultFromJson(const std::string& name, const nlohmann::json& s) {
  SceneResult scene;
  scene.name = name;
  scene.stresses = s.at("stresses").get<std::string>();
  scene.cameras = s.at("cameras").get<int>();
  scene.view_jump_degrees = s.value("view_jump_degrees", 0.0);
  scene.novel_view_degrees = s.value("novel_view_degrees", 0.0);
  scene.camera_kept = s.value("camera_kept", false);
  scene.hull_ms = s.at("hull_ms").get<double>();
  scene.codec_ms = s.value("codec_ms", 0.0);
  scene.hull_ms_p95 = s.value("hull_ms_p95", scene.hull_ms);
  scene.refine_ms = s.value("refine_ms", 0.0);
  scene.refine_ms_p95 = s.value("refine_ms_p95", scene.refine_ms);
  scene.codec_ms_p95 = s.value("codec_ms_p95", scene.codec_ms);
  if (s.contains("codec_stages_ms")) {
    for (const auto& [stage, ms] : s.at("codec_stages_ms").items()) {
      scene.codec_stage_ms[stage] = ms.at("p50").get<double>();
      scene.codec_stage_ms_p95[stage] = ms.at("p95").get<double>();
    }
  }
  scene.triangles = s.at("triangles").get<double>();
  scene.bytes_per_frame = s.at("bytes_per_frame").get<double>();
  scene.feather_bytes_per_frame = s.value("feather_bytes_per_frame", 0.0);
  scene.pod_link_bytes_per_frame = s.value("pod_link_bytes_per_frame", 0.0);
  if (s.contains("hull")) {
    const auto& hull = s.at("hull");
    scene.chamfer_mm = measuredFromJson(hull, "chamfer_mm");
    scene.silhouette_iou = hull.value("silhouette_iou", std::vector<double>{});
    scene.cells_visited = hull.value("cells_visited", 0.0);
    scene.voxel_mm = hull.value("voxel_mm", 0.0);
    scene.silhouette_error_mm = measuredFromJson(hull, "silhouette_error_mm");
    scene.dense_grid_points = hull.value("dense_grid_points", 0.0);
  }
  if (s.contains("segmentation")) {
    const auto& segmentation = s.at("segmentation");
    scene.mask_iou = segmentation.value("mask_iou", std::vector<double>{});
    scene.mask_iou_agreed = segmentation.value("mask_iou_agreed", std::vector<double>{});
    scene.shadow_taken = measuredFromJson(segmentation, "shadow_taken");
  }
  if (s.contains("montage_agreement")) {
    const auto& a = s.at("montage_agreement");
    scene.montage_agreement = {true, a.at("differing_pixel_share").get<double>(),
                               a.at("holoportation_error_share_there").get<double>(),
                               a.at("psnr_gain_bound_db").get<double>()};
  }
  for (const auto& [mode, m] : s.at("modes").items()) {
    ModeResult& r = scene.modes[mode];
    r.rmse_percent = m.at("rmse_percent").get<double>();
    r.psnr_db = m.at("psnr_db").get<double>();
    r.ssim = m.at("ssim").get<double>();
    r.flicker = measuredFromJson(m, "flicker");
    r.seam_visibility = measuredFromJson(m, "seam_visibility");
    r.images = m.at("images").get<size_t>();
    r.ms_per_new_mesh = m.at("ms_per_new_mesh").get<double>();
    r.ms_per_new_mesh_p95 = m.value("ms_per_new_mesh_p95", r.ms_per_new_mesh);
    r.client_bytes_per_frame = m.value("client_bytes_per_frame", 0.0);
    r.layers_ms = m.value("layers_ms", 0.0);
    r.layer_video_ms = m.value("layer_video_ms", 0.0);
    r.mesh_bytes_per_frame = m.value("mesh_bytes_per_frame", 0.0);
    r.layer_colour_bytes_per_frame = m.value("layer_colour_bytes_per_frame", 0.0);
    r.layer_camera_bytes_per_frame = m.value("layer_camera_bytes_per_frame", 0.0);
    r.atlas_moved = measuredFromJson(m, "atlas_moved");
    r.gpu_passes_ms = m.at("gpu_passes_ms").get<std::map<std::string, double>>();
    if (m.contains("regions")) {
      for (size_t k = 0; k < kErrorRegionCount; ++k) {
        const auto& region = m.at("regions").at(errorRegionName(static_cast<ErrorRegion>(k)));
        r.regions.pixels[k] = region.at("pixels").get<size_t>();
        r.regions.squared_error[k] = region.at("squared_error").get<double>();
      }
    }
  }
  return scene;
}

}  // namespace holofuse::eval
