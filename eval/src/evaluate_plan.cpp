// Rendering and scoring an evaluation plan: each mode renders each view of
// the plan on every frame and is compared with the view's truth (paper 000
// section 5.1's leave-one-out, or novel poses against a synthetic truth).
#include "evaluate_plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>

#include "base/eta.h"
#include "base/statistics.h"
#include "eval/view_maps.h"
#include "fusion_server/layer_stage.h"
#include "geometry/depth_raster.h"
#include "image/image_io.h"
#include "metrics/image_metrics.h"
#include "protocol/frame.h"
#include "render_client/client.h"
#include "render_client/reference/depth_map.h"
#include "render_client/reference/visibility.h"
#include "render_client/renderer.h"
#include "render_client/texture_field_passes.h"
#include "texture/texture_atlas.h"

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
  return writeImage(path.string(), rgb);
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
  Image8 seams;                      // one channel, 255 on a seam triangle
  Image8 regions;                    // eval::errorRegions of the truth's mask
  std::vector<int32_t> triangle_of;  // per pixel, the visible triangle (-1: none)
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
  out.triangle_of = std::move(triangle_of);
  return out;
}

}  // namespace

std::pair<const Image8&, const Image8&> truthOf(const FrameData& frame,
                                                const ViewSequence& sequence) {
  const size_t k = static_cast<size_t>(sequence.truth);
  if (sequence.novel_truth) return {frame.novel_truth[k].color, frame.novel_truth[k].mask};
  return {frame.true_colors[k], frame.true_masks[k]};
}

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

// What the server's layer stages cost for one frame.
struct LayeredFrameCost {
  size_t bytes = 0;                           // the TextureBundle on the wire
  size_t colour_bytes = 0, camera_bytes = 0;  // of them, the layers' planes
  double layers_ms = 0, video_ms = 0;
  fusion::LayerStats stats;
};

// Mode layered as the loop runs it: the server's layer stage builds the
// frame's texture layers from views (its atlas and video streams kept from
// frame to frame in stage) and codes them (as video under --layer-video),
// and the client decodes them (its video streams in streams) and places
// the atlas on the mesh from the layout.
StatusOr<LayeredFrameCost> layeredFrame(const EvalOptions& options, fusion::LayerStage& stage,
                                        const Mesh& mesh,
                                        const std::vector<render::ViewImages>& views,
                                        uint64_t frame_id, render::LayerStreams* streams,
                                        Mesh* placed, LayeredViews* layers) {
  std::vector<LayerView> sources;
  std::vector<uint32_t> camera_ids;
  std::map<uint32_t, Camera> cameras;
  for (const render::ViewImages& view : views) {
    sources.push_back(
        {&view.camera, &view.color, &view.mask, view.feather.empty() ? nullptr : &view.feather});
    camera_ids.push_back(view.camera.id);
    cameras[view.camera.id] = view.camera;
  }
  hull::HullOptions hull;  // the hull's lattice, as prepareFrame carves
  hull.voxel_size = options.loop.fusion.hull.voxel_size;
  const fusion::FusionSettings& fusion = options.loop.fusion;
  protocol::TextureBundle bundle;
  bundle.frame_id = frame_id;
  std::deque<std::vector<uint8_t>> storage;
  LayeredFrameCost cost;
  const auto t0 = Clock::now();
  HOLOFUSE_RETURN_IF_ERROR(
      stage.build(mesh, sources, camera_ids, hull, fusion.layers, &cost.stats));
  if (isVideoCodec(fusion.layers.video.codec)) {
    cost.layers_ms = msSince(t0);
    const auto t1 = Clock::now();
    HOLOFUSE_RETURN_IF_ERROR(stage.encodeVideo(false, bundle, storage));
    cost.video_ms = msSince(t1);
  } else {
    stage.encodeLz4(fusion.image_codec, fusion.lz4_acceleration, fusion.lz4_hc_level, bundle,
                    storage);
    cost.layers_ms = msSince(t0);
  }
  cost.bytes = protocol::encodeFrame(bundle, 0).size();
  for (const auto& planes : bundle.layers->layers) {
    for (const protocol::Plane& plane : planes)
      (plane.kind == protocol::PlaneKind::kCamera ? cost.camera_bytes : cost.colour_bytes) +=
          plane.data.size();
  }
  if (placed == nullptr) return cost;
  HOLOFUSE_ASSIGN_OR_RETURN(render::DecodedLayers decoded,
                            render::layersOfBundle(*bundle.layers, cameras, streams));
  *placed = mesh;
  HOLOFUSE_RETURN_IF_ERROR(applyAtlasLayout(*placed, decoded.layout).status());
  *layers = std::move(decoded.views);
  return cost;
}

