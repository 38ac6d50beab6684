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

#include "capture_node/pod.h"
#include "common/depth_raster.h"
#include "common/html_report.h"
#include "common/image_codec.h"
#include "common/image_io.h"
#include "common/mesh_codec.h"
#include "dataset/dataset.h"
#include "dataset/inspection.h"
#include "fusion_server/fusion_worker.h"
#include "fusion_server/photo_refine.h"
#include "hull/hull_error.h"
#include "hull/visual_hull.h"
#include "metrics/geometry_metrics.h"
#include "metrics/image_metrics.h"
#include "protocol/clock.h"
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
using metrics::ErrorRegion;
using metrics::errorRegionName;
using metrics::flicker;
using metrics::ImageQuality;
using metrics::kErrorRegionCount;
using metrics::kOutsideRegions;
using metrics::kPsnrCap;
using metrics::luminance;
using metrics::PictureAgreement;
using metrics::pictureAgreement;
using metrics::psnrFromMse;
using metrics::RegionErrors;
using metrics::regionErrors;
using metrics::regionsPicture;
using metrics::seamVisibility;

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Medians and 95th percentiles as the live loop's report takes them
// (render::percentile, interpolated), so the two reports compare.
double median(const std::vector<double>& v) { return render::percentile(v, 50); }
double percentile95(const std::vector<double>& v) { return render::percentile(v, 95); }

// One frame as the client receives it, and the truth it is judged by.
struct FrameData {
  uint64_t frame_id = 0;
  Mesh mesh;
  // With EvalOptions::hull_without_held_out, per held-out camera (by
  // index): the hull carved without its silhouette, as the client would
  // receive it.
  std::map<int, Mesh> mesh_without;
  std::vector<render::ViewImages>
      views;  // reported calibration, colour, segmented mask: the client's
  std::vector<Image8>
      true_colors;                 // per camera: its whole image, which leave-one-out compares with
  std::vector<Image8> true_masks;  // per camera
  std::vector<scene::RenderedView> novel_truth;  // per novel pose (SceneInput::novel_poses)
  double hull_ms = 0;
  double refine_ms = 0;  // the hull's photo-consistency refinement (EvalOptions::refine_voxels)
  // The codecs on the frame's way, per stage (codecStages()): the slowest
  // pod's encoding (pods work in parallel), the server's decoding of every
  // pod frame, its Draco and image encoding for clients, and the client's
  // decoding of both. Transport is not simulated.
  std::map<std::string, double> codec_ms;
  // The stages the live report samples once per pod frame (pod_encode,
  // server_decode): each pod's time, so their p50 and p95 mean what the
  // live report's do.
  std::map<std::string, std::vector<double>> per_pod_ms;
  size_t pod_link_bytes = 0;  // every pod's PodFrame, as the pods send them
  size_t client_link_bytes =
      0;                     // MeshFrame, TextureBundle and Stats, as the server sends each client
  size_t feather_bytes = 0;  // of them, the pods' feather maps (protocol 1.2)
  hull::HullStats hull_stats;
};

// One whole protocol frame from bytes that must hold one (this process
// made or recorded them): the transport's parsing, which no codec stage of
// the loop counts.
protocol::Frame parsedFrame(const protocol::Bytes& wire, const std::string& what) {
  auto frame = dataset::parseWholeFrame(wire, what);
  if (!frame.isOk()) throw std::runtime_error(frame.status().message());
  return std::move(*frame);
}

// The server's side of one pod frame (protocol bytes, as sent or
// recorded), decoded as fusion_server decodes it, into the frame's group.
// source names where the bytes came from in errors. Returns what the
// group now holds for that camera.
const fusion::PodImages& receivePodFrame(const protocol::Bytes& wire, const Camera& reported,
                                         const std::string& source, fusion::FrameGroup& group,
                                         FrameData& frame) {
  const protocol::Frame parsed =
      parsedFrame(wire, source + ": camera " + std::to_string(reported.id));
  const auto t0 = Clock::now();
  protocol::PodFrame pod;
  Status status = protocol::decodeFrame(parsed, pod);
  auto images = status.isOk()
                    ? fusion::podImagesOf(pod, wire.size(), reported, protocol::monotonicNs())
                    : status;
  const double decode_ms = msSince(t0);
  frame.codec_ms["server_decode"] += decode_ms;
  frame.per_pod_ms["server_decode"].push_back(decode_ms);
  if (!images.isOk()) {
    throw std::runtime_error(source + ": camera " + std::to_string(reported.id) + ": " +
                             images.status().message());
  }
  frame.pod_link_bytes += wire.size();
  return group.pods[pod.camera_id] = std::move(*images);
}

// The server's packing of the group's hull for clients (Draco, the images
// re-encoded) and the client's decoding of it: the frame's mesh and views
// are what a client of the live loop renders, its client-link bytes and
// codec times what the loop spends.
void sendToClient(fusion::FrameGroup group, const Mesh& hull, const EvalOptions& options,
                  const std::vector<Camera>& reported, FrameData& frame) {
  fusion::FusionSettings settings;
  settings.hull.voxel_size = options.voxel_size;
  settings.draco = options.draco;
  settings.image_codec = options.image_codec;
  settings.lz4_acceleration = options.lz4_acceleration;
  settings.lz4_hc_level = options.lz4_hc_level;
  settings.pods_expected = static_cast<uint32_t>(reported.size());
  fusion::GroupJob job;
  job.group = std::move(group);  // the decoded images move on; the caller is done with them
  job.group.complete = true;
  // The Stats carry each pod's arrivals as the loop's do, so their bytes
  // are the loop's (no network here: no jitter).
  for (const auto& [id, pod] : job.group.pods)
    job.pod_arrivals.push_back({static_cast<uint16_t>(id), 1, 0});
  const uint64_t hull_end_ns = protocol::monotonicNs();
  const fusion::FusedOutput fused =
      fusion::packageFused(job, settings, hull, hull_end_ns, hull_end_ns);
  const protocol::Bytes mesh_wire = fused.mesh_frame->flatten(),
                        bundle_wire = fused.texture_bundle->flatten();
  const protocol::Bytes stats_wire = fused.stats->flatten();
  frame.client_link_bytes += mesh_wire.size() + bundle_wire.size() + stats_wire.size();
  const protocol::Frame bundle_frame = parsedFrame(bundle_wire, "texture bundle");
  const protocol::Frame mesh_frame_parsed = parsedFrame(mesh_wire, "mesh frame");
  std::map<uint32_t, Camera> cameras;
  for (const Camera& camera : reported) cameras[camera.id] = camera;
  const auto t0 = Clock::now();
  protocol::TextureBundle bundle;
  Status status = protocol::decodeFrame(bundle_frame, bundle);
  auto views = status.isOk() ? render::viewsOfBundle(bundle, cameras) : status;
  frame.feather_bytes += status.isOk() ? render::featherBytes(bundle) : 0;
  protocol::MeshFrame mesh_frame;
  status = protocol::decodeFrame(mesh_frame_parsed, mesh_frame);
  auto mesh = status.isOk() ? decodeDraco(mesh_frame.mesh.data(), mesh_frame.mesh.size()) : status;
  frame.codec_ms["decode"] += msSince(t0);
  if (!views.isOk()) throw std::runtime_error("the client's images: " + views.status().message());
  if (mesh_frame.mesh.empty()) {
    // The server sends no Draco bytes when encoding failed, and says why in the Stats.
    protocol::Stats stats;
    status = protocol::decodeFrame(parsedFrame(stats_wire, "stats"), stats);
    throw std::runtime_error("the server's mesh: " +
                             (status.isOk() ? stats.note : status.message()));
  }
  if (!mesh.isOk()) throw std::runtime_error("the client's mesh: " + mesh.status().message());
  // The server's encoding, from the stamps it put in the frames it sent.
  frame.codec_ms["mesh_encode"] +=
      protocol::stampedMs(mesh_frame.stamps, protocol::Stage::kMeshEncode);
  frame.codec_ms["image_encode"] +=
      protocol::stampedMs(bundle.stamps, protocol::Stage::kImageEncode);
  frame.mesh = std::move(*mesh);
  frame.views = std::move(*views);
}

