// The leave-one-camera-out runner end to end on a tiny configuration (real
// pods' capture code, hull, Draco, lavapipe), its reports, its bad input,
// and the verdict rule.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "browser_check.h"
#include "eval/leave_one_out.h"

namespace holofuse::eval {
namespace {

// An EXR's channel names and float values, read as any EXR viewer would.
struct FloatFile {
  std::vector<std::string> channels;
  std::vector<float> values;
};
FloatFile readFloatFile(const std::string& path) {
  FloatFile file;
  auto in = OIIO::ImageInput::open(path);
  if (!in) return file;
  const OIIO::ImageSpec& spec = in->spec();
  file.channels = spec.channelnames;
  file.values.resize(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, file.values.data()))
    file.values.clear();
  return file;
}

namespace fs = std::filesystem;

EvalOptions tiny() {
  EvalOptions options;
  options.frames = 2;
  options.width = 160;
  options.height = 120;
  options.held_out_cameras = 1;
  return options;
}

// Every progress line says which part of the whole run it is in (here two
// scenes) and, once there is a pace, the time the run has left.
TEST(LeaveOneOut, ProgressLinesCountTheRunsPartsWithTheTimeLeft) {
  EvalOptions options = tiny();
  options.scenes = {"few-cameras", "clean"};
  options.modes = {render::BlendMode::kNormal};
  std::vector<std::string> lines;
  ASSERT_TRUE(
      runLeaveOneOut(options, [&](const std::string& line) { lines.push_back(line); }).isOk());
  ASSERT_EQ(lines.size(), 2u) << "a held-out camera of each scene";
  EXPECT_EQ(lines[0].rfind("few-cameras / normal: ", 0), 0u) << lines[0];
  EXPECT_NE(lines[0].find("; the run: part 1 of 2, ETA "), std::string::npos) << lines[0];
  EXPECT_EQ(lines[1].rfind("clean / normal: ", 0), 0u) << lines[1];
  EXPECT_NE(lines[1].find("; the run: part 2 of 2, ETA 0 s"), std::string::npos) << lines[1];
}

TEST(LeaveOneOut, MeasuresEveryModeAndWritesReportsAndImages) {
  EvalOptions options = tiny();
  options.scenes = {"few-cameras"};
  options.save_images = true;
  options.out_dir = (fs::temp_directory_path() / "holofuse_eval_test").string();
  fs::remove_all(options.out_dir);
  const auto results = runLeaveOneOut(options).value();
  ASSERT_EQ(results.size(), 1u);
  const SceneResult& scene = results[0];
  EXPECT_EQ(scene.cameras, 4);
  EXPECT_GT(scene.triangles, 1000);
  ASSERT_EQ(scene.modes.size(), 4u) << "normal, holoportation, montage4d, fragment";
  for (const auto& [mode, m] : scene.modes) {
    EXPECT_EQ(m.images, 2u) << mode;
    // A coarse hull from four 160x120 silhouettes: far from perfect, far
    // from noise.
    EXPECT_GT(m.psnr_db, 8.0) << mode;
    EXPECT_LT(m.psnr_db, 40.0) << mode;
    EXPECT_GT(m.ssim, 0.05) << mode;
    EXPECT_LT(m.ssim, 1.0) << mode;
    EXPECT_NEAR(m.rmse_percent, 100.0 * std::sqrt(std::pow(10.0, -m.psnr_db / 10.0)),
                0.35 * m.rmse_percent)
        << "RMSE and PSNR describe the same errors (means of each differ a little)";
    EXPECT_GE(m.flicker, 0.0) << mode << ": two frames give one pair to compare";
    EXPECT_TRUE(std::isfinite(m.flicker));
    // No pod of the other three looks within 60 degrees of the held-out
    // one; the seams of the two beside it, 90 degrees away, are measured.
    EXPECT_GT(m.seam_visibility, 0.0) << mode;
    EXPECT_TRUE(std::isfinite(m.seam_visibility)) << mode;
    EXPECT_GT(m.ms_per_new_mesh, 0.0);
    EXPECT_GE(m.ms_per_new_mesh_p95, m.ms_per_new_mesh);
  }
  EXPECT_FALSE(scene.modes.at("montage4d").gpu_passes_ms.empty());
  // The two field modes' pictures compared view for view: the gain of
  // montage4d exact wherever it differs bounds the gain it has.
  ASSERT_TRUE(scene.montage_agreement.measured);
  EXPECT_GE(scene.montage_agreement.differing_share, 0.0);
  EXPECT_LE(scene.montage_agreement.differing_share, 1.0);
  EXPECT_GE(scene.montage_agreement.gain_bound_db + 1e-9,
            scene.modes.at("montage4d").psnr_db - scene.modes.at("holoportation").psnr_db);
  EXPECT_GT(scene.codec_ms, 0.0) << "image and Draco coding on the frame's way";
  EXPECT_GE(scene.codec_ms_p95, scene.codec_ms);
  // Every codec stage of the loop is timed.
  ASSERT_EQ(scene.codec_stage_ms.size(), codecStages().size());
  for (const auto& [stage, ms] : scene.codec_stage_ms) EXPECT_GT(ms, 0.0) << stage;
  EXPECT_GT(scene.pod_link_bytes_per_frame, 0.0);
  EXPECT_GT(scene.bytes_per_frame, 0.0);
  EXPECT_GE(scene.hull_ms_p95, scene.hull_ms);
  // The hull against the truth: a superset a few voxels thick, covering
  // each true silhouette.
  EXPECT_GT(scene.chamfer_mm, 2.0);
  EXPECT_LT(scene.chamfer_mm, 60.0);
  ASSERT_EQ(scene.silhouette_iou.size(), 4u);
  for (double iou : scene.silhouette_iou) EXPECT_GT(iou, 0.6);
  EXPECT_LT(scene.cells_visited, scene.dense_grid_points)
      << "the hierarchical hull samples less than the dense grid";
  ASSERT_TRUE(writeQualityReports(options, results, options.out_dir).isOk());
  std::ifstream json_file(fs::path(options.out_dir) / "quality.json");
  const auto json = nlohmann::json::parse(json_file);
  EXPECT_DOUBLE_EQ(json["scenes"]["few-cameras"]["modes"]["montage4d"]["psnr_db"].get<double>(),
                   scene.modes.at("montage4d").psnr_db);
  EXPECT_TRUE(json["scenes"]["few-cameras"].contains("montage4d_against_holoportation"));
  EXPECT_DOUBLE_EQ(json["scenes"]["few-cameras"]["montage4d_against_holoportation"]["pictures"]
                       ["psnr_gain_bound_db"]
                           .get<double>(),
                   scene.montage_agreement.gain_bound_db);
  std::ifstream md(fs::path(options.out_dir) / "quality.md");
  const std::string text((std::istreambuf_iterator<char>(md)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("| few-cameras |"), std::string::npos);
  // Paper 000 Table 2's layout: RMSE, PSNR, SSIM and fps per mode; flicker
  // and seams in a table of their own.
  EXPECT_NE(
      text.find(
          "| Scene | normal RMSE | normal PSNR | normal SSIM | normal fps | holoportation RMSE |"),
      std::string::npos);
  EXPECT_NE(text.find("| Scene | normal flicker | normal seams | holoportation flicker |"),
            std::string::npos);
  // Paper 000 Table 3's layout: the passes as rows, the modes as columns;
  // normal mode runs none of them.
  const size_t table3 = text.find("## Time per stage of a new mesh (paper 000 Table 3 layout)");
  ASSERT_NE(table3, std::string::npos);
  EXPECT_NE(text.find("| stage | normal | holoportation | montage4d |", table3), std::string::npos);
  EXPECT_NE(text.find("| geodesics | - |", table3), std::string::npos);
  EXPECT_NE(text.find("| render after a new mesh (wall clock) |", table3), std::string::npos);
  // The page this run wrote, in a browser: PSNR, SSIM, flicker, seam
  // visibility and time per mode, and the scene's latency stack, each drawn
  // as its values say.
  if (!holofuse::test::chromium().empty()) {
    EXPECT_EQ(holofuse::test::chartsRendered(fs::path(options.out_dir) / "quality.html"), 6);
  }
  // Anyone can recompute the numbers from the saved images with their own
  // tools: here OpenCV's PNG reader and a plain masked PSNR (every channel
  // of every pixel inside the mask, peak 255), averaged over the images as
  // the report does.
  for (const auto& [mode, m] : scene.modes) {
    double psnr_sum = 0, squared_sum = 0;
    size_t values_sum = 0;
    int images = 0;
    for (const char* frame : {"frame30", "frame31"}) {
      const fs::path stem = fs::path(options.out_dir) / "images" / "few-cameras" / mode /
                            (std::string(frame) + "_camera0_");
      const cv::Mat rendered = cv::imread(stem.string() + "rendered.png", cv::IMREAD_COLOR);
      const cv::Mat truth = cv::imread(stem.string() + "true.png", cv::IMREAD_COLOR);
      const cv::Mat mask = cv::imread(stem.string() + "mask.png", cv::IMREAD_GRAYSCALE);
      ASSERT_FALSE(rendered.empty() || truth.empty() || mask.empty()) << stem;
      ASSERT_EQ(rendered.size(), truth.size());
      EXPECT_EQ(cv::imread(stem.string() + "rendered.png", cv::IMREAD_UNCHANGED).channels(), 3)
          << "RGB, as the truth";
      double squared = 0;
      size_t values = 0;
      for (int y = 0; y < mask.rows; ++y) {
        for (int x = 0; x < mask.cols; ++x) {
          if (mask.at<uint8_t>(y, x) == 0) continue;
          for (int c = 0; c < 3; ++c) {
            const double d = rendered.at<cv::Vec3b>(y, x)[c] - truth.at<cv::Vec3b>(y, x)[c];
            squared += d * d;
            ++values;
          }
        }
      }
      ASSERT_GT(values, 0u);
      psnr_sum += 10.0 * std::log10(255.0 * 255.0 / (squared / static_cast<double>(values)));
      squared_sum += squared;
      values_sum += values;
      ++images;
      // The error map is black outside the mask and somewhere not black
      // inside it; the regions picture colours exactly the mask's pixels.
      const cv::Mat error = cv::imread(stem.string() + "error.png", cv::IMREAD_COLOR);
      const cv::Mat regions = cv::imread(stem.string() + "regions.png", cv::IMREAD_COLOR);
      ASSERT_FALSE(error.empty() || regions.empty()) << stem;
      size_t lit_error = 0, dark_outside = 0, outside = 0, region_inside = 0, inside = 0;
      for (int y = 0; y < mask.rows; ++y) {
        for (int x = 0; x < mask.cols; ++x) {
          const bool in = mask.at<uint8_t>(y, x) != 0;
          const bool error_lit = error.at<cv::Vec3b>(y, x) != cv::Vec3b(0, 0, 0);
          const bool region_lit = regions.at<cv::Vec3b>(y, x) != cv::Vec3b(0, 0, 0);
          inside += in;
          outside += !in;
          lit_error += in && error_lit;
          dark_outside += !in && !error_lit && !region_lit;
          region_inside += in && region_lit;
        }
      }
      EXPECT_EQ(dark_outside, outside) << stem;
      EXPECT_EQ(region_inside, inside) << stem;
      EXPECT_GT(lit_error, 0u) << stem;
      // The float maps beside them, as an EXR reader opens them: the signed
      // error is the PNGs' difference over 255 inside the mask and 0
      // outside; in the field modes the other cameras' weights lie in
      // [0, 1] and sum to at most one (zero where no field reaches and the
      // blend falls back on the normal weights), exactly one somewhere.
      const FloatFile error_exr = readFloatFile(stem.string() + "error.exr");
      ASSERT_EQ(error_exr.channels, (std::vector<std::string>{"error.R", "error.G", "error.B"}));
      ASSERT_EQ(error_exr.values.size(), static_cast<size_t>(mask.rows * mask.cols * 3));
      size_t wrong = 0;
      for (int y = 0; y < mask.rows; ++y) {
        for (int x = 0; x < mask.cols; ++x) {
          for (int c = 0; c < 3; ++c) {  // OpenCV's blue first
            const double expected =
                mask.at<uint8_t>(y, x) == 0
                    ? 0.0
                    : (rendered.at<cv::Vec3b>(y, x)[2 - c] - truth.at<cv::Vec3b>(y, x)[2 - c]) /
                          255.0;
            wrong += std::abs(error_exr.values[(y * mask.cols + x) * 3 + c] - expected) > 1e-6;
          }
        }
      }
      EXPECT_EQ(wrong, 0u) << stem;
      const fs::path weights_file = stem.string() + "weights.exr";
      if (mode == "normal") {
        EXPECT_FALSE(fs::exists(weights_file)) << "mode normal has no per-vertex fields";
        continue;
      }
      if (mode == "fragment" && !fs::exists(weights_file)) continue;
      const FloatFile weights = readFloatFile(weights_file.string());
      ASSERT_FALSE(weights.channels.empty()) << weights_file;
      for (const std::string& name : weights.channels) {
        EXPECT_EQ(name.rfind("weight.camera", 0), 0u) << name;
        EXPECT_NE(name, "weight.camera0") << "camera 0 is the one left out";
      }
      const size_t k = weights.channels.size();
      size_t seen = 0, whole = 0, out_of_range = 0;
      for (size_t p = 0; p * k < weights.values.size(); ++p) {
        double sum = 0;
        for (size_t c = 0; c < k; ++c) {
          const float w = weights.values[p * k + c];
          out_of_range += !(w >= 0.0f && w <= 1.0f + 1e-5f);
          sum += w;
        }
        if (sum <= 0) continue;
        ++seen;
        whole += std::abs(sum - 1.0) < 1e-3;
        out_of_range += sum > 1.0 + 1e-3;
      }
      EXPECT_EQ(out_of_range, 0u) << weights_file;
      EXPECT_GT(seen, 0u) << weights_file;
      EXPECT_GT(whole, 0u) << weights_file;
    }
    EXPECT_NEAR(psnr_sum / images, m.psnr_db, 1e-9)
        << mode << ": the saved images give the reported PSNR";
    // The regions split the very error the PSNR is made of: every pixel
    // inside the masks in one region, their squared errors adding up.
    size_t region_pixels = 0;
    double region_squared = 0;
    for (size_t r = 0; r < holofuse::metrics::kErrorRegionCount; ++r) {
      region_pixels += m.regions.pixels[r];
      region_squared += m.regions.squared_error[r];
    }
    EXPECT_EQ(3 * region_pixels, values_sum) << mode;
    EXPECT_NEAR(region_squared, squared_sum, 1e-6 * squared_sum) << mode;
    EXPECT_GT(
        m.regions.pixels[static_cast<size_t>(holofuse::metrics::ErrorRegion::kSilhouetteBorder)],
        0u)
        << mode;
    EXPECT_GT(m.regions.pixels[static_cast<size_t>(holofuse::metrics::ErrorRegion::kElsewhere)], 0u)
        << mode;
    if (mode == "normal") continue;
    // The shares of the difference from normal sum to one, in the report too.
    const auto shares = regionSharesAgainstNormal(scene.modes, mode);
    ASSERT_EQ(shares.size(), holofuse::metrics::kErrorRegionCount) << mode;
    double share_sum = 0;
    for (const auto& [region, share] : shares) {
      share_sum += share;
      EXPECT_DOUBLE_EQ(
          json["scenes"]["few-cameras"]["modes"][mode]["share_of_difference_from_normal"][region]
              .get<double>(),
          share);
    }
    EXPECT_NEAR(share_sum, 1.0, 1e-9) << mode;
  }
  EXPECT_NE(text.find("## Where the errors differ"), std::string::npos);
  EXPECT_NE(text.find("| few-cameras | pixels |"), std::string::npos);
  fs::remove_all(options.out_dir);
}

// Pods that send only their foreground's rectangle (the default margin)
// cost the links less and change nothing downstream: the server carves
// the same hull from them and every mode renders the same picture as from
// whole images.
TEST(LeaveOneOut, CroppedPodImagesGiveTheSameHullAndPicturesAsWholeOnes) {
  EvalOptions options = tiny();
  options.scenes = {"clean"};
  options.loop.pods.crop_margin = -1;
  const SceneResult whole = runLeaveOneOut(options).value().at(0);
  options.loop.pods.crop_margin = 8;
  const SceneResult cropped = runLeaveOneOut(options).value().at(0);
  EXPECT_EQ(cropped.triangles, whole.triangles);
  EXPECT_DOUBLE_EQ(cropped.chamfer_mm, whole.chamfer_mm);
  for (const auto& [mode, m] : whole.modes) {
    EXPECT_DOUBLE_EQ(cropped.modes.at(mode).psnr_db, m.psnr_db) << mode;
    EXPECT_DOUBLE_EQ(cropped.modes.at(mode).ssim, m.ssim) << mode;
  }
  EXPECT_LT(cropped.pod_link_bytes_per_frame, 0.7 * whole.pod_link_bytes_per_frame);
  EXPECT_LT(cropped.bytes_per_frame, 0.7 * whole.bytes_per_frame);
}

// Stricter leave-one-out: the held-out camera's silhouette leaves the hull
// too. The hull from the other three pods is another (larger) one, so the
// scores move; the scene's geometry numbers stay those of the loop's hull.
TEST(LeaveOneOut, TheHullCanBeCarvedWithoutTheHeldOutCameraToo) {
  EvalOptions options = tiny();
  options.scenes = {"few-cameras"};
  options.modes = {render::BlendMode::kNormal};
  const SceneResult shaped = runLeaveOneOut(options).value().at(0);
  options.hull_without_held_out = true;
  const SceneResult strict = runLeaveOneOut(options).value().at(0);
  EXPECT_NE(strict.modes.at("normal").psnr_db, shaped.modes.at("normal").psnr_db);
  EXPECT_EQ(strict.modes.at("normal").images, shaped.modes.at("normal").images);
  EXPECT_EQ(strict.triangles, shaped.triangles) << "the scene's hull is the loop's";
  EXPECT_DOUBLE_EQ(strict.chamfer_mm, shaped.chamfer_mm);
  options.out_dir = (fs::temp_directory_path() / "holofuse_eval_strict").string();
  ASSERT_TRUE(writeQualityReports(options, {strict}, options.out_dir).isOk());
  std::ifstream in(fs::path(options.out_dir) / "quality.json");
  EXPECT_EQ(nlohmann::json::parse(in)["settings"]["hull_without_held_out"], true);
  fs::remove_all(options.out_dir);
  options.geometry = "truth";  // nothing to carve again
  EXPECT_FALSE(runLeaveOneOut(options).isOk());
}

// Mode layered as the loop runs it (the server's layer stage, the wire,
// the client's decoding): each held-out view is rendered from layers of
// the other cameras only, scores close to the camera images' blend at
// fewer client milliseconds per view, and its bytes are the layers' (of
// every camera) in place of the images'.
TEST(LeaveOneOut, ModeLayeredScoresNearTheImagesFromLayersOfTheOtherCameras) {
  EvalOptions options = tiny();
  options.scenes = {"clean"};
  options.modes = {render::BlendMode::kNormal, render::BlendMode::kLayered};
  const SceneResult result = runLeaveOneOut(options).value().at(0);
  const ModeResult& normal = result.modes.at("normal");
  const ModeResult& layered = result.modes.at("layered");
  EXPECT_EQ(layered.images, normal.images);
  // Measured at 160x120, 8 cameras, one held out, charts at 3 texels a
  // voxel: 0.15 dB and 0.025 SSIM below (the atlas resamples small images).
  EXPECT_NEAR(layered.psnr_db, normal.psnr_db, 0.6);
  EXPECT_NEAR(layered.ssim, normal.ssim, 0.03);
  EXPECT_GT(layered.layers_ms, 0.0);
  EXPECT_EQ(normal.layers_ms, 0.0);
  EXPECT_DOUBLE_EQ(normal.client_bytes_per_frame, result.bytes_per_frame);
  EXPECT_NE(layered.client_bytes_per_frame, result.bytes_per_frame);
  EXPECT_GT(layered.client_bytes_per_frame, 0.0);
  // The link's parts: the same mesh in both modes; the layers' colour and
  // camera planes inside what the client receives; the atlas's charts
  // mostly kept in place frame to frame.
  EXPECT_GT(normal.mesh_bytes_per_frame, 0.0);
  EXPECT_DOUBLE_EQ(layered.mesh_bytes_per_frame, normal.mesh_bytes_per_frame);
  EXPECT_EQ(normal.layer_colour_bytes_per_frame, 0.0);
  EXPECT_GT(layered.layer_colour_bytes_per_frame, 0.0);
  EXPECT_GT(layered.layer_camera_bytes_per_frame, 0.0);
  EXPECT_LT(layered.mesh_bytes_per_frame + layered.layer_colour_bytes_per_frame +
                layered.layer_camera_bytes_per_frame,
            layered.client_bytes_per_frame);
  EXPECT_EQ(normal.atlas_moved, -1.0);
  EXPECT_GE(layered.atlas_moved, 0.0);
  EXPECT_LT(layered.atlas_moved, 0.5);
  RecordProperty("layered_minus_normal_psnr_db", std::to_string(layered.psnr_db - normal.psnr_db));
  RecordProperty("layered_minus_normal_ssim", std::to_string(layered.ssim - normal.ssim));
  RecordProperty("layered_over_normal_bytes",
                 std::to_string(layered.client_bytes_per_frame / normal.client_bytes_per_frame));
}

// The layers' colour as H.264 (--layer-video): the same views from the
// same layers, coded over the sequence's frames (a key frame, then
// predicted ones) and decoded as a client decodes them: fewer bytes than
// LZ4 layers, nearly their picture, and the coding's own milliseconds.
TEST(LeaveOneOut, LayersAsVideoCostFewerBytesThanLz4LayersForNearlyTheirPicture) {
  EvalOptions options = tiny();
  options.scenes = {"clean"};
  options.frames = 3;
  options.modes = {render::BlendMode::kLayered};
  const ModeResult lz4 = runLeaveOneOut(options).value().at(0).modes.at("layered");
  options.loop.fusion.layers.video.codec = protocol::Codec::kH264;
  const ModeResult video = runLeaveOneOut(options).value().at(0).modes.at("layered");
  EXPECT_EQ(video.images, lz4.images);
  EXPECT_EQ(lz4.layer_video_ms, 0.0);
  EXPECT_GT(video.layer_video_ms, 0.0);
  // Measured at 8 pods 320x240, 4 frames (crf 12, 4:4:4): 39% of the
  // client link with LZ4 layers, PSNR 0.05 dB and SSIM 0.013 lower.
  EXPECT_LT(video.client_bytes_per_frame, 0.8 * lz4.client_bytes_per_frame);
  EXPECT_NEAR(video.psnr_db, lz4.psnr_db, 0.3);
  EXPECT_NEAR(video.ssim, lz4.ssim, 0.03);
  RecordProperty("video_over_lz4_bytes",
                 std::to_string(video.client_bytes_per_frame / lz4.client_bytes_per_frame));
}

// --layer-video-crf-step: each layer after the first at a higher CRF.
// The deeper layer's stream shrinks, the first layer's stays as it was,
// so the whole link shrinks for nearly the same picture.
TEST(LeaveOneOut, DeeperLayersAtAHigherCrfCostFewerBytesForNearlyThePicture) {
  EvalOptions options = tiny();
  options.scenes = {"clean"};
  options.frames = 3;
  options.modes = {render::BlendMode::kLayered};
  options.loop.fusion.layers.video.codec = protocol::Codec::kH264;
  options.loop.fusion.layers.video_crf_step = 0;
  const ModeResult alike = runLeaveOneOut(options).value().at(0).modes.at("layered");
  options.loop.fusion.layers.video_crf_step = 12;
  const ModeResult stepped = runLeaveOneOut(options).value().at(0).modes.at("layered");
  EXPECT_LT(stepped.client_bytes_per_frame, 0.95 * alike.client_bytes_per_frame);
  EXPECT_NEAR(stepped.psnr_db, alike.psnr_db, 0.3);
  EXPECT_NEAR(stepped.ssim, alike.ssim, 0.02);
}

TEST(LeaveOneOut, AViewpointJumpComparesOnlyTheFramesAtTheHeldOutPose) {
  EvalOptions options = tiny();
  options.scenes = {"viewpoint-jump"};
  options.frames = 4;
  options.modes = {render::BlendMode::kNormal};
  const auto results = runLeaveOneOut(options).value();
  EXPECT_EQ(results.at(0).modes.at("normal").images, 2u) << "two frames before the jump, two after";
}

TEST(LeaveOneOut, TheTrueSurfaceScoresAboveTheHullSoGeometryErrorsShow) {
  EvalOptions options = tiny();
  options.scenes = {"few-cameras"};
  options.frames = 1;
  options.modes = {render::BlendMode::kNormal};
  const double hull = runLeaveOneOut(options).value().at(0).modes.at("normal").psnr_db;
  options.geometry = "truth";
  const double truth = runLeaveOneOut(options).value().at(0).modes.at("normal").psnr_db;
  EXPECT_GT(truth, hull + 1.0) << "hull " << hull << " dB, true surface " << truth << " dB";
  options.geometry = "mesh-of-dreams";
  EXPECT_FALSE(runLeaveOneOut(options).isOk());
}

// Novel views: every pod blended, the truth rendered by the scene at the
// new pose. Beside a pod the picture is far better than where leave-one-out
// puts the user (no pod of four sees the held-out camera's front), and
// better than halfway between two pods.
TEST(LeaveOneOut, NovelViewsBesideAPodScoreAboveViewsBetweenPods) {
  EvalOptions options = tiny();
  options.scenes = {"few-cameras"};
  options.frames = 1;
  options.modes = {render::BlendMode::kNormal};
  options.novel_view_degrees = {5, 45};
  const auto results = runLeaveOneOut(options).value();
  ASSERT_EQ(results.size(), 3u);
  EXPECT_EQ(results[0].name, "few-cameras");
  EXPECT_EQ(results[1].name, "few-cameras +5 deg");
  EXPECT_EQ(results[2].name, "few-cameras +45 deg");
  EXPECT_DOUBLE_EQ(results[1].novel_view_degrees, 5.0);
  for (const auto& row : results) EXPECT_EQ(row.modes.at("normal").images, 1u) << row.name;
  const double held_out = results[0].modes.at("normal").psnr_db,
               beside = results[1].modes.at("normal").psnr_db,
               between = results[2].modes.at("normal").psnr_db;
  EXPECT_GT(beside, held_out + 3.0) << held_out << " / " << beside;
  EXPECT_GT(beside, between) << beside << " / " << between;
  // Beside a pod its seams are in view: the error of a coarse hull's
  // textures changes across them, by far less than a full-range step.
  EXPECT_GT(results[1].modes.at("normal").seam_visibility, 0.5);
  EXPECT_LT(results[1].modes.at("normal").seam_visibility, 100.0);
  EXPECT_FALSE(montageVerdict(results[1]).met) << "needs both modes";
}

// With the held-out camera's image kept in the blend, montage4d's view
// weight gives that image the most weight at its own pose: far better than
// leave-one-out, which must do without it. The row says so in its JSON.
TEST(LeaveOneOut, KeepingTheCameraInTheBlendAddsARowThatScoresAboveLeaveOneOut) {
  EvalOptions options = tiny();
  options.scenes = {"few-cameras"};
  options.frames = 1;
  options.modes = {render::BlendMode::kHoloportation, render::BlendMode::kMontage4D};
  options.camera_kept = true;
  options.save_images = true;
  options.out_dir = (fs::temp_directory_path() / "holofuse_eval_kept_images").string();
  fs::remove_all(options.out_dir);
  const auto results = runLeaveOneOut(options).value();
  ASSERT_EQ(results.size(), 2u);
  EXPECT_FALSE(results[0].camera_kept);
  // Its images go to a folder a shell takes unquoted.
  EXPECT_TRUE(
      fs::exists(fs::path(options.out_dir) / "images" / "few-cameras_camera_kept" / "montage4d"));
  fs::remove_all(options.out_dir);
  EXPECT_EQ(results[1].name, "few-cameras (camera kept)");
  EXPECT_TRUE(results[1].camera_kept);
  const double left_out = results[0].modes.at("montage4d").psnr_db,
               kept = results[1].modes.at("montage4d").psnr_db;
  EXPECT_GT(kept, left_out + 3.0) << left_out << " / " << kept;
  const fs::path out = fs::temp_directory_path() / "holofuse_eval_kept_test";
  ASSERT_TRUE(writeQualityReports(options, results, out.string()).isOk());
  std::ifstream json_file(out / "quality.json");
  const auto json = nlohmann::json::parse(json_file);
  EXPECT_TRUE(json["scenes"]["few-cameras (camera kept)"].value("camera_kept", false));
  EXPECT_FALSE(json["scenes"]["few-cameras"].value("camera_kept", false));
  std::ifstream md(out / "quality.md");
  const std::string text((std::istreambuf_iterator<char>(md)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("| few-cameras (camera kept) |"), std::string::npos);
  EXPECT_NE(text.find("outside the target's protocol"), std::string::npos);
  fs::remove_all(out);
}

TEST(LeaveOneOut, UnknownScenesListTheValidOnes) {
  EvalOptions options = tiny();
  options.scenes = {"sunny-beach"};
  {
    const auto refused = runLeaveOneOut(options);
    ASSERT_FALSE(refused.isOk()) << "an unknown scene must be refused";
    const std::string what = refused.isOk() ? "" : refused.status().message();
    EXPECT_NE(what.find("sunny-beach"), std::string::npos);
    EXPECT_NE(what.find("calibration-error"), std::string::npos);
  }
}

TEST(LeaveOneOut, VerdictNeedsHalfADecibelHigherSsimAndLessFlickerAfterAJump) {
  SceneResult scene;
  scene.name = "viewpoint-jump";
  scene.view_jump_degrees = 90;
  scene.modes["holoportation"] = {10.0, 30.0, 0.90, 4.0, 5.0, 10, 0, {}, 0, {}};
  scene.modes["montage4d"] = {9.0, 30.6, 0.91, 3.0, 5.0, 10, 0, {}, 0, {}};
  EXPECT_TRUE(montageVerdict(scene).met);
  scene.modes["montage4d"].flicker = 5.0;
  EXPECT_FALSE(montageVerdict(scene).met);
  EXPECT_NE(montageVerdict(scene).why.find("flicker"), std::string::npos);
  // Not measured (too few frames after the jump) is not less flicker.
  scene.modes["montage4d"].flicker = -1;
  EXPECT_FALSE(montageVerdict(scene).met);
  EXPECT_LT(montageVerdict(scene).flicker_ratio, 0.0);
  EXPECT_NE(montageVerdict(scene).why.find("not measured"), std::string::npos)
      << montageVerdict(scene).why;
  // Both steady is a tie, not less.
  scene.modes["montage4d"].flicker = 0;
  scene.modes["holoportation"].flicker = 0;
  EXPECT_FALSE(montageVerdict(scene).met);
  EXPECT_DOUBLE_EQ(montageVerdict(scene).flicker_ratio, 1.0);
  scene.view_jump_degrees = 0;  // no jump: flicker is not part of the target
  EXPECT_TRUE(montageVerdict(scene).met);
  scene.modes["montage4d"].psnr_db = 30.4;
  EXPECT_FALSE(montageVerdict(scene).met);
  EXPECT_NEAR(montageVerdict(scene).psnr_gain_db, 0.4, 1e-12);
}

}  // namespace
}  // namespace holofuse::eval