namespace {

// holoportation's and montage4d's pictures of the same views, compared
// with each other: the first of the two to render a view keeps its picture,
// cut to the truth's rectangle (all that is compared), until the second
// renders it (metrics: pictureAgreement).
class PictureComparison {
 public:
  void add(const std::pair<int, int>& key, render::BlendMode mode, const Image8& picture,
           const Image8& truth_color, const Image8& truth_mask) {
    const PixelRect rect = foregroundRect(truth_mask);
    if (!first_mode_) first_mode_ = mode;
    if (rect.empty()) {
      // Nothing to compare: both modes score the cap (compareInMask), and so
      // does the best, so the means cover the same images as the modes'.
      if (mode != *first_mode_) {
        holoportation_psnr_ += kPsnrCap;
        best_montage_psnr_ += kPsnrCap;
        ++compared_;
      }
      return;
    }
    if (mode == *first_mode_) {
      first_pictures_[key] = cropImage(picture, rect);
      return;
    }
    const auto first = first_pictures_.find(key);
    if (first == first_pictures_.end()) return;
    const Image8 second = cropImage(picture, rect);
    const bool holoportation_first = *first_mode_ == render::BlendMode::kHoloportation;
    const PictureAgreement a = pictureAgreement(
        holoportation_first ? first->second : second, holoportation_first ? second : first->second,
        cropImage(truth_color, rect), cropImage(truth_mask, rect));
    first_pictures_.erase(first);
    // The mean PSNR over images, as the modes' scores are.
    holoportation_psnr_ += psnrFromMse(a.a_squared_error / (3.0 * static_cast<double>(a.pixels)));
    best_montage_psnr_ += a.bestPsnrOfB();
    ++compared_;
    pixels_ += a.pixels;
    differing_ += a.differing;
    error_ += a.a_squared_error;
    error_differing_ += a.a_squared_error_differing;
  }

  // Left unmeasured when no view was compared.
  void into(ModeAgreement& agreement) const {
    if (compared_ == 0) return;
    agreement.measured = true;
    agreement.differing_share =
        pixels_ ? static_cast<double>(differing_) / static_cast<double>(pixels_) : 0.0;
    agreement.holoportation_error_share = error_ > 0 ? error_differing_ / error_ : 0.0;
    agreement.gain_bound_db =
        (best_montage_psnr_ - holoportation_psnr_) / static_cast<double>(compared_);
  }

