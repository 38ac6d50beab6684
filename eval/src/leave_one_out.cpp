#include "eval/leave_one_out.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>

#include "base/statistics.h"
#include "capture_node/pod.h"
#include "common/depth_raster.h"
#include "common/image_io.h"
#include "dataset/dataset.h"
#include "dataset/inspection.h"
#include "eval_pipeline.h"
#include "fusion_server/fusion_worker.h"
#include "hull/hull_error.h"
#include "hull/visual_hull.h"
#include "metrics/geometry_metrics.h"
#include "metrics/image_metrics.h"
#include "render_client/client.h"
#include "render_client/reference/depth_map.h"
#include "render_client/reference/visibility.h"
#include "render_client/renderer.h"
#include "render_client/texture_field_passes.h"
#include "result_json.h"

namespace holofuse::eval {

using metrics::compareInMask;
using metrics::ErrorImage;
using metrics::errorImage;
using metrics::errorMapPicture;
using metrics::flicker;
using metrics::ImageQuality;
using metrics::kPsnrCap;
using metrics::PictureAgreement;
using metrics::pictureAgreement;
using metrics::psnrFromMse;
using metrics::regionErrors;
using metrics::regionsPicture;
using metrics::seamVisibility;

namespace {

namespace fs = std::filesystem;

// Medians and 95th percentiles as the live loop's report takes them
// (base/statistics.h, interpolated), so the two reports compare.
double median(const std::vector<double>& v) { return percentile(v, 50); }
double percentile95(const std::vector<double>& v) { return percentile(v, 95); }

// RGB like the true images (a render's alpha is not part of the comparison).
Status saveImage(const fs::path& path, const Image8& image) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  if (ec) return Status(StatusCode::kIoError, path.parent_path().string() + ": " + ec.message());
  Image8 rgb = image;
  if (image.channels == 4) {
    rgb = Image8(image.width, image.height, 3);
    for (size_t p = 0; p < static_cast<size_t>(image.width) * image.height; ++p) {
      for (int c = 0; c < 3; ++c) rgb.pixels[p * 3 + c] = image.pixels[p * 4 + c];
    }
  }
  return writePng(path.string(), rgb);
}

// A row's name as a folder name a shell takes unquoted: "clean (camera
// kept)" -> "clean_camera_kept", "dataset:temple" -> "dataset-temple",
// "clean +45 deg" -> "clean_+45_deg".
std::string folderName(const std::string& name) {
  std::string folder;
  for (char c : name) {
    if (c == ':') {
      folder += '-';
    } else if (c == ' ') {
      if (!folder.empty() && folder.back() != '_') folder += '_';
    } else if (c != '(' && c != ')') {
      folder += c;
    }
  }
  return folder;
}

// The pixels of a view that a seam triangle covers, the same for every
// mode so their seam visibility compares: triangles the rules of paper 000
// section 4.3 (the CPU reference) mark for a camera that looks within 60
// degrees of the view's direction, the cameras any blend leans on there,
// and always for the nearest camera (and any within a degree of it): with
// 4 pods 90 degrees apart no other pod is within 60 degrees of a held-out
// one, yet the two beside it carry the whole blend. (The seams of every
// camera together cover most of the subject.)
struct ViewRegions {
  Image8 seams;    // one channel, 255 on a seam triangle
  Image8 regions;  // eval::errorRegions of the truth's mask
};
ViewRegions viewRegions(const Mesh& mesh, const Camera& pose,
                        const std::vector<render::ViewImages>& views, const Image8& truth_mask,
                        const render::FieldParameters& fields) {
  std::vector<render::reference::PodView> pods;
  for (const auto& view : views) pods.push_back({view.camera, view.color, view.mask, view.feather});
  const auto sights = render::reference::vertexSights(mesh, pods);
  render::reference::VoteOptions vote;
  vote.delta = fields.vote_delta;
  vote.levels = fields.vote_levels;
  const auto trusted = render::reference::majorityVote(mesh, pods, sights, vote);
  const auto seams = render::reference::seamTriangles(mesh, sights, trusted);
  std::vector<uint8_t> seam(mesh.triangleCount(), 0);
  double nearest = -1;  // the largest cosine between a camera's direction and the view's
  for (const auto& pod : pods)
    nearest = std::max(nearest, glm::dot(pod.camera.forward(), pose.forward()));
  const double one_degree = glm::radians(1.0);
  const double lowest =
      std::min(0.5, std::cos(std::acos(std::clamp(nearest, -1.0, 1.0)) + one_degree));
  for (size_t i = 0; i < seams.size(); ++i) {
    if (glm::dot(pods[i].camera.forward(), pose.forward()) < lowest) continue;
    for (size_t t = 0; t < seam.size() && t < seams[i].size(); ++t) seam[t] |= seams[i][t] != 0;
  }
  std::vector<int32_t> triangle_of;
  const DepthMap depth = rasterizeDepth(mesh, pose, 0.05, &triangle_of);
  ViewRegions out;
  out.seams = Image8(pose.width, pose.height, 1, 0);
  for (size_t p = 0; p < triangle_of.size(); ++p) {
    if (triangle_of[p] >= 0 && seam[static_cast<size_t>(triangle_of[p])]) out.seams.pixels[p] = 255;
  }
  out.regions = errorRegions(truth_mask, depth, out.seams, 3, fields.relative_jump);
  return out;
}

// A scene to evaluate, from the synthetic library or from a dataset: its
// cameras' reported poses, and every frame as the client would receive it.
struct SceneInput {
  std::vector<Camera> reported;
  std::vector<FrameData> frames;
};

// One view a row of the evaluation renders on every frame and compares
// with its truth.
struct ViewSequence {
  Camera pose;  // rendered from, at its size, to compare pixel for pixel
  // Before the scene's viewpoint jump, the pose rendered from instead (and
  // nothing compared): the jump then lands on pose.
  std::optional<Camera> pose_before_jump;
  // The camera whose image takes no part (not in the blend, the vote, the
  // seams or the global visibility), and whose hull without it is used
  // where one was carved; -1: every camera takes part.
  int left_out = -1;
  // The truth: camera truth's true image, or novel pose truth's
  // (FrameData::novel_truth).
  int truth = 0;
  bool novel_truth = false;
  std::string name;  // "camera 3", "novel 1": image file names and progress
};

// What one row renders and compares with: one sequence per view.
struct EvaluationPlan {
  std::string what;  // "held out camera", "camera kept", "novel view": for progress lines
  std::vector<ViewSequence> sequences;
};

std::pair<const Image8&, const Image8&> truthOf(const FrameData& frame,
                                                const ViewSequence& sequence) {
  const size_t k = static_cast<size_t>(sequence.truth);
  if (sequence.novel_truth) return {frame.novel_truth[k].color, frame.novel_truth[k].mask};
  return {frame.true_colors[k], frame.true_masks[k]};
}

// Leave-one-camera-out (or, with keep_camera, each chosen camera's pose
// with its image kept in): the chosen cameras' poses, each compared with
// its own image; under a viewpoint jump of jump_degrees along the ring,
// the first half of the frames render from the camera the jump starts at.
EvaluationPlan cameraPlan(const EvalOptions& options, const SceneInput& input, double jump_degrees,
                          bool keep_camera) {
  const int camera_count = static_cast<int>(input.reported.size());
  // A jump of this many cameras along the ring is the preset's angle.
  const int jump = static_cast<int>(std::lround(jump_degrees / 360.0 * camera_count));
  EvaluationPlan plan;
  plan.what = keep_camera ? "camera kept" : "held out camera";
  for (int held : heldOutCameras(camera_count, options.held_out_cameras)) {
    ViewSequence sequence;
    sequence.pose = input.reported[static_cast<size_t>(held)];
    if (jump != 0) {
      sequence.pose_before_jump = input.reported[static_cast<size_t>(
          ((held + jump) % camera_count + camera_count) % camera_count)];
    }
    sequence.left_out = keep_camera ? -1 : held;
    sequence.truth = held;
    sequence.name = "camera" + std::to_string(held);
    plan.sequences.push_back(std::move(sequence));
  }
  return plan;
}

// Novel views: each pose seen with every camera blended, compared with the
// scene's truth there (frames' novel_truth, in poses' order).
EvaluationPlan novelPlan(const std::vector<Camera>& poses) {
  EvaluationPlan plan;
  plan.what = "novel view";
  for (size_t j = 0; j < poses.size(); ++j) {
    ViewSequence sequence;
    sequence.pose = poses[j];
    sequence.truth = static_cast<int>(j);
    sequence.novel_truth = true;
    sequence.name = "novel" + std::to_string(j);
    plan.sequences.push_back(std::move(sequence));
  }
  return plan;
}

// Every mode, every sequence of the plan, every frame of one scene.
Status evaluateModes(const EvalOptions& options, render::VulkanContext& context,
                     const SceneInput& input, const EvaluationPlan& plan, SceneResult& result,
                     const std::function<void(const std::string&)>& progress) {
  const int frame_count = static_cast<int>(input.frames.size());
  const int jump_frame = frame_count / 2;  // for sequences with a pose before the jump
  // Seam pixels and error regions per (sequence, frame), shared by the modes.
  std::map<std::pair<int, int>, ViewRegions> region_cache;
  // holoportation's and montage4d's pictures per (sequence, frame), to
  // compare with each other when both modes run.
  const auto runs = [&](render::BlendMode mode) {
    return std::find(options.modes.begin(), options.modes.end(), mode) != options.modes.end();
  };
  const bool compare_pictures =
      runs(render::BlendMode::kHoloportation) && runs(render::BlendMode::kMontage4D);
  // The first of the two to run keeps its pictures, cut to the truth's
  // rectangle (all that is compared), until the second renders the same view.
  std::map<std::pair<int, int>, Image8> first_pictures;
  std::optional<render::BlendMode> first_mode;
  double holoportation_psnr = 0, best_montage_psnr = 0, error = 0, error_differing = 0;
  size_t compared = 0, pixels = 0, differing = 0;
  auto comparePictures = [&](const std::pair<int, int>& key, render::BlendMode mode,
                             const Image8& picture) {
    const auto [truth_color, truth_mask] = truthOf(input.frames[static_cast<size_t>(key.second)],
                                                   plan.sequences[static_cast<size_t>(key.first)]);
    const PixelRect rect = foregroundRect(truth_mask);
    if (!first_mode) first_mode = mode;
    if (rect.empty()) {
      // Nothing to compare: both modes score the cap (compareInMask), and so
      // does the best, so the means cover the same images as the modes'.
      if (mode != *first_mode) {
        holoportation_psnr += kPsnrCap;
        best_montage_psnr += kPsnrCap;
        ++compared;
      }
      return;
    }
    if (mode == *first_mode) {
      first_pictures[key] = cropImage(picture, rect);
      return;
    }
    const auto first = first_pictures.find(key);
    if (first == first_pictures.end()) return;
    const Image8 second = cropImage(picture, rect);
    const bool holoportation_first = *first_mode == render::BlendMode::kHoloportation;
    const PictureAgreement a = pictureAgreement(
        holoportation_first ? first->second : second, holoportation_first ? second : first->second,
        cropImage(truth_color, rect), cropImage(truth_mask, rect));
    first_pictures.erase(first);
    // The mean PSNR over images, as the modes' scores are.
    holoportation_psnr += psnrFromMse(a.a_squared_error / (3.0 * static_cast<double>(a.pixels)));
    best_montage_psnr += a.bestPsnrOfB();
    ++compared;
    pixels += a.pixels;
    differing += a.differing;
    error += a.a_squared_error;
    error_differing += a.a_squared_error_differing;
  };
  for (render::BlendMode mode : options.modes) {
    const std::string mode_name = render::blendModeName(mode);
    ModeResult& m = result.modes[mode_name];
    std::vector<double> mesh_ms;
    std::map<std::string, std::vector<double>> passes;
    double flicker_sum = 0;
    size_t flicker_pairs = 0;
    const auto mode_start = Clock::now();
    double seam_sum = 0;
    size_t seam_images = 0;
    for (int s = 0; s < static_cast<int>(plan.sequences.size()); ++s) {
      const ViewSequence& sequence = plan.sequences[static_cast<size_t>(s)];
      const Camera& pose = sequence.pose;
      render::Renderer renderer(context, pose.width, pose.height);
      renderer.setHalfPrecisionVertices(options.loop.render.half_precision_vertices);
      render::BlendSettings settings = options.loop.render.blend;
      settings.mode = mode;
      settings.frame_interval_s = 1.0 / options.fps;
      std::optional<ErrorImage> previous;
      for (int f = 0; f < frame_count; ++f) {
        const FrameData& frame = input.frames[static_cast<size_t>(f)];
        // Leave-one-out proper may carve without the held-out camera too.
        const auto without = sequence.left_out >= 0 ? frame.mesh_without.find(sequence.left_out)
                                                    : frame.mesh_without.end();
        const Mesh& mesh = without != frame.mesh_without.end() ? without->second : frame.mesh;
        renderer.setMesh(mesh);
        std::vector<render::ViewImages> others = frame.views;
        if (sequence.left_out >= 0) others.erase(others.begin() + sequence.left_out);
        renderer.setViews(others);
        const bool before_jump = sequence.pose_before_jump && f < jump_frame;
        const auto t0 = Clock::now();
        const Image8 picture =
            renderer.render(before_jump ? *sequence.pose_before_jump : pose, settings);
        mesh_ms.push_back(msSince(t0));
        const auto times = renderer.fieldTimesMs();
        for (size_t t = 0; t < times.size(); ++t) {
          if (times[t] >= 0)
            passes[render::TextureFieldPasses::stageNames()[t]].push_back(
                times[t]);  // -1: no such pass
        }
        if (before_jump) continue;  // not at the held-out pose yet: nothing to compare with
        const auto [truth_color, truth_mask] = truthOf(frame, sequence);
        const ImageQuality q = compareInMask(picture, truth_color, truth_mask);
        const auto key = std::make_pair(s, f);
        if (compare_pictures &&
            (mode == render::BlendMode::kHoloportation || mode == render::BlendMode::kMontage4D)) {
          comparePictures(key, mode, picture);
        }
        auto cached = region_cache.find(key);
        if (cached == region_cache.end()) {
          cached = region_cache
                       .emplace(key, viewRegions(mesh, pose, others, truth_mask,
                                                 options.loop.render.blend.fields))
                       .first;
        }
        const ViewRegions& regions = cached->second;
        m.regions.add(regionErrors(picture, truth_color, regions.regions));
        const double seams = seamVisibility(picture, truth_color, truth_mask, regions.seams);
        if (seams >= 0) {
          seam_sum += seams;
          ++seam_images;
        }
        m.rmse_percent += q.rmse_percent;
        m.psnr_db += q.psnr_db;
        m.ssim += q.ssim;
        ++m.images;
        ErrorImage error = errorImage(picture, truth_color, truth_mask);
        if (previous) {
          flicker_sum += flicker(*previous, error);
          ++flicker_pairs;
        }
        previous = std::move(error);
        if (options.save_images) {
          const fs::path dir =
              fs::path(options.out_dir) / "images" / folderName(result.name) / mode_name;
          const std::string stem = "frame" + std::to_string(frame.frame_id) + "_" + sequence.name;
          for (const auto& [suffix, image] :
               {std::pair<const char*, Image8>{"_rendered.png", picture},
                {"_true.png", truth_color},
                {"_mask.png", truth_mask},
                {"_error.png", errorMapPicture(picture, truth_color, truth_mask)},
                {"_regions.png", regionsPicture(regions.regions)}}) {
            HOLOFUSE_RETURN_IF_ERROR(saveImage(dir / (stem + suffix), image));
          }
        }
      }
      if (progress) {
        // Leave-one-out counts its cameras; novel views their poses.
        const size_t of = sequence.novel_truth ? plan.sequences.size() : input.reported.size();
        progress(result.name + " / " + mode_name + ": " + plan.what + " " +
                 std::to_string(sequence.truth) + " of " + std::to_string(of) + ", " +
                 std::to_string(frame_count) + " frames, " +
                 std::to_string(static_cast<int>(msSince(mode_start) / 1000)) + " s so far");
      }
    }
    if (m.images > 0) {
      m.seam_visibility = seam_images ? seam_sum / static_cast<double>(seam_images) : -1.0;
      m.rmse_percent /= static_cast<double>(m.images);
      m.psnr_db /= static_cast<double>(m.images);
      m.ssim /= static_cast<double>(m.images);
    }
    m.flicker = flicker_pairs ? flicker_sum / static_cast<double>(flicker_pairs) : -1.0;
    m.ms_per_new_mesh = median(mesh_ms);
    m.ms_per_new_mesh_p95 = percentile95(mesh_ms);
    for (const auto& [pass, values] : passes) m.gpu_passes_ms[pass] = median(values);
  }
  if (compared > 0) {
    ModeAgreement& agreement = result.montage_agreement;
    agreement.measured = true;
    agreement.differing_share =
        pixels ? static_cast<double>(differing) / static_cast<double>(pixels) : 0.0;
    agreement.holoportation_error_share = error > 0 ? error_differing / error : 0.0;
    agreement.gain_bound_db =
        (best_montage_psnr - holoportation_psnr) / static_cast<double>(compared);
  }
  return Status::ok();
}

// The leave-one-out row's scene again, with each held-out camera's image
// kept in the blend: what the camera's own pose scores when its image
// takes part.
StatusOr<SceneResult> cameraKeptRow(const EvalOptions& options, render::VulkanContext& context,
                                    const SceneInput& input, const SceneResult& leave_one_out,
                                    const std::function<void(const std::string&)>& progress) {
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
  for (const auto& frame : input.frames) {
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
    const auto t0 = Clock::now();
    Mesh hull;
    if (options.loop.fusion.hull_error_target > 0 && input.frames.empty()) {
      // The error target picks the voxel on the first frame; the rest follow it.
      hull::HullForTarget found = hull::carveToErrorTarget(
          hull_views, hull_options, options.loop.fusion.hull_error_target, &frame.hull_stats);
      hull = std::move(found.mesh);
      hull_options.voxel_size = found.voxel_size;
    } else {
      hull = hull::carveVisualHull(hull_views, hull_options, &frame.hull_stats);
    }
    frame.hull_ms = msSince(t0);
    HOLOFUSE_ASSIGN_OR_RETURN(
        hull, refineCarved(options, group, hull_views, std::move(hull), hull_options, frame));
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
    const EvalOptions& options, const std::function<void(const std::string&)>& progress) {
  HOLOFUSE_ASSIGN_OR_RETURN(const std::vector<const scene::ScenePreset*> presets,
                            checkedScenes(options));
  // (The Vulkan context throws when no device answers: said here as an
  // error naming the device asked for.)
  std::optional<render::VulkanContext> started;
  try {
    started.emplace(options.device);
  } catch (const std::exception& e) {
    return Status(StatusCode::kIoError, "Vulkan device '" + options.device + "': " + e.what());
  }
  render::VulkanContext& context = *started;
  std::vector<SceneResult> results;
  for (const auto& dir : options.datasets) {
    SceneResult result;
    HOLOFUSE_ASSIGN_OR_RETURN(const SceneInput input, loadDatasetScene(options, dir, result));
    summariseFrames(input, result);
    result.silhouette_error_mm = silhouetteErrorMm(input.frames[0]);
    HOLOFUSE_RETURN_IF_ERROR(evaluateModes(options, context, input,
                                           cameraPlan(options, input, 0, false), result, progress));
    results.push_back(std::move(result));
    if (options.camera_kept) {
      HOLOFUSE_ASSIGN_OR_RETURN(SceneResult kept,
                                cameraKeptRow(options, context, input, results.back(), progress));
      results.push_back(std::move(kept));
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
    const SceneResult leave_one_out = result;
    results.push_back(std::move(result));
    if (options.camera_kept) {
      HOLOFUSE_ASSIGN_OR_RETURN(SceneResult kept,
                                cameraKeptRow(options, context, input, leave_one_out, progress));
      results.push_back(std::move(kept));
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
      results.push_back(std::move(row));
    }
  }
  return results;
}

}  // namespace holofuse::eval
