#include "eval/leave_one_out.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>

#include "base/statistics.h"
#include "capture_node/pod.h"
#include "dataset/dataset.h"
#include "dataset/inspection.h"
#include "eval_pipeline.h"
#include "evaluate_plan.h"
#include "fusion_server/fusion_worker.h"
#include "hull/hull_error.h"
#include "hull/visual_hull.h"
#include "metrics/geometry_metrics.h"
#include "metrics/image_metrics.h"
#include "render_client/client.h"
#include "render_client/renderer.h"
#include "result_json.h"

namespace holofuse::eval {

namespace {

namespace fs = std::filesystem;

// The leave-one-out row's scene again, with each held-out camera's image
// kept in the blend: what the camera's own pose scores when its image
// takes part.
StatusOr<SceneResult> cameraKeptRow(const EvalOptions& options, gpu::VulkanContext& context,
                                    const SceneInput& input, const SceneResult& leave_one_out,
                                    RunProgress& progress) {
  SceneResult row = leave_one_out;
  row.modes.clear();
  row.name = leave_one_out.name + " (camera kept)";
  row.camera_kept = true;
  const EvaluationPlan plan = cameraPlan(options, input, row.view_jump_degrees, true);
  HOLOFUSE_RETURN_IF_ERROR(evaluateModes(options, context, input, plan, row, progress));
  return row;
}

// The first frame's hull against the masks the server carved from.
double silhouetteErrorMm(const FrameData& frame) {
  std::vector<hull::HullView> views;
  for (const auto& view : frame.views) views.push_back({view.camera, view.mask, {}});
  const hull::SilhouetteError error = hull::silhouetteError(frame.mesh, views);
  return error.valid ? 1000.0 * error.mean_m : -1.0;
}

// Frame statistics shared by both sources.
void summariseFrames(const SceneInput& input, SceneResult& result) {
  std::vector<double> hull_ms, refine_ms, codec_ms;
  std::map<std::string, std::vector<double>> stage_ms;
  const double n = static_cast<double>(input.frames.size());
  uint64_t shadow = 0, shadow_taken = 0;
  for (const auto& frame : input.frames) {
    if (result.mask_iou.size() < frame.mask_iou.size())
      result.mask_iou.resize(frame.mask_iou.size(), 1.0);
    for (size_t c = 0; c < frame.mask_iou.size(); ++c)
      result.mask_iou[c] = std::min(result.mask_iou[c], frame.mask_iou[c]);
    if (result.mask_iou_agreed.size() < frame.mask_iou_agreed.size())
      result.mask_iou_agreed.resize(frame.mask_iou_agreed.size(), 1.0);
    for (size_t c = 0; c < frame.mask_iou_agreed.size(); ++c)
      result.mask_iou_agreed[c] = std::min(result.mask_iou_agreed[c], frame.mask_iou_agreed[c]);
    shadow += frame.shadow_pixels;
    shadow_taken += frame.shadow_taken;
    hull_ms.push_back(frame.hull_ms);
    refine_ms.push_back(frame.refine_ms);
    double sum = 0;
    for (const std::string& stage : codecStages()) {
      const auto it = frame.codec_ms.find(stage);
      const double ms = it == frame.codec_ms.end() ? 0.0 : it->second;
      sum += ms;
      const auto pods = frame.per_pod_ms.find(stage);
      if (pods == frame.per_pod_ms.end()) {
        stage_ms[stage].push_back(ms);
      } else {
        stage_ms[stage].insert(stage_ms[stage].end(), pods->second.begin(), pods->second.end());
      }
    }
    codec_ms.push_back(sum);
    result.bytes_per_frame += static_cast<double>(frame.client_link_bytes) / n;
    result.feather_bytes_per_frame += static_cast<double>(frame.feather_bytes) / n;
    result.pod_link_bytes_per_frame += static_cast<double>(frame.pod_link_bytes) / n;
    result.cells_visited += static_cast<double>(frame.hull_stats.cells_visited()) / n;
    result.dense_grid_points += static_cast<double>(frame.hull_stats.grid_points) / n;
    result.triangles += static_cast<double>(frame.mesh.triangleCount()) / n;
  }
  if (shadow > 0)
    result.shadow_taken = static_cast<double>(shadow_taken) / static_cast<double>(shadow);
  result.hull_ms = median(hull_ms);
  result.codec_ms = median(codec_ms);
  result.hull_ms_p95 = percentile95(hull_ms);
  result.refine_ms = median(refine_ms);
  result.refine_ms_p95 = percentile95(refine_ms);
  result.codec_ms_p95 = percentile95(codec_ms);
  for (const auto& [stage, ms] : stage_ms) {
    result.codec_stage_ms[stage] = median(ms);
    result.codec_stage_ms_p95[stage] = percentile95(ms);
  }
}

// A dataset (recorded or imported): its cameras' images and masks, the
// hull carved in its capture volume at its voxel size (options.loop.fusion.hull.voxel_size
// when the dataset names none or a voxel was given), through Draco. Its masks are the truth the
// images are compared inside; there is no true surface.
StatusOr<SceneInput> loadDatasetScene(const EvalOptions& options, const std::string& dir,
                                      SceneResult& result) {
  auto dataset = dataset::Dataset::open(dir);
  if (!dataset.isOk()) return dataset.status();
  SceneInput input;
  std::vector<Camera> cameras;
  for (const auto& [id, cam] : dataset->cameras()) {
    HOLOFUSE_ASSIGN_OR_RETURN(const protocol::Calibration calibration,
                              dataset->readCalibration(id));
    cameras.push_back(fromCalibration(calibration));
  }
  if (cameras.size() < 2) {
    return Status(StatusCode::kMalformed, dir + ": leave-one-camera-out needs at least 2 cameras");
  }
  input.reported = cameras;
  hull::HullOptions hull_options =
      dataset::hullOptionsFor(*dataset, options.loop.fusion.hull.voxel_size);
  if (!options.voxel_from_dataset) hull_options.voxel_size = options.loop.fusion.hull.voxel_size;
  // The frame ids every camera holds, in order; each camera's record in
  // camera order (the first, should a camera repeat an id).
  std::map<uint64_t, std::map<uint32_t, dataset::RecordInfo>> by_id;
  for (const auto& [id, cam] : dataset->cameras()) {
    for (const auto& r : cam.frames) by_id[r.frame_id].try_emplace(id, r);
  }
  for (const auto& [frame_id, by_camera] : by_id) {
    if (by_camera.size() != cameras.size()) continue;
    if (static_cast<int>(input.frames.size()) >= options.frames) break;
    std::vector<dataset::RecordInfo> records;
    for (const auto& [id, r] : by_camera) records.push_back(r);
    FrameData frame;
    frame.frame_id = frame_id;
    fusion::FrameGroup group;
    group.frame_id = frame_id;
    for (size_t c = 0; c < records.size(); ++c) {
      auto recorded = dataset->readFrame(records[c]);
      if (!recorded.isOk()) return recorded.status();
      // The pods' encoding is not timed: the recording was made. The truth
      // is the recorded image and mask, back in their whole frame.
      HOLOFUSE_ASSIGN_OR_RETURN(const fusion::PodImages* received,
                                receivePodFrame(recorded->bytes, cameras[c], dir, group, frame));
      const fusion::PodImages& pod = *received;
      const Camera& cam = cameras[c];
      frame.true_colors.push_back(
          placeInFrame(pod.color, pod.offset_x, pod.offset_y, cam.width, cam.height));
      frame.true_masks.push_back(
          placeInFrame(pod.mask, pod.offset_x, pod.offset_y, cam.width, cam.height));
    }
    const std::vector<hull::HullView> hull_views = fusion::hullViewsOf(group);
    fusion::FusedMesh carved;
    if (options.loop.fusion.hull_error_target > 0 && input.frames.empty()) {
      // The error target picks the voxel on the first frame; the rest follow it.
      const auto t0 = Clock::now();
      hull::HullForTarget found = hull::carveToErrorTarget(
          hull_views, hull_options, options.loop.fusion.hull_error_target, &frame.hull_stats);
      frame.hull_ms = msSince(t0);
      carved.carved = std::move(found.mesh);
      hull_options.voxel_size = found.voxel_size;
    } else {
      carved = fusion::carveHull(hull_views, hull_options, &frame.hull_stats);
      frame.hull_ms = carved.carveMs();
    }
    HOLOFUSE_ASSIGN_OR_RETURN(
        const Mesh hull,
        refineCarved(options, group, hull_views, std::move(carved), hull_options, frame));
    HOLOFUSE_RETURN_IF_ERROR(sendToClient(std::move(group), hull, options, cameras, frame));
    input.frames.push_back(std::move(frame));
  }
  if (input.frames.empty())
    return Status(StatusCode::kMalformed, dir + ": no frame id is held by every camera");
  result.name = "dataset:" + fs::path(dir).lexically_normal().filename().string();
  if (result.name == "dataset:")
    result.name = "dataset:" + fs::path(dir).lexically_normal().parent_path().filename().string();
  result.stresses = dataset->metadata() ? dataset->metadata()->source : "a recording";
  result.cameras = static_cast<int>(cameras.size());
  result.chamfer_mm = -1;  // no true surface
  result.voxel_mm = 1000.0 * hull_options.voxel_size;
  for (size_t i = 0; i < cameras.size(); ++i) {
    result.silhouette_iou.push_back(
        metrics::silhouetteIoU(input.frames[0].mesh, cameras[i], input.frames[0].true_masks[i]));
  }
  return input;
}

Status invalid(const std::string& message) { return Status(StatusCode::kMalformed, message); }

// The scenes options name (the whole library when none and no dataset),
// or what is wrong with the options.
StatusOr<std::vector<const scene::ScenePreset*>> checkedScenes(const EvalOptions& options) {
  std::vector<const scene::ScenePreset*> presets;
  if (options.scenes.empty() && options.datasets.empty()) {
    for (const auto& preset : scene::sceneLibrary()) presets.push_back(&preset);
  }
  for (const auto& name : options.scenes) {
    const scene::ScenePreset* preset = scene::findScene(name);
    if (preset == nullptr)
      return invalid("unknown scene '" + name + "'; valid scenes: " + scene::sceneNames());
    presets.push_back(preset);
  }
  if (options.frames < 1) return invalid("--frames must be at least 1");
  if (options.geometry != "hull" && options.geometry != "truth")
    return invalid("geometry '" + options.geometry + "': expected hull or truth");
  if (options.geometry == "truth" && options.hull_without_held_out)
    return invalid("--hull-without-held-out carves the hull again: it needs --geometry hull");
  if (options.geometry == "truth" && !options.datasets.empty())
    return invalid("--geometry truth needs a synthetic scene: a dataset has no true surface");
  return presets;
}

}  // namespace

StatusOr<std::vector<SceneResult>> runLeaveOneOut(
    const EvalOptions& options, const std::function<void(const std::string&)>& say) {
  HOLOFUSE_ASSIGN_OR_RETURN(const std::vector<const scene::ScenePreset*> presets,
                            checkedScenes(options));
  // Each scene's leave-one-out row, its camera-kept row, each novel view.
  const size_t kept = options.camera_kept ? 1 : 0;
  RunProgress progress(say, options.datasets.size() * (1 + kept) +
                                presets.size() * (1 + kept + options.novel_view_degrees.size()));
  // (The Vulkan context throws when no device answers: said here as an
  // error naming the device asked for.)
  std::optional<gpu::VulkanContext> started;
  try {
    started.emplace(options.device);
  } catch (const std::exception& e) {
    return Status(StatusCode::kIoError, "Vulkan device '" + options.device + "': " + e.what());
  }
  gpu::VulkanContext& context = *started;
  std::vector<SceneResult> results;
  for (const auto& dir : options.datasets) {
    SceneResult result;
    HOLOFUSE_ASSIGN_OR_RETURN(const SceneInput input, loadDatasetScene(options, dir, result));
    summariseFrames(input, result);
    result.silhouette_error_mm = silhouetteErrorMm(input.frames[0]);
    HOLOFUSE_RETURN_IF_ERROR(evaluateModes(options, context, input,
                                           cameraPlan(options, input, 0, false), result, progress));
    progress.partDone();
    results.push_back(std::move(result));
    if (options.camera_kept) {
      HOLOFUSE_ASSIGN_OR_RETURN(SceneResult kept_row,
                                cameraKeptRow(options, context, input, results.back(), progress));
      progress.partDone();
      results.push_back(std::move(kept_row));
    }
  }
  for (const scene::ScenePreset* preset : presets) {
    scene::SceneOptions scene_options = preset->scene;
    scene_options.frames_per_second = options.fps;
    const scene::SyntheticScene scene(scene_options);
    const int camera_count = options.cameras > 0 ? options.cameras : preset->cameras;
    const std::vector<Camera> truth =
        scene::SyntheticScene::cameraRig(camera_count, options.width, options.height);
    SceneInput input;
    std::vector<Image8> plates;
    for (const Camera& camera : truth) {
      input.reported.push_back(scene::reportedCalibration(camera, preset->calibration_error_degrees,
                                                          preset->calibration_error_metres,
                                                          scene_options.seed));
      plates.push_back(scene.backgroundPlate(camera));
    }
    EvalOptions scene_eval = options;
    if (options.loop.fusion.hull_error_target > 0 && options.geometry == "hull") {
      // The error target picks the voxel on the first frame; the rest follow it.
      std::vector<hull::HullView> views;
      for (size_t i = 0; i < truth.size(); ++i) {
        capture::PodCapture capture = capture::capturePodFrame(
            scene, truth[i], plates[i], options.first_frame, static_cast<uint16_t>(i));
        views.push_back({input.reported[i], capture.mask, capture.feather});
      }
      hull::HullOptions hull_options;
      hull_options.voxel_size = options.loop.fusion.hull.voxel_size;
      scene_eval.loop.fusion.hull.voxel_size =
          hull::carveToErrorTarget(views, hull_options, options.loop.fusion.hull_error_target)
              .voxel_size;
    }
    SceneResult result;
    result.name = preset->name;
    result.voxel_mm = 1000.0 * scene_eval.loop.fusion.hull.voxel_size;
    result.stresses = preset->stresses;
    result.cameras = camera_count;
    result.view_jump_degrees = preset->view_jump_degrees;
    for (int f = 0; f < options.frames; ++f) {
      HOLOFUSE_ASSIGN_OR_RETURN(FrameData frame,
                                prepareFrame(scene_eval, scene, truth, input.reported, plates,
                                             options.first_frame + static_cast<uint64_t>(f)));
      input.frames.push_back(std::move(frame));
    }
    summariseFrames(input, result);
    result.silhouette_error_mm = silhouetteErrorMm(input.frames[0]);
    {
      const Mesh truth_surface = scene.truthMesh(options.first_frame, 0.01);
      result.chamfer_mm = 1000.0 * metrics::chamferDistance(input.frames[0].mesh, truth_surface);
      for (size_t i = 0; i < truth.size(); ++i) {
        result.silhouette_iou.push_back(
            metrics::silhouetteIoU(input.frames[0].mesh, truth[i], input.frames[0].true_masks[i]));
      }
    }
    HOLOFUSE_RETURN_IF_ERROR(evaluateModes(
        options, context, input, cameraPlan(options, input, result.view_jump_degrees, false),
        result, progress));
    progress.partDone();
    const SceneResult leave_one_out = result;
    results.push_back(std::move(result));
    if (options.camera_kept) {
      HOLOFUSE_ASSIGN_OR_RETURN(SceneResult kept_row,
                                cameraKeptRow(options, context, input, leave_one_out, progress));
      progress.partDone();
      results.push_back(std::move(kept_row));
    }
    for (double degrees : options.novel_view_degrees) {
      // The same frames, seen from beside the chosen pods with all of them
      // blended; the scene renders the truth there.
      SceneInput novel = input;
      std::vector<Camera> poses;
      for (int k : heldOutCameras(camera_count, options.held_out_cameras)) {
        poses.push_back(scene::SyntheticScene::ringPose(360.0 * k / camera_count + degrees,
                                                        static_cast<uint32_t>(1000 + k),
                                                        options.width, options.height));
      }
      for (FrameData& frame : novel.frames) {
        for (const Camera& pose : poses)
          frame.novel_truth.push_back(scene.render(pose, frame.frame_id));
      }
      SceneResult row = leave_one_out;
      row.modes.clear();
      char suffix[32];
      std::snprintf(suffix, sizeof(suffix), " %+g deg", degrees);
      row.name = preset->name + suffix;
      row.novel_view_degrees = degrees;
      row.view_jump_degrees = 0;
      HOLOFUSE_RETURN_IF_ERROR(
          evaluateModes(options, context, novel, novelPlan(poses), row, progress));
      progress.partDone();
      results.push_back(std::move(row));
    }
  }
  return results;
}

}  // namespace holofuse::eval