 private:
  std::map<std::pair<int, int>, Image8> first_pictures_;
  std::optional<render::BlendMode> first_mode_;
  double holoportation_psnr_ = 0, best_montage_psnr_ = 0, error_ = 0, error_differing_ = 0;
  size_t compared_ = 0, pixels_ = 0, differing_ = 0;
};

// --save-images: a view's picture, its truth, mask, error and regions as
// PNG, the error in float and, in the field modes, whose image weighs where.
Status saveViewImages(const EvalOptions& options, const std::string& scene,
                      const std::string& mode_name, uint64_t frame_id, const ViewSequence& sequence,
                      const Image8& picture, const Image8& truth_color, const Image8& truth_mask,
                      const ViewRegions& regions, const Mesh& mesh,
                      const std::vector<render::ViewImages>& others, render::Renderer& renderer) {
  const fs::path dir = fs::path(options.out_dir) / "images" / folderName(scene) / mode_name;
  const std::string stem = "frame" + std::to_string(frame_id) + "_" + sequence.name;
  for (const auto& [suffix, image] :
       {std::pair<const char*, Image8>{"_rendered.png", picture},
        {"_true.png", truth_color},
        {"_mask.png", truth_mask},
        {"_error.png", errorMapPicture(picture, truth_color, truth_mask)},
        {"_regions.png", regionsPicture(regions.regions)}}) {
    HOLOFUSE_RETURN_IF_ERROR(saveImage(dir / (stem + suffix), image));
  }
  // The same in float, and whose image weighs where (field modes).
  const FloatMap error_map = signedErrorMap(picture, truth_color, truth_mask);
  HOLOFUSE_RETURN_IF_ERROR(writeFloatImage((dir / (stem + "_error.exr")).string(),
                                           sequence.pose.width, sequence.pose.height,
                                           error_map.channels, error_map.values));
  std::vector<uint32_t> camera_ids;
  for (const auto& view : others) camera_ids.push_back(view.camera.id);
  const FloatMap weight_map = viewWeightMap(mesh, sequence.pose, regions.triangle_of,
                                            renderer.readFields().weights, camera_ids);
  if (!weight_map.channels.empty()) {
    HOLOFUSE_RETURN_IF_ERROR(writeFloatImage((dir / (stem + "_weights.exr")).string(),
                                             sequence.pose.width, sequence.pose.height,
                                             weight_map.channels, weight_map.values));
  }
  return Status::ok();
}

// What the client link carries a frame in this mode: the loop's frames,
// or for layers the mesh, the layers of every camera (as the live server
// builds them) and the stats; with the layer stage's times.
Status measureClientLink(const EvalOptions& options, const SceneInput& input, bool layered,
                         ModeResult& m, std::vector<double>& layers_ms,
                         std::vector<double>& layer_video_ms) {
  const double frame_count = static_cast<double>(input.frames.size());
  m.client_bytes_per_frame = 0;
  m.mesh_bytes_per_frame = 0;
  for (const FrameData& frame : input.frames)
    m.mesh_bytes_per_frame += static_cast<double>(frame.mesh_bytes) / frame_count;
  if (layered) {
    fusion::LayerStage stage;
    double moved = 0;
    int moved_frames = 0;
    m.layer_colour_bytes_per_frame = m.layer_camera_bytes_per_frame = 0;
    for (const FrameData& frame : input.frames) {
      HOLOFUSE_ASSIGN_OR_RETURN(const LayeredFrameCost cost,
                                layeredFrame(options, stage, frame.mesh, frame.views,
                                             frame.frame_id, nullptr, nullptr, nullptr));
      layers_ms.push_back(cost.layers_ms);
      if (cost.video_ms > 0) layer_video_ms.push_back(cost.video_ms);
      m.client_bytes_per_frame +=
          static_cast<double>(frame.client_link_bytes - frame.bundle_bytes + cost.bytes) /
          frame_count;
      m.layer_colour_bytes_per_frame += static_cast<double>(cost.colour_bytes) / frame_count;
      m.layer_camera_bytes_per_frame += static_cast<double>(cost.camera_bytes) / frame_count;
      if (&frame != &input.frames.front()) {
        moved += cost.stats.atlas.movedFraction();
        ++moved_frames;
      }
    }
    m.atlas_moved = moved_frames > 0 ? moved / moved_frames : -1.0;
  } else {
    for (const FrameData& frame : input.frames)
      m.client_bytes_per_frame += static_cast<double>(frame.client_link_bytes) / frame_count;
  }
  return Status::ok();
}

}  // namespace

void RunProgress::say(const std::string& line, double part_done) {
  if (!sink_) return;
  const double done = static_cast<double>(parts_done_) + part_done;
  std::string whole;
  if (parts_ > 1) {
    whole = "; the run: part " + std::to_string(std::min(parts_done_ + 1, parts_)) + " of " +
            std::to_string(parts_) + ", " +
            eta_.textOfShares(done, static_cast<double>(parts_) - done);
  }
  sink_(line + whole);
}

