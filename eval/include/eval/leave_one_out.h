// Leave-one-camera-out evaluation (docs/design.md section 7, paper 000 section
// 5.1): every frame of a named synthetic scene goes through the loop's own
// stages in one process (pod capture and segmentation, visual hull, Draco
// round trip, the render client's Renderer), and each camera in turn is
// rendered from its reported pose with its own image left out of the
// blend, then compared with its true image inside its true mask.
//
// The held-out camera still carves the hull, as every depth sensor shapes
// the mesh in the paper's cross-validation: only its image is withheld from
// the client (blend, vote, seams and visibility score alike).
// Each held-out camera keeps one Renderer across the frames, so montage4d's
// temporal field evolves as it would for a user sitting at that pose.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "capture_node/pod.h"
#include "codec/mesh_codec.h"
#include "eval/loop_settings.h"
#include "geometry/depth_raster.h"
#include "metrics/image_metrics.h"
#include "protocol/messages.h"
#include "protocol/stage_budget.h"
#include "render_client/blend_mode.h"
#include "render_client/renderer.h"
#include "render_client/texture_field_passes.h"
#include "scene/scene_library.h"

namespace holofuse::eval {

struct EvalOptions {
  std::vector<std::string> scenes;  // empty: the whole library (unless datasets are given)
  // Dataset folders (recorded or imported), evaluated like scenes: their
  // masks are the truth the images are compared inside.
  std::vector<std::string> datasets;
  std::vector<render::BlendMode> modes = {
      render::BlendMode::kNormal, render::BlendMode::kHoloportation, render::BlendMode::kMontage4D,
      render::BlendMode::kFragment};
  int frames = 8;
  uint64_t first_frame = 30;
  uint32_t width = 320, height = 240;
  double fps = 10.0;         // the scene clock: frame ids per second
  int held_out_cameras = 0;  // 0: every camera; else this many, evenly spread
  // Synthetic scenes only: besides leave-one-out, render at these offsets
  // (degrees around the ring) from the chosen cameras' poses with every
  // camera blended, against the scene's true image at that pose; one result
  // row per offset. Where a user sits near a pod, not between two.
  std::vector<double> novel_view_degrees;
  // Besides leave-one-out, score each chosen camera's own pose with its
  // image kept in the blend, vote and seams: one more row per scene. Paper
  // 000's Table 2 numbers (38-40 dB) are only within reach this way, since
  // a view-dependent field then gives the camera's own image most of the
  // weight. Outside the target's protocol.
  bool camera_kept = false;
  // Leave-one-out with the held-out camera's silhouette out of the hull too
  // (carved again from the others for each held-out camera and frame), not
  // only its image out of the client: nothing of the camera shapes what is
  // compared with its true image. Off by default, as in paper 000's
  // cross-validation, where every sensor shapes the mesh.
  bool hull_without_held_out = false;
  std::string out_dir;       // where save_images writes
  bool save_images = false;  // rendered, true image and mask per image compared
  std::string device;        // Vulkan device selector ("" picks a GPU if any)
  // "hull": the fusion server's visual hull (what the loop sees); "truth":
  // the scene's true surface, to tell blending errors from geometry errors.
  std::string geometry = "hull";
  // The live loop's own settings, which the sweep's knobs turn: the pods'
  // encoding, the server's fusion (loop.fusion.hull.voxel_size, the hull
  // error target: each scene's voxel is then the coarsest from the voxel
  // down that meets it on the first frame, hull::carveToErrorTarget), the
  // client's rendering (its mode aside: modes above).
  LoopSettings loop;
  // A dataset carves at the voxel size it was recorded or imported with
  // unless a voxel is given (--voxel, the sweep's voxel knob).
  bool voxel_from_dataset = true;
  int cameras = 0;  // 0: the scene's own count
  // Per-stage ms budgets (render::loadBudget's file); the reports flag each
  // scene and mode whose p95 goes over the budget of a stage the evaluation
  // times the way the live loop does: "hull", the codec stages
  // (codecStages()) and "render".
  protocol::Budget budget;
};

struct ModeResult {
  double rmse_percent = 0, psnr_db = 0, ssim = 0;  // means over the images compared
  // Mean frame-to-frame change of the error image, grey levels; negative:
  // not measured (no two consecutive frames were compared).
  double flicker = -1;
  double seam_visibility =
      -1;  // mean of eval::seamVisibility over images with seams in view; -1: none
  size_t images = 0;
  double ms_per_new_mesh = 0;  // median wall time of a render that follows a new mesh
  std::map<std::string, double> gpu_passes_ms;  // medians of the field passes' timestamps
  double ms_per_new_mesh_p95 = 0;               // the 95th percentile of ms_per_new_mesh's renders
  metrics::RegionErrors regions;  // the squared error over every image, by where it sits
  // Bytes a frame takes on the client link in this mode: the scene's
  // (mesh, images, stats) for the modes of camera images; for mode
  // layered the mesh, the texture layers built from every camera and the
  // stats.
  double client_bytes_per_frame = 0;
  double layers_ms = 0;  // mode layered: median of the server's layer builds (0: other modes)
  // mode layered with --layer-video: median of the server's video coding
  // of the layers (0: LZ4 layers, or other modes)
  double layer_video_ms = 0;
  // Of client_bytes_per_frame: the MeshFrame; for mode layered the layers'
  // colour planes (video or LZ4) and their camera planes.
  double mesh_bytes_per_frame = 0, layer_colour_bytes_per_frame = 0,
         layer_camera_bytes_per_frame = 0;
  // Mode layered: the mean share of the atlas's squares a video coder
  // cannot predict in place from the frame before (AtlasStats::
  // movedFraction), over every frame but a stream's first; -1: not measured.
  double atlas_moved = -1;
};

// The share of the squared-error difference between normal and the mode
// that each region carries: (normal's - the mode's) in the region over the
// same in all; sums to 1. Empty where normal did not run or the two
// errors differ by under 1e-9 of normal's (no difference to share).
// One channel, an ErrorRegion per pixel of a compared view
// (kOutsideRegions outside mask): within reach_px of the mask's background
// (the silhouette border), then within reach_px of a depth discontinuity
// of the mesh seen from the pose (depth, kNoDepth where none: the
// discontinuity test of paper 000 section 4.2, reference::
// dilatedDiscontinuities, so the mesh's outline counts too), then the
// seams (one channel, non-zero on a seam), then elsewhere.
Image8 errorRegions(const Image8& mask, const DepthMap& depth, const Image8& seams,
                    int reach_px = 3, double relative_jump = 0.03);

std::map<std::string, double> regionSharesAgainstNormal(
    const std::map<std::string, ModeResult>& modes, const std::string& mode);

// What a frame's codec time covers, for reports.
inline constexpr const char* kCodecsMeaning =
    "the slowest pod's encoding, the server's decoding of every pod frame and its Draco and image "
    "encoding for "
    "clients, and the client's decoding of both";
// Why a leave-one-out report has no per-pod jitter, and where to read it.
inline constexpr const char* kNoJitterHere =
    "The evaluation runs every stage in one process, with no network, so it has no arrival jitter: "
    "the live loop's "
    "report (./holofuse demo) gives each pod's RFC 3550 jitter at the server, and so does each "
    "point of a sweep "
    "run with --live-frames.";

// The codec stages of a frame, in order, under the live report's stage
// names (report.json latency_ms.stages): pod_encode and server_decode
// (per pod frame, as the live report samples them; in a frame's codec
// total, the slowest pod's encoding and every pod's decoding, which the
// server does one after another as they arrive), mesh_encode, image_encode
// and decode (the client's images and Draco mesh).
inline const std::vector<std::string>& codecStages() {
  static const std::vector<std::string> stages = {"pod_encode", "server_decode", "mesh_encode",
                                                  "image_encode", "decode"};
  return stages;
}

// The stages a budget file can hold that the evaluation times as the loop
// stamps them: hull, refine, the codec stages, render; and the same listed for
// people: "hull, pod_encode, ..., render".
inline std::vector<std::string> budgetedStages() {
  std::vector<std::string> stages = {"hull", "refine"};
  stages.insert(stages.end(), codecStages().begin(), codecStages().end());
  stages.push_back("render");
  return stages;
}
inline std::string budgetedStagesText() {
  std::string text;
  for (const std::string& stage : budgetedStages()) text += (text.empty() ? "" : ", ") + stage;
  return text;
}

// montage4d's pictures against holoportation's, view for view (both modes
// run): the share of the compared pixels where they differ by more than 2
// grey levels, holoportation's squared error there as a share of its
// whole, and what montage4d's mean PSNR would gain on holoportation's if
// its pictures were exact on every differing pixel (metrics/image_metrics.h
// PictureAgreement): how much of the picture montage4d's fields change at
// these settings, and the most those changes could gain.
struct ModeAgreement {
  bool measured = false;
  double differing_share = 0, holoportation_error_share = 0, gain_bound_db = 0;
};

struct SceneResult {
  std::string name, stresses;
  double novel_view_degrees = 0;  // 0: leave-one-camera-out; else the offset of a novel-view row
  bool camera_kept =
      false;  // the held-out camera's image stayed in the blend (EvalOptions::camera_kept)
  int cameras = 0;
  double hull_ms = 0;  // median
  // Median per frame of the codecs (kCodecsMeaning), through the loop's own
  // encoding and decoding code.
  double codec_ms = 0;
  double hull_ms_p95 = 0, codec_ms_p95 = 0;  // 95th percentiles of the same
  double refine_ms = 0,
         refine_ms_p95 = 0;  // the hull's refinement (0 without it): median, 95th percentile
  // Per codec stage (codecStages()): median and 95th percentile over frames,
  // or for pod_encode and server_decode over pod frames (as the live report
  // samples them).
  std::map<std::string, double> codec_stage_ms, codec_stage_ms_p95;
  double triangles = 0;  // mean
  double view_jump_degrees = 0;
  // Means per frame, as the loop sends them: server to one client (the
  // Draco MeshFrame, the TextureBundle of every camera's images, the
  // Stats), and every pod to the server (the PodFrames).
  double bytes_per_frame = 0;
  double feather_bytes_per_frame = 0;  // of bytes_per_frame, the pods' feather maps
  double pod_link_bytes_per_frame = 0;
  // The geometry against the truth, on the first frame (hull as decoded by
  // the client; truth by marching cubes at 1 cm).
  double chamfer_mm = 0;               // negative: no true surface (datasets)
  std::vector<double> silhouette_iou;  // per camera
  // The pods' masks against the truth (synthetic scenes; empty for
  // datasets): per camera, the worst IoU over the frames; and the share of
  // the true shadow's pixels taken for the subject (negative: no shadow).
  std::vector<double> mask_iou;
  // The same masks after the rig's agreement (hull/mask_agreement.h): what
  // import records, and what the live pods would send were they told.
  std::vector<double> mask_iou_agreed;
  double shadow_taken = -1;
  double cells_visited = 0;  // mean per frame (eval/visual_hull.h's count)
  double voxel_mm = 0;       // the hull's voxel
  double silhouette_error_mm =
      -1;  // first frame, against the segmented masks; negative: not measured
  ModeAgreement montage_agreement;
  double dense_grid_points = 0;             // what the dense grid would have sampled
  std::map<std::string, ModeResult> modes;  // by blendModeName
};

// A new mesh's latency by stage for the reports' stacked bars: the hull,
// each codec stage (codecStages()), the client's render; and one row of it
// for a mode's result, at p50 or p95.
std::vector<std::string> latencyStages();
std::vector<double> latencyParts(const SceneResult& scene, const ModeResult& mode, bool p95);

// progress(text) is called with one line per finished held-out sequence.
// An error names what is wrong with the options, or the dataset, file and
// record that cannot be read.
StatusOr<std::vector<SceneResult>> runLeaveOneOut(
    const EvalOptions& options, const std::function<void(const std::string&)>& progress = {});

// quality.json (scene -> mode -> metric, with the settings) and quality.md
// (paper 000 Table 2 layout, plus flicker and the montage4d verdict).
Status writeQualityReports(const EvalOptions& options, const std::vector<SceneResult>& results,
                           const std::string& out_dir);

// One budgeted stage of a scene (and mode, "-" for the server's and the
// codecs' stages) at p95 against its budget.
struct BudgetCheck {
  std::string mode, stage;
  double p95_ms = 0, budget_ms = 0;
  bool over() const { return p95_ms > budget_ms; }
};
// Every stage of budget the evaluation times (budgetedStagesText()) for the
// scene's hull and codecs and each of modes' render.
std::vector<BudgetCheck> checkBudget(const protocol::Budget& budget, const SceneResult& scene,
                                     const std::vector<std::string>& modes);

// A metric that may not have been measured (negative), for a table cell:
// the value in format, or "n/a".
std::string measuredText(double value, const char* format);

// The target of issue "Measure it": montage4d beats holoportation by at
// least 0.5 dB PSNR and in SSIM (and flickers less after a viewpoint jump).
struct Verdict {
  double psnr_gain_db = 0, ssim_gain = 0;
  double flicker_ratio = -1;  // montage4d's flicker over holoportation's; negative: not measured
  ModeAgreement agreement;    // the scene's
  bool met = false;
  std::string why;  // what fell short, empty when met
};
Verdict montageVerdict(const SceneResult& scene);

}  // namespace holofuse::eval