std::vector<int> heldOutCameras(int cameras, int limit) {
  std::vector<int> ids;
  const int count = limit > 0 ? std::min(limit, cameras) : cameras;
  for (int k = 0; k < count; ++k) ids.push_back(k * cameras / count);
  return ids;
}

// The hull refined as the server refines it (EvalOptions::refine_voxels;
// the hull itself when off).
Mesh refined(const Mesh& hull, const std::vector<hull::HullView>& views,
             const std::vector<Image8>& colors, const EvalOptions& options, double voxel_size) {
  if (!(options.refine_voxels > 0)) return hull;
  fusion::PhotoRefineOptions refine;
  refine.depth_voxels = options.refine_voxels;
  refine.voxel_size = voxel_size;
  return fusion::refineByPhotoConsistency(hull, views, colors, refine);
}

// For each camera held out, the mesh its image is compared with where that
// is not the frame's: the hull carved without its silhouette
// (EvalOptions::hull_without_held_out), and refined without its colour
// (EvalOptions::refine_voxels), so that beyond its silhouette, which paper
// 000's protocol lets shape the hull, nothing of a held-out image shapes
// what it is compared with. Through Draco, as a client receives a mesh.
std::map<int, Mesh> meshesForHeldOut(const EvalOptions& options,
                                     const std::vector<hull::HullView>& views,
                                     const std::vector<Image8>& colors, const Mesh& hull,
                                     const hull::HullOptions& hull_options) {
  std::map<int, Mesh> meshes;
  if (!options.hull_without_held_out && !(options.refine_voxels > 0)) return meshes;
  for (int held : heldOutCameras(static_cast<int>(views.size()), options.held_out_cameras)) {
    std::vector<hull::HullView> others = views;
    others.erase(others.begin() + held);
    std::vector<Image8> other_colors;
    if (!colors.empty()) {
      other_colors = colors;
      other_colors.erase(other_colors.begin() + held);
    }
    const Mesh mesh =
        refined(options.hull_without_held_out ? hull::carveVisualHull(others, hull_options) : hull,
                others, other_colors, options, hull_options.voxel_size);
    auto bytes = encodeDraco(mesh, options.draco);
    auto decoded = bytes.isOk() ? decodeDraco(bytes->data(), bytes->size()) : bytes.status();
    if (!decoded.isOk()) {
      throw std::runtime_error("the hull without camera " +
                               std::to_string(views[static_cast<size_t>(held)].camera.id) + ": " +
                               decoded.status().message());
    }
    meshes[held] = std::move(*decoded);
  }
  return meshes;
}

// What follows the carving in the server, timed as its refine stage, and
// the meshes the held-out cameras are compared with: the mesh the frame
// sends.
Mesh refineCarved(const EvalOptions& options, const fusion::FrameGroup& group,
                  const std::vector<hull::HullView>& views, Mesh carved,
                  const hull::HullOptions& hull_options, FrameData& frame) {
  const bool refining = options.refine_voxels > 0;
  // The colours in whole frames only for the refinement, which reads them.
  const std::vector<Image8> colors =
      refining ? fusion::colorsInFrame(group) : std::vector<Image8>{};
  std::optional<Mesh> mesh;
  if (refining) {
    const auto t0 = Clock::now();
    mesh = refined(carved, views, colors, options, hull_options.voxel_size);
    frame.refine_ms = msSince(t0);
  }
  frame.mesh_without = meshesForHeldOut(options, views, colors, carved, hull_options);
  return mesh ? std::move(*mesh) : std::move(carved);
}

FrameData prepareFrame(const EvalOptions& options, const scene::SyntheticScene& scene,
                       const std::vector<Camera>& truth, const std::vector<Camera>& reported,
                       const std::vector<Image8>& plates, uint64_t frame_id) {
  FrameData frame;
  frame.frame_id = frame_id;
  fusion::FrameGroup group;
  group.frame_id = frame_id;
  double slowest_pod_ms = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    capture::PodCapture capture =
        capture::capturePodFrame(scene, truth[i], plates[i], frame_id, static_cast<uint16_t>(i));
    frame.true_colors.push_back(capture.view.color);
    frame.true_masks.push_back(capture.view.mask);
    const protocol::Bytes wire =
        capture::encodePodFrame(capture, static_cast<uint32_t>(i), options.image_codec,
                                options.crop_margin, options.lz4_acceleration, options.lz4_hc_level)
            .flatten();
    // As the pod stamps it: its planes' encoding, not the frame's packing.
    const double encode_ms = protocol::stampedMs(capture.stamps, protocol::Stage::kPodEncode);
    slowest_pod_ms = std::max(slowest_pod_ms, encode_ms);
    frame.per_pod_ms["pod_encode"].push_back(encode_ms);
    receivePodFrame(wire, reported[i], "pod", group, frame);
  }
  frame.codec_ms["pod_encode"] = slowest_pod_ms;
  // The silhouettes back in whole frames before the hull's clock starts, as
  // in the server.
  const std::vector<hull::HullView> hull_views = fusion::hullViewsOf(group);
  const auto t0 = Clock::now();
  // The true surface at the hull's voxel size, when asked for.
  hull::HullOptions hull_options;
  hull_options.voxel_size = options.voxel_size;
  Mesh hull = options.geometry == "truth"
                  ? scene.truthMesh(frame_id, options.voxel_size)
                  : hull::carveVisualHull(hull_views, hull_options, &frame.hull_stats);
  frame.hull_ms = msSince(t0);
  if (options.geometry != "truth")
    hull = refineCarved(options, group, hull_views, std::move(hull), hull_options, frame);
  sendToClient(std::move(group), hull, options, reported, frame);
  return frame;
}