Status evaluateModes(const EvalOptions& options, gpu::VulkanContext& context,
                     const SceneInput& input, const EvaluationPlan& plan, SceneResult& result,
                     RunProgress& progress) {
  const int frame_count = static_cast<int>(input.frames.size());
  const int jump_frame = frame_count / 2;  // for sequences with a pose before the jump
  // Seam pixels and error regions per (sequence, frame), shared by the modes.
  std::map<std::pair<int, int>, ViewRegions> region_cache;
  // holoportation's and montage4d's pictures of each view compared, when
  // both modes run.
  const auto runs = [&](render::BlendMode mode) {
    return std::find(options.modes.begin(), options.modes.end(), mode) != options.modes.end();
  };
  const bool compare_pictures =
      runs(render::BlendMode::kHoloportation) && runs(render::BlendMode::kMontage4D);
  PictureComparison comparison;
  // This scene's views in every mode, for the time left.
  Eta eta;
  const size_t views = options.modes.size() * plan.sequences.size();
  size_t views_done = 0;
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
    const bool layered = mode == render::BlendMode::kLayered;
    std::vector<double> layers_ms, layer_video_ms;
    HOLOFUSE_RETURN_IF_ERROR(
        measureClientLink(options, input, layered, m, layers_ms, layer_video_ms));
    for (int s = 0; s < static_cast<int>(plan.sequences.size()); ++s) {
      const ViewSequence& sequence = plan.sequences[static_cast<size_t>(s)];
      const Camera& pose = sequence.pose;
      // Mode layered: the layers of the cameras this view may use, the
      // atlas and video streams kept over the sequence's frames as the
      // server and a client keep them.
      fusion::LayerStage layer_stage;
      render::LayerStreams layer_streams;
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
        std::vector<render::ViewImages> others = frame.views;
        if (sequence.left_out >= 0) others.erase(others.begin() + sequence.left_out);
        if (layered) {
          Mesh placed;
          LayeredViews layers;
          const auto built = layeredFrame(options, layer_stage, mesh, others, frame.frame_id,
                                          &layer_streams, &placed, &layers);
          if (!built.isOk())
            return Status(built.status().code(), result.name + ", frame " +
                                                     std::to_string(frame.frame_id) + ": " +
                                                     built.status().message());
          renderer.setMesh(placed);
          renderer.setLayers(layers);
        } else {
          renderer.setMesh(mesh);
          renderer.setViews(others);
        }
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
          comparison.add(key, mode, picture, truth_color, truth_mask);
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
          HOLOFUSE_RETURN_IF_ERROR(saveViewImages(options, result.name, mode_name, frame.frame_id,
                                                  sequence, picture, truth_color, truth_mask,
                                                  regions, mesh, others, renderer));
        }
      }
      eta.stepDone();
      ++views_done;
      // Leave-one-out counts its cameras; novel views their poses.
      const size_t of = sequence.novel_truth ? plan.sequences.size() : input.reported.size();
      progress.say(result.name + " / " + mode_name + ": " + plan.what + " " +
                       std::to_string(sequence.truth) + " of " + std::to_string(of) + ", " +
                       std::to_string(frame_count) + " frames, " +
                       std::to_string(static_cast<int>(msSince(mode_start) / 1000)) + " s so far" +
                       (views_done < views ? "; this scene's " + eta.text(views - views_done) : ""),
                   static_cast<double>(views_done) / static_cast<double>(views));
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
    m.layers_ms = layers_ms.empty() ? 0.0 : median(layers_ms);
    m.layer_video_ms = layer_video_ms.empty() ? 0.0 : median(layer_video_ms);
    for (const auto& [pass, values] : passes) m.gpu_passes_ms[pass] = median(values);
  }
  comparison.into(result.montage_agreement);
  return Status::ok();
}

}  // namespace holofuse::eval