// RGB like the true images (a render's alpha is not part of the comparison).
void saveImage(const fs::path& path, const Image8& image) {
  fs::create_directories(path.parent_path());
  Image8 rgb = image;
  if (image.channels == 4) {
    rgb = Image8(image.width, image.height, 3);
    for (size_t p = 0; p < static_cast<size_t>(image.width) * image.height; ++p) {
      for (int c = 0; c < 3; ++c) rgb.pixels[p * 3 + c] = image.pixels[p * 4 + c];
    }
  }
  const Status written = writePng(path.string(), rgb);
  if (!written.isOk()) throw std::runtime_error(written.message());
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

// A scene to evaluate, from the synthetic library or from a dataset: the
// poses to render from, and every frame as the client would receive it.
struct SceneInput {
  std::vector<Camera> reported;
  std::vector<FrameData> frames;
  // Novel views instead of held-out cameras: every camera takes part and
  // frames[f].novel_truth[j] is the truth at novel_poses[j].
  std::vector<Camera> novel_poses;
  // The held-out camera's own image stays in the blend (EvalOptions::camera_kept).
  bool camera_kept = false;
};

// Every mode, every held-out camera, every frame of one scene.
void evaluateModes(const EvalOptions& options, render::VulkanContext& context,
                   const SceneInput& input, SceneResult& result,
                   const std::function<void(const std::string&)>& progress) {
  const int camera_count = static_cast<int>(input.reported.size());
  const int frame_count = static_cast<int>(input.frames.size());
  // A jump of this many cameras along the ring is the preset's angle.
  const int jump = static_cast<int>(std::lround(result.view_jump_degrees / 360.0 * camera_count));
  const int jump_frame = jump != 0 ? frame_count / 2 : 0;
  // Seam pixels and error regions per (sequence, frame), shared by the modes.
  std::map<std::pair<int, int>, ViewRegions> region_cache;
  const bool novel = !input.novel_poses.empty();
  // The truth a sequence's frame is compared with.
  auto truthOf = [&](int held, int f) -> std::pair<const Image8&, const Image8&> {
    const FrameData& frame = input.frames[static_cast<size_t>(f)];
    const size_t k = static_cast<size_t>(held);
    if (novel) return {frame.novel_truth[k].color, frame.novel_truth[k].mask};
    return {frame.true_colors[k], frame.true_masks[k]};
  };
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
    const auto [truth_color, truth_mask] = truthOf(key.first, key.second);
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
    const std::vector<int> evaluated =
        novel ? std::vector<int>{} : heldOutCameras(camera_count, options.held_out_cameras);
    std::vector<int> sequences = evaluated;
    if (novel) {
      for (size_t j = 0; j < input.novel_poses.size(); ++j)
        sequences.push_back(static_cast<int>(j));
    }
    for (int held : sequences) {
      // Rendered at the held-out camera's own size, to compare pixel for pixel.
      const Camera& pose = novel ? input.novel_poses[static_cast<size_t>(held)]
                                 : input.reported[static_cast<size_t>(held)];
      render::Renderer renderer(context, pose.width, pose.height);
      renderer.setHalfPrecisionVertices(options.half_precision_vertices);
      render::BlendSettings settings;
      settings.mode = mode;
      settings.frame_interval_s = 1.0 / options.fps;
      settings.alpha = options.alpha;
      settings.lambda = options.lambda;
      settings.fields = options.fields;
      settings.beta = options.beta;
      settings.feather_width_px = options.feather_width_px;
      settings.fragment_test = options.fragment_test;
      std::optional<ErrorImage> previous;
      for (int f = 0; f < frame_count; ++f) {
        const FrameData& frame = input.frames[static_cast<size_t>(f)];
        // Leave-one-out proper may carve without the held-out camera too; a
        // kept camera or a novel pose has no camera to leave out.
        const auto without =
            novel || input.camera_kept ? frame.mesh_without.end() : frame.mesh_without.find(held);
        const Mesh& mesh = without != frame.mesh_without.end() ? without->second : frame.mesh;
        renderer.setMesh(mesh);
        // The held-out image takes no part at all: not in the blend, the
        // vote, the seams or the global visibility (unless kept on purpose).
        std::vector<render::ViewImages> others = frame.views;
        if (!novel && !input.camera_kept) others.erase(others.begin() + held);
        renderer.setViews(others);
        const bool before_jump = !novel && f < jump_frame;
        const int view =
            before_jump ? ((held + jump) % camera_count + camera_count) % camera_count : held;
        const auto t0 = Clock::now();
        const Image8 picture =
            renderer.render(novel ? pose : input.reported[static_cast<size_t>(view)], settings);
        mesh_ms.push_back(msSince(t0));
        const auto times = renderer.fieldTimesMs();
        for (size_t s = 0; s < times.size(); ++s) {
          if (times[s] >= 0)
            passes[render::TextureFieldPasses::stageNames()[s]].push_back(
                times[s]);  // -1: no such pass
        }
        if (before_jump) continue;  // not at the held-out pose yet: nothing to compare with
        const auto [truth_color, truth_mask] = truthOf(held, f);
        const ImageQuality q = compareInMask(picture, truth_color, truth_mask);
        const auto key = std::make_pair(held, f);
        if (compare_pictures &&
            (mode == render::BlendMode::kHoloportation || mode == render::BlendMode::kMontage4D)) {
          comparePictures(key, mode, picture);
        }
        auto cached = region_cache.find(key);
        if (cached == region_cache.end()) {
          cached =
              region_cache.emplace(key, viewRegions(mesh, pose, others, truth_mask, options.fields))
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
          const std::string stem = "frame" + std::to_string(frame.frame_id) +
                                   (novel ? "_novel" : "_camera") + std::to_string(held);
          saveImage(dir / (stem + "_rendered.png"), picture);
          saveImage(dir / (stem + "_true.png"), truth_color);
          saveImage(dir / (stem + "_mask.png"), truth_mask);
          saveImage(dir / (stem + "_error.png"), errorMapPicture(picture, truth_color, truth_mask));
          saveImage(dir / (stem + "_regions.png"), regionsPicture(regions.regions));
        }
      }
      if (progress) {
        progress(result.name + " / " + mode_name +
                 (novel               ? ": novel view "
                  : input.camera_kept ? ": camera kept "
                                      : ": held out camera ") +
                 std::to_string(held) + " of " +
                 std::to_string(novel ? static_cast<int>(sequences.size()) : camera_count) + ", " +
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
}

// The leave-one-out row's scene again, with each held-out camera's image
// kept in the blend: what the camera's own pose scores when its image
// takes part.
SceneResult cameraKeptRow(const EvalOptions& options, render::VulkanContext& context,
                          const SceneInput& input, const SceneResult& leave_one_out,
                          const std::function<void(const std::string&)>& progress) {
  SceneInput kept = input;
  kept.camera_kept = true;
  SceneResult row = leave_one_out;
  row.modes.clear();
  row.name = leave_one_out.name + " (camera kept)";
  row.camera_kept = true;
  evaluateModes(options, context, kept, row, progress);
  return row;
}

// Per scene (novel-view and camera-kept rows share their scene's frames):
// bytes per frame on each link and the codecs' ms, as report cells.
std::vector<std::vector<std::string>> linkRows(const std::vector<SceneResult>& results) {
  std::vector<std::vector<std::string>> rows;
  for (const auto& scene : results) {
    if (scene.novel_view_degrees != 0 || scene.camera_kept) continue;
    char cells[5][32];
    std::snprintf(cells[0], sizeof(cells[0]), "%.1f", scene.pod_link_bytes_per_frame / 1000.0);
    std::snprintf(cells[1], sizeof(cells[1]), "%.1f", scene.bytes_per_frame / 1000.0);
    std::snprintf(cells[2], sizeof(cells[2]), "%.1f", scene.feather_bytes_per_frame / 1000.0);
    std::snprintf(cells[3], sizeof(cells[3]), "%.1f", scene.codec_ms);
    std::snprintf(cells[4], sizeof(cells[4]), "%.1f", scene.codec_ms_p95);
    rows.push_back({scene.name, cells[0], cells[1], cells[2], cells[3], cells[4]});
  }
  return rows;
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
// hull carved in its capture volume at its voxel size (options.voxel_size
// when the dataset names none or a voxel was given), through Draco. Its masks are the truth the
// images are compared inside; there is no true surface.
SceneInput loadDatasetScene(const EvalOptions& options, const std::string& dir,
                            SceneResult& result) {
  auto dataset = dataset::Dataset::open(dir);
  if (!dataset.isOk()) throw std::invalid_argument(dataset.status().message());
  SceneInput input;
  std::vector<Camera> cameras;
  for (const auto& [id, cam] : dataset->cameras()) {
    auto calibration = dataset->readCalibration(id);
    if (!calibration.isOk()) throw std::invalid_argument(calibration.status().message());
    cameras.push_back(fromCalibration(*calibration));
  }
  if (cameras.size() < 2)
    throw std::invalid_argument(dir + ": leave-one-camera-out needs at least 2 cameras");
  input.reported = cameras;
  hull::HullOptions hull_options = dataset::hullOptionsFor(*dataset, options.voxel_size);
  if (!options.voxel_from_dataset) hull_options.voxel_size = options.voxel_size;
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
      if (!recorded.isOk()) throw std::invalid_argument(recorded.status().message());
      // The pods' encoding is not timed: the recording was made. The truth
      // is the recorded image and mask, back in their whole frame.
      const fusion::PodImages& pod =
          receivePodFrame(recorded->bytes, cameras[c], dir, group, frame);
      const Camera& cam = cameras[c];
      frame.true_colors.push_back(
          placeInFrame(pod.color, pod.offset_x, pod.offset_y, cam.width, cam.height));
      frame.true_masks.push_back(
          placeInFrame(pod.mask, pod.offset_x, pod.offset_y, cam.width, cam.height));
    }
    const std::vector<hull::HullView> hull_views = fusion::hullViewsOf(group);
    const auto t0 = Clock::now();
    Mesh hull;
    if (options.hull_error_target > 0 && input.frames.empty()) {
      // The error target picks the voxel on the first frame; the rest follow it.
      hull::HullForTarget found = hull::carveToErrorTarget(
          hull_views, hull_options, options.hull_error_target, &frame.hull_stats);
      hull = std::move(found.mesh);
      hull_options.voxel_size = found.voxel_size;
    } else {
      hull = hull::carveVisualHull(hull_views, hull_options, &frame.hull_stats);
    }
    frame.hull_ms = msSince(t0);
    hull = refineCarved(options, group, hull_views, std::move(hull), hull_options, frame);
    sendToClient(std::move(group), hull, options, cameras, frame);
    input.frames.push_back(std::move(frame));
  }
  if (input.frames.empty())
    throw std::invalid_argument(dir + ": no frame id is held by every camera");
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

}  // namespace

std::vector<SceneResult> runLeaveOneOut(const EvalOptions& options,
                                        const std::function<void(const std::string&)>& progress) {
  std::vector<const scene::ScenePreset*> presets;
  if (options.scenes.empty() && options.datasets.empty()) {
    for (const auto& preset : scene::sceneLibrary()) presets.push_back(&preset);
  }
  for (const auto& name : options.scenes) {
    const scene::ScenePreset* preset = scene::findScene(name);
    if (preset == nullptr) {
      throw std::invalid_argument("unknown scene '" + name +
                                  "'; valid scenes: " + scene::sceneNames());
    }
    presets.push_back(preset);
  }
  if (options.frames < 1) throw std::invalid_argument("--frames must be at least 1");
  if (options.geometry != "hull" && options.geometry != "truth") {
    throw std::invalid_argument("geometry '" + options.geometry + "': expected hull or truth");
  }
  if (options.geometry == "truth" && options.hull_without_held_out) {
    throw std::invalid_argument(
        "--hull-without-held-out carves the hull again: it needs --geometry hull");
  }
  if (options.geometry == "truth" && !options.datasets.empty()) {
    throw std::invalid_argument(
        "--geometry truth needs a synthetic scene: a dataset has no true surface");
  }
  render::VulkanContext context(options.device);
  std::vector<SceneResult> results;
  for (const auto& dir : options.datasets) {
    SceneResult result;
    const SceneInput input = loadDatasetScene(options, dir, result);
    summariseFrames(input, result);
    result.silhouette_error_mm = silhouetteErrorMm(input.frames[0]);
    evaluateModes(options, context, input, result, progress);
    results.push_back(std::move(result));
    if (options.camera_kept)
      results.push_back(cameraKeptRow(options, context, input, results.back(), progress));
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
    if (options.hull_error_target > 0 && options.geometry == "hull") {
      // The error target picks the voxel on the first frame; the rest follow it.
      std::vector<hull::HullView> views;
      for (size_t i = 0; i < truth.size(); ++i) {
        capture::PodCapture capture = capture::capturePodFrame(
            scene, truth[i], plates[i], options.first_frame, static_cast<uint16_t>(i));
        views.push_back({input.reported[i], capture.mask, capture.feather});
      }
      hull::HullOptions hull_options;
      hull_options.voxel_size = options.voxel_size;
      scene_eval.voxel_size =
          hull::carveToErrorTarget(views, hull_options, options.hull_error_target).voxel_size;
    }
    SceneResult result;
    result.name = preset->name;
    result.voxel_mm = 1000.0 * scene_eval.voxel_size;
    result.stresses = preset->stresses;
    result.cameras = camera_count;
    result.view_jump_degrees = preset->view_jump_degrees;
    for (int f = 0; f < options.frames; ++f) {
      input.frames.push_back(prepareFrame(scene_eval, scene, truth, input.reported, plates,
                                          options.first_frame + static_cast<uint64_t>(f)));
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
    evaluateModes(options, context, input, result, progress);
    const SceneResult leave_one_out = result;
    results.push_back(std::move(result));
    if (options.camera_kept)
      results.push_back(cameraKeptRow(options, context, input, leave_one_out, progress));
    for (double degrees : options.novel_view_degrees) {
      // The same frames, seen from beside the chosen pods with all of them
      // blended; the scene renders the truth there.
      SceneInput novel = input;
      for (int k : heldOutCameras(camera_count, options.held_out_cameras)) {
        novel.novel_poses.push_back(scene::SyntheticScene::ringPose(
            360.0 * k / camera_count + degrees, static_cast<uint32_t>(1000 + k), options.width,
            options.height));
      }
      for (FrameData& frame : novel.frames) {
        for (const Camera& pose : novel.novel_poses)
          frame.novel_truth.push_back(scene.render(pose, frame.frame_id));
      }
      SceneResult row = leave_one_out;
      row.modes.clear();
      char suffix[32];
      std::snprintf(suffix, sizeof(suffix), " %+g deg", degrees);
      row.name = preset->name + suffix;
      row.novel_view_degrees = degrees;
      row.view_jump_degrees = 0;
      evaluateModes(options, context, novel, row, progress);
      results.push_back(std::move(row));
    }
  }
  return results;
}

std::vector<std::string> latencyStages() {
  std::vector<std::string> stages = {"hull", "refine"};
  stages.insert(stages.end(), codecStages().begin(), codecStages().end());
  stages.push_back("client render");
  return stages;
}

std::vector<double> latencyParts(const SceneResult& scene, const ModeResult& mode, bool p95) {
  std::vector<double> parts = {p95 ? scene.hull_ms_p95 : scene.hull_ms,
                               p95 ? scene.refine_ms_p95 : scene.refine_ms};
  const auto& codec_ms = p95 ? scene.codec_stage_ms_p95 : scene.codec_stage_ms;
  for (const std::string& stage : codecStages())
    parts.push_back(codec_ms.count(stage) ? codec_ms.at(stage) : 0.0);
  parts.push_back(p95 ? mode.ms_per_new_mesh_p95 : mode.ms_per_new_mesh);
  return parts;
}

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

Image8 errorRegions(const Image8& mask, const DepthMap& depth, const Image8& seams, int reach_px,
                    double relative_jump) {
  const uint32_t w = mask.width, h = mask.height;
  if (mask.channels != 1 || seams.width != w || seams.height != h || seams.channels != 1 ||
      depth.width != w || depth.height != h) {
    throw std::invalid_argument(
        "errorRegions: mask, depth and seams must be one-channel images of one size");
  }
  const size_t n = static_cast<size_t>(w) * h;
  // The mask as a depth map: its outline is the mask's inside pixels next
  // to the background, so that grown by reach_px - 1 it holds the pixels
  // within reach_px of the background.
  DepthMap silhouette{w, h, std::vector<double>(n, kNoDepth)};
  for (size_t p = 0; p < n; ++p) {
    if (mask.pixels[p] != 0) silhouette.depth[p] = 1.0;
  }
  const auto near_outside = render::reference::dilatedDiscontinuities(
      silhouette, {std::max(0, reach_px - 1), relative_jump});
  const auto near_jump =
      render::reference::dilatedDiscontinuities(depth, {std::max(0, reach_px), relative_jump});
  Image8 regions(w, h, 1, kOutsideRegions);
  for (size_t p = 0; p < n; ++p) {
    if (mask.pixels[p] == 0) continue;
    ErrorRegion r = ErrorRegion::kElsewhere;
    if (near_outside[p]) {
      r = ErrorRegion::kSilhouetteBorder;
    } else if (near_jump[p]) {
      r = ErrorRegion::kOcclusionEdge;
    } else if (seams.pixels[p] != 0) {
      r = ErrorRegion::kSeam;
    }
    regions.pixels[p] = static_cast<uint8_t>(r);
  }
  return regions;
}

std::map<std::string, double> regionSharesAgainstNormal(
    const std::map<std::string, ModeResult>& modes, const std::string& mode) {
  const auto normal = modes.find(render::blendModeName(render::BlendMode::kNormal));
  const auto other = modes.find(mode);
  std::map<std::string, double> shares;
  if (normal == modes.end() || other == modes.end() || normal == other) return shares;
  std::array<double, kErrorRegionCount> difference{};
  double total = 0, scale = 0;
  for (size_t r = 0; r < kErrorRegionCount; ++r) {
    difference[r] =
        normal->second.regions.squared_error[r] - other->second.regions.squared_error[r];
    total += difference[r];
    scale += normal->second.regions.squared_error[r];
  }
  if (!(std::abs(total) > 1e-9 * std::max(scale, 1.0))) return shares;
  for (size_t r = 0; r < kErrorRegionCount; ++r) {
    shares[errorRegionName(static_cast<ErrorRegion>(r))] = difference[r] / total;
  }
  return shares;
}

std::vector<BudgetCheck> checkBudget(const render::Budget& budget, const SceneResult& scene,
                                     const std::vector<std::string>& modes) {
  std::vector<BudgetCheck> checks;
  auto check = [&](const std::string& mode, const std::string& stage, double p95) {
    const auto it = budget.find(stage);
    if (it != budget.end()) checks.push_back({mode, stage, p95, it->second});
  };
  check("-", "hull", scene.hull_ms_p95);
  check("-", "refine", scene.refine_ms_p95);
  for (const auto& [stage, p95] : scene.codec_stage_ms_p95) check("-", stage, p95);
  for (const auto& mode : modes) {
    const auto it = scene.modes.find(mode);
    if (it != scene.modes.end()) check(mode, "render", it->second.ms_per_new_mesh_p95);
  }
  return checks;
}

std::string measuredText(double value, const char* format) {
  if (value < 0) return "n/a";
  char text[32];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

// What the verdict tables' "pictures differ on" column says.
constexpr const char* kPicturesDifferMeaning =
    "Pictures differ on: the share of the compared pixels where montage4d's picture differs from "
    "holoportation's "
    "by more than 2 grey levels, and (in brackets) the PSNR gain montage4d would have if exact on "
    "every one of them: "
    "the most that what its fields change could gain, at these settings (other settings change "
    "other pixels).";

Verdict montageVerdict(const SceneResult& scene) {
  Verdict v;
  const auto holo = scene.modes.find("holoportation"), montage = scene.modes.find("montage4d");
  if (holo == scene.modes.end() || montage == scene.modes.end()) {
    v.why = "needs both holoportation and montage4d";
    return v;
  }
  v.psnr_gain_db = montage->second.psnr_db - holo->second.psnr_db;
  v.ssim_gain = montage->second.ssim - holo->second.ssim;
  const double holo_flicker = holo->second.flicker, montage_flicker = montage->second.flicker;
  if (holo_flicker >= 0 && montage_flicker >= 0) {
    // Both steady (0 and 0) is a tie, not less flicker.
    v.flicker_ratio = holo_flicker > 0      ? montage_flicker / holo_flicker
                      : montage_flicker > 0 ? montage_flicker / 1e-6
                                            : 1.0;
  }
  v.agreement = scene.montage_agreement;
  std::vector<std::string> short_of;
  if (v.psnr_gain_db < 0.5) {
    std::string why = "PSNR gain below 0.5 dB";
    if (v.agreement.measured && v.agreement.gain_bound_db < 0.5) {
      char text[200];
      std::snprintf(text, sizeof(text),
                    " (montage4d changes too little of holoportation's picture: they differ on "
                    "%.0f%% of the pixels, "
                    "and exact on all of them it would gain %.2f dB)",
                    100 * v.agreement.differing_share, v.agreement.gain_bound_db);
      why += text;
    }
    short_of.push_back(why);
  }
  if (!(v.ssim_gain > 0)) short_of.push_back("SSIM not higher");
  if (scene.view_jump_degrees != 0 && v.flicker_ratio < 0) {
    // The jump comes halfway: three frames give one pair after it.
    short_of.push_back("flicker after the jump not measured (it needs --frames 3 or more)");
  } else if (scene.view_jump_degrees != 0 && !(v.flicker_ratio < 1.0)) {
    short_of.push_back("flickers no less after the jump");
  }
  v.met = short_of.empty();
  for (const auto& s : short_of) v.why += (v.why.empty() ? "" : "; ") + s;
  return v;
}

void writeQualityReports(const EvalOptions& options, const std::vector<SceneResult>& results,
                         const std::string& out_dir) {
  fs::create_directories(out_dir);
  nlohmann::json json;
  json["settings"] = {
      {"frames", options.frames},
      {"first_frame", options.first_frame},
      {"size", std::to_string(options.width) + "x" + std::to_string(options.height)},
      {"scene_fps", options.fps},
      {"held_out_cameras", options.held_out_cameras},
      {"geometry", options.geometry},
      {"voxel_size", options.voxel_size},
      {"hull_error_target_mm", 1000.0 * options.hull_error_target},
      {"refine_voxels", options.refine_voxels},
      {"crop_margin", options.crop_margin},
      {"hull_without_held_out", options.hull_without_held_out},
      {"metrics",
       "RMSE and PSNR over RGB inside the true mask; SSIM on luminance (Wang 2004, "
       "11x11 Gaussian sigma 1.5, K1 0.01, K2 0.03), mean over windows centred in the mask; "
       "flicker: mean |change of the error image| between frames, grey levels (null: no two frames "
       "compared); "
       "seam_visibility: RMS gradient of the luminance error image over the pixels seam "
       "triangles cover, grey levels per pixel"}};
  for (const auto& scene : results) {
    nlohmann::json& s = json["scenes"][scene.name];
    s = sceneResultJson(scene);
    const Verdict v = montageVerdict(scene);
    s["montage4d_against_holoportation"] = {
        {"psnr_gain_db", v.psnr_gain_db},
        {"ssim_gain", v.ssim_gain},
        {"flicker_ratio", measuredJson(v.flicker_ratio)},
        {"target_met", v.met},
        {"short_of", v.why},
        {"is_a_target",
         scene.name != "clean" && scene.novel_view_degrees == 0 && !scene.camera_kept}};
    if (v.agreement.measured) {
      s["montage4d_against_holoportation"]["pictures"] = s["montage_agreement"];
    }
  }

  // The layout of paper 000 Table 2: per scene, per mode RMSE, PSNR, SSIM
  // and rate; then flicker and seams, which it does not measure.
  std::vector<std::string> modes;
  for (auto mode : options.modes) modes.push_back(render::blendModeName(mode));
  std::ofstream md(fs::path(out_dir) / "quality.md");
  md << "# Leave-one-camera-out quality\n\n"
     << "Geometry: " << (options.geometry == "truth" ? "the true surface" : "the visual hull")
     << ". " << options.frames << " frames per scene from frame " << options.first_frame << ", "
     << options.width << "x" << options.height
     << "; each camera rendered from its reported pose without its own image"
     << (options.hull_without_held_out ? " and with a hull carved without its silhouette" : "")
     << ", compared with its "
        "true image inside its true mask (rows \"(camera kept)\": with its own image; \"+D deg\": "
        "novel poses, every "
        "camera blended).\n\n";
  char cell[256];
  // One table per group of columns, a column per mode and measure.
  auto modeTable = [&](const std::vector<std::string>& measures,
                       const std::function<std::vector<std::string>(const ModeResult&)>& cells) {
    md << "| Scene |";
    for (const auto& mode : modes) {
      for (const auto& measure : measures) md << " " << mode << " " << measure << " |";
    }
    md << "\n|---|";
    for (size_t i = 0; i < modes.size() * measures.size(); ++i) md << "---:|";
    md << "\n";
    for (const auto& scene : results) {
      md << "| " << scene.name << " |";
      for (const auto& mode : modes) {
        const auto it = scene.modes.find(mode);
        for (size_t i = 0; i < measures.size(); ++i) {
          md << " " << (it == scene.modes.end() ? std::string() : cells(it->second).at(i)) << " |";
        }
      }
      md << "\n";
    }
  };
  modeTable({"RMSE", "PSNR", "SSIM", "fps"}, [&](const ModeResult& m) -> std::vector<std::string> {
    char v[4][32];
    std::snprintf(v[0], sizeof(v[0]), "%.2f%%", m.rmse_percent);
    std::snprintf(v[1], sizeof(v[1]), "%.2f dB", m.psnr_db);
    std::snprintf(v[2], sizeof(v[2]), "%.4f", m.ssim);
    std::snprintf(v[3], sizeof(v[3]), "%.1f",
                  m.ms_per_new_mesh > 0 ? 1000.0 / m.ms_per_new_mesh : 0.0);
    return {v[0], v[1], v[2], v[3]};
  });
  md << "\nfps: one render after a new mesh (field passes included), this machine's Vulkan device; "
        "paper 000's is "
        "the average over every frame.\n\n## Flicker and seams\n\n";
  modeTable({"flicker", "seams"}, [&](const ModeResult& m) -> std::vector<std::string> {
    return {measuredText(m.flicker, "%.2f"), measuredText(m.seam_visibility, "%.2f")};
  });
  md << "\nflicker: mean frame-to-frame change of the error image, grey levels (n/a: no two frames "
        "compared). seams: "
        "seam visibility, the RMS gradient of the luminance error along the pixels seam triangles "
        "cover (grey levels "
        "per pixel; lower is less visible; n/a: no seam in view).\n\n";
  md << "## Where the errors differ\n\nPSNR per region over every image (the squared error "
        "pooled), and the share of "
        "the squared-error difference from normal that each region carries (the shares sum to "
        "100%; a negative "
        "one goes against the whole picture's difference); the row \"pixels\" gives each region's "
        "share of the "
        "compared pixels. Regions: within 3 px of the true mask's edge (border), of a depth jump "
        "of the "
        "mesh seen from the pose (occlusion), on seam triangles (seam), elsewhere; pictures with "
        "--save-images "
        "(*_error.png, *_regions.png).\n\n"
     << "| Scene | mode |";
  for (size_t r = 0; r < kErrorRegionCount; ++r)
    md << " " << errorRegionName(static_cast<ErrorRegion>(r)) << " |";
  md << "\n|---|---|";
  for (size_t r = 0; r < kErrorRegionCount; ++r) md << "---|";
  md << "\n";
  for (const auto& scene : results) {
    if (scene.modes.empty()) continue;
    const RegionErrors& any =
        scene.modes.begin()->second.regions;  // every mode compares the same pixels
    double all_pixels = 0;
    for (size_t count : any.pixels) all_pixels += static_cast<double>(count);
    md << "| " << scene.name << " | pixels |";
    for (size_t count : any.pixels) {
      std::snprintf(cell, sizeof(cell), " %.1f%% |",
                    all_pixels > 0 ? 100.0 * static_cast<double>(count) / all_pixels : 0.0);
      md << cell;
    }
    md << "\n";
    for (const auto& mode : modes) {
      const auto it = scene.modes.find(mode);
      if (it == scene.modes.end()) continue;
      const auto shares = regionSharesAgainstNormal(scene.modes, mode);
      md << "| " << scene.name << " | " << mode << " |";
      for (size_t r = 0; r < kErrorRegionCount; ++r) {
        const char* name = errorRegionName(static_cast<ErrorRegion>(r));
        const double samples = 3.0 * static_cast<double>(it->second.regions.pixels[r]);
        if (samples == 0) {
          md << " n/a |";
          continue;
        }
        std::snprintf(cell, sizeof(cell), " %.2f dB",
                      psnrFromMse(it->second.regions.squared_error[r] / samples));
        md << cell;
        if (shares.count(name)) {
          std::snprintf(cell, sizeof(cell), " (%+.0f%%)", 100.0 * shares.at(name));
          md << cell;
        }
        md << " |";
      }
      md << "\n";
    }
  }
  md << "\n## Geometry\n\nThe surface the client received against the truth (first frame; Chamfer "
        "from each mesh's "
        "vertices to the other's triangles, truth by marching cubes at 1 cm; IoU of its silhouette "
        "in each true mask; "
        "silhouette error: mean distance between its outline and each segmented mask's, what the "
        "voxel controls and "
        "`--hull-error-mm` targets).\n\n"
        "| Scene | voxel mm | triangles | hull ms | cells visited | dense grid points | Chamfer mm "
        "| silhouette error mm "
        "| IoU mean | IoU worst |\n"
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& scene : results) {
    double mean_iou = 0, worst_iou = 1;
    for (double v : scene.silhouette_iou) {
      mean_iou += v / static_cast<double>(scene.silhouette_iou.size());
      worst_iou = std::min(worst_iou, v);
    }
    char chamfer[32] = "n/a (no true surface)";
    if (scene.chamfer_mm >= 0) std::snprintf(chamfer, sizeof(chamfer), "%.1f", scene.chamfer_mm);
    char silhouette[32] = "n/a";
    if (scene.silhouette_error_mm >= 0)
      std::snprintf(silhouette, sizeof(silhouette), "%.2f", scene.silhouette_error_mm);
    std::snprintf(
        cell, sizeof(cell), "| %s | %.1f | %.0f | %.1f | %.0f | %.0f | %s | %s | %.3f | %.3f |\n",
        scene.name.c_str(), scene.voxel_mm, scene.triangles, scene.hull_ms, scene.cells_visited,
        scene.dense_grid_points, chamfer, silhouette, mean_iou, worst_iou);
    md << cell;
  }
  md << "\n## Links and codecs\n\nBytes per frame as the loop sends them (the pods' rectangles "
        "with their "
        "feather maps; the server's Draco mesh and images to one client), and the codecs' ms per "
        "frame: "
     << kCodecsMeaning << ". " << kNoJitterHere
     << "\n\n| Scene | pods to server KB | server to client KB | of which feather maps KB | codecs "
        "ms p50 | p95 |\n"
     << "|---|---:|---:|---:|---:|---:|\n";
  for (const auto& row : linkRows(results)) {
    md << "|";
    for (const auto& cell : row) md << " " << cell << " |";
    md << "\n";
  }
  md << "\n"
     << "## montage4d against holoportation\n\nTarget on every scene but clean: at least +0.5 dB "
        "PSNR, higher SSIM, "
        "and less flicker after a viewpoint jump. "
     << kPicturesDifferMeaning
     << "\n\n| Scene | PSNR gain | SSIM gain | flicker ratio | pictures differ on | verdict |\n"
        "|---|---:|---:|---:|---:|---|\n";
  std::vector<std::vector<std::string>> verdict_rows;
  for (const auto& scene : results) {
    const Verdict v = montageVerdict(scene);
    if (scene.modes.count("holoportation") == 0 || scene.modes.count("montage4d") == 0) continue;
    char gains[2][32];
    std::snprintf(gains[0], sizeof(gains[0]), "%+.2f dB", v.psnr_gain_db);
    std::snprintf(gains[1], sizeof(gains[1]), "%+.4f", v.ssim_gain);
    const std::string flicker_ratio = measuredText(v.flicker_ratio, "%.2f");
    const bool novel = scene.novel_view_degrees != 0;
    const bool target = scene.name != "clean" && !novel && !scene.camera_kept;
    const std::string verdict =
        novel ? std::string("novel view (all pods blended): outside the target's protocol")
        : scene.camera_kept
            ? std::string(
                  "camera kept in the blend (paper 000 Table 2's reach): outside the "
                  "target's protocol")
        : !target ? std::string("baseline, not a target")
        : v.met   ? std::string("met")
                  : "MISSED: " + v.why;
    char differ[48] = "n/a";
    if (v.agreement.measured) {
      std::snprintf(differ, sizeof(differ), "%.1f%% (%+.2f dB)", 100 * v.agreement.differing_share,
                    v.agreement.gain_bound_db);
    }
    verdict_rows.push_back({(target && !v.met ? "!" : "") + scene.name, gains[0], gains[1],
                            flicker_ratio, differ, verdict});
    std::snprintf(cell, sizeof(cell), "| %s | %+.2f dB | %+.4f | %s | %s | ", scene.name.c_str(),
                  v.psnr_gain_db, v.ssim_gain, flicker_ratio.c_str(), differ);
    md << cell << verdict << " |\n";
  }

  // Paper 000 Table 3's layout: per scene, the GPU passes of a new mesh
  // (timestamps, medians) as rows and the modes as columns, then the wall
  // clock of that render. normal mode runs no field passes.
  std::vector<std::pair<std::string, std::vector<std::vector<std::string>>>> stage_tables;
  for (const auto& scene : results) {
    if (scene.novel_view_degrees != 0 || scene.camera_kept)
      continue;                       // the same renders as the scene's own row
    std::vector<std::string> stages;  // in pipeline order
    for (const auto& stage : render::TextureFieldPasses::stageNames()) {
      for (const auto& mode : modes) {
        const auto it = scene.modes.find(mode);
        if (it != scene.modes.end() && it->second.gpu_passes_ms.count(stage) &&
            std::find(stages.begin(), stages.end(), stage) == stages.end()) {
          stages.push_back(stage);
        }
      }
    }
    auto row = [&](const std::string& label,
                   const std::function<double(const ModeResult&)>& value) {
      std::vector<std::string> cells = {label};
      for (const auto& mode : modes) {
        const auto it = scene.modes.find(mode);
        const double v = it == scene.modes.end() ? -1.0 : value(it->second);
        std::snprintf(cell, sizeof(cell), "%.2f", v);
        cells.push_back(v >= 0 ? cell : "-");
      }
      return cells;
    };
    std::vector<std::vector<std::string>> table;
    for (const auto& stage : stages) {
      table.push_back(row(stage, [&](const ModeResult& m) {
        const auto it = m.gpu_passes_ms.find(stage);
        return it == m.gpu_passes_ms.end() ? -1.0 : it->second;
      }));
    }
    table.push_back(row("field passes, total", [](const ModeResult& m) {
      double total = 0;
      for (const auto& [stage, ms] : m.gpu_passes_ms) total += ms;
      return m.gpu_passes_ms.empty() ? -1.0 : total;
    }));
    table.push_back(row("render after a new mesh (wall clock)",
                        [](const ModeResult& m) { return m.ms_per_new_mesh; }));
    stage_tables.emplace_back(scene.name, std::move(table));
  }
  md << "\n## Time per stage of a new mesh (paper 000 Table 3 layout)\n\nGPU ms per field pass "
        "(timestamps, medians; "
        "on a CPU device such as lavapipe the boundaries are approximate), then the wall clock of "
        "the whole render "
        "after a new mesh. `-`: the mode runs no such pass.\n";
  for (const auto& [name, table] : stage_tables) {
    md << "\n" << name << "\n\n| stage |";
    for (const auto& mode : modes) md << " " << mode << " |";
    md << "\n|---|";
    for (size_t i = 0; i < modes.size(); ++i) md << "---:|";
    md << "\n";
    for (const auto& cells : table) {
      md << "|";
      for (const auto& c : cells) md << " " << c << " |";
      md << "\n";
    }
  }

  // The budget (options.budget): each scene's hull and each mode's render,
  // at p95, against it.
  std::vector<std::vector<std::string>> budget_rows;
  nlohmann::json violations = nlohmann::json::array();
  for (const auto& scene : results) {
    if (scene.novel_view_degrees != 0 || scene.camera_kept) continue;
    for (const BudgetCheck& check : checkBudget(options.budget, scene, modes)) {
      char value[2][32];
      std::snprintf(value[0], sizeof(value[0]), "%.1f", check.p95_ms);
      std::snprintf(value[1], sizeof(value[1]), "%.1f", check.budget_ms);
      budget_rows.push_back(
          {(check.over() ? "!" : "") + scene.name, check.mode, check.stage, value[0], value[1]});
      if (check.over()) {
        violations.push_back({{"scene", scene.name},
                              {"mode", check.mode},
                              {"stage", check.stage},
                              {"p95_ms", check.p95_ms},
                              {"budget_ms", check.budget_ms}});
      }
    }
  }
  // A budget's stages the evaluation does not time (end_to_end, the
  // transport, the pods' rendering...) are named, not passed over in silence.
  std::string unchecked;
  nlohmann::json unchecked_stages = nlohmann::json::array();
  const std::vector<std::string> budgeted = budgetedStages();
  for (const auto& [stage, ms] : options.budget) {
    if (std::find(budgeted.begin(), budgeted.end(), stage) != budgeted.end()) continue;
    unchecked += (unchecked.empty() ? "" : ", ") + stage;
    unchecked_stages.push_back(stage);
  }
  const std::string unchecked_text =
      unchecked.empty()
          ? ""
          : " Not timed here, so not checked (the live loop's report checks them): " + unchecked +
                ".";
  if (!options.budget.empty()) {
    json["budget_ms"] = options.budget;
    json["budget_unchecked"] = unchecked_stages;
    md << "\n## Budget\n\np95 against the budget of each stage the evaluation times as the loop "
          "does ("
       << budgetedStagesText() << ")." << unchecked_text
       << (violations.empty()
               ? " Nothing is over budget.\n"
               : "\n\n| Scene | mode | stage | p95 ms | budget ms |\n|---|---|---|---:|---:|\n");
    for (const auto& v : violations) {
      std::snprintf(cell, sizeof(cell), "| %s | %s | %s | %.1f | %.1f |\n",
                    v["scene"].get<std::string>().c_str(), v["mode"].get<std::string>().c_str(),
                    v["stage"].get<std::string>().c_str(), v["p95_ms"].get<double>(),
                    v["budget_ms"].get<double>());
      md << cell;
    }
    json["budget_violations"] = violations;
  }
  std::ofstream(fs::path(out_dir) / "quality.json") << json.dump(2) << "\n";

  // The same for people, with charts.
  std::vector<std::string> scene_names;
  for (const auto& scene : results) scene_names.push_back(scene.name);
  auto metric = [&](double ModeResult::*field) {
    std::vector<html::Series> series;
    for (const auto& mode : modes) {
      html::Series s{mode, {}};
      for (const auto& scene : results) {
        const auto it = scene.modes.find(mode);
        // Negative means not measured (no seam in view, no frame pair):
        // drawn as "n/a", not as a 0 that would look best.
        const double value = it == scene.modes.end() ? -1.0 : it->second.*field;
        s.values.push_back(value < 0 ? std::nan("") : value);
      }
      series.push_back(std::move(s));
    }
    return series;
  };
  std::vector<std::vector<std::string>> rows;
  for (const auto& scene : results) {
    for (const auto& mode : modes) {
      const auto it = scene.modes.find(mode);
      if (it == scene.modes.end()) continue;
      const ModeResult& m = it->second;
      char v[4][32];
      std::snprintf(v[0], sizeof(v[0]), "%.2f%%", m.rmse_percent);
      std::snprintf(v[1], sizeof(v[1]), "%.2f dB", m.psnr_db);
      std::snprintf(v[2], sizeof(v[2]), "%.4f", m.ssim);
      std::snprintf(v[3], sizeof(v[3]), "%.1f", m.ms_per_new_mesh);
      rows.push_back({scene.name, mode, v[0], v[1], v[2], measuredText(m.flicker, "%.2f"),
                      measuredText(m.seam_visibility, "%.2f"), v[3], std::to_string(m.images)});
    }
  }
  std::string body =
      "<p>" +
      html::escape(
          std::to_string(options.frames) + " frames per scene from frame " +
          std::to_string(options.first_frame) + ", " + std::to_string(options.width) + "x" +
          std::to_string(options.height) +
          "; each camera rendered from its reported pose without its own image, "
          "compared with its true image inside its true mask (rows \"(camera kept)\": with its own "
          "image; \"+D deg\": novel poses, every camera blended).") +
      "</p>\n";
  body += html::barChart("PSNR by scene", scene_names, metric(&ModeResult::psnr_db), "dB");
  body +=
      html::barChart("SSIM by scene", scene_names, metric(&ModeResult::ssim), "luminance, masked");
  body += html::barChart("Flicker by scene", scene_names, metric(&ModeResult::flicker),
                         "grey levels per frame");
  body +=
      html::barChart("Seam visibility by scene", scene_names, metric(&ModeResult::seam_visibility),
                     "RMS error gradient along seams, grey levels per pixel");
  body += html::barChart("Client time per new mesh", scene_names,
                         metric(&ModeResult::ms_per_new_mesh), "ms");
  body +=
      "<h2>All numbers</h2>\n" + html::table({"scene", "mode", "RMSE", "PSNR", "SSIM", "flicker",
                                              "seam visibility", "ms per new mesh", "images"},
                                             rows);
  body +=
      "<h2>Links and codecs</h2>\n<p>Bytes per frame as the loop sends them, and the codecs' ms "
      "per frame: " +
      html::escape(kCodecsMeaning) + ". " + html::escape(kNoJitterHere) + "</p>\n" +
      html::table({"scene", "pods to server KB", "server to client KB", "of which feather maps KB",
                   "codecs ms p50", "p95"},
                  linkRows(results));
  body +=
      "<h2>montage4d against holoportation</h2>\n<p>Target on every scene but clean: at least +0.5 "
      "dB PSNR, "
      "higher SSIM, and less flicker after a viewpoint jump. Misses are flagged. " +
      html::escape(kPicturesDifferMeaning) + "</p>\n" +
      html::table({"scene", "PSNR gain", "SSIM gain", "flicker ratio",
                   "pictures differ on (gain if exact there)", "verdict"},
                  verdict_rows);
  // The latency budget of a new mesh per scene: the server's hull, the
  // codecs on the frame's way, and each mode's render, p50 and p95 over
  // the frames (transport is not simulated).
  if (!budget_rows.empty() || !options.budget.empty()) {
    body +=
        "<h2>Budget</h2>\n<p>p95 against the budget of each stage the evaluation times as the loop "
        "does "
        "(" +
        budgetedStagesText() + "); over-budget rows are flagged." + html::escape(unchecked_text) +
        "</p>\n" + html::table({"scene", "mode", "stage", "p95 ms", "budget ms"}, budget_rows);
  }
  body +=
      "<h2>Latency of a new mesh by stage</h2>\n<p>p50 and p95 over the renders: the hull, the "
      "codecs by stage (" +
      std::string(kCodecsMeaning) + ") and the client's render. Transport is not simulated.</p>\n";
  for (const auto& scene : results) {
    if (scene.novel_view_degrees != 0 || scene.camera_kept) continue;
    std::vector<html::StackRow> stack;
    for (const auto& mode : modes) {
      const auto it = scene.modes.find(mode);
      if (it == scene.modes.end()) continue;
      for (const bool p95 : {false, true}) {
        stack.push_back({mode + (p95 ? " p95" : " p50"), latencyParts(scene, it->second, p95)});
      }
    }
    body += html::stackedBars("Latency of a new mesh: " + scene.name, latencyStages(), stack, "ms");
  }
  body +=
      "<h2>Time per stage of a new mesh (paper 000 Table 3 layout)</h2>\n<p>GPU ms per field pass "
      "(timestamps, "
      "medians; approximate on a CPU device), then the wall clock of the render after a new "
      "mesh.</p>\n";
  std::vector<std::string> stage_header = {"stage"};
  stage_header.insert(stage_header.end(), modes.begin(), modes.end());
  for (const auto& [name, table] : stage_tables)
    body += "<h3>" + html::escape(name) + "</h3>\n" + html::table(stage_header, table);
  std::ofstream(fs::path(out_dir) / "quality.html")
      << html::page("holofuse leave-one-camera-out quality", body);
}

}  // namespace holofuse::eval
