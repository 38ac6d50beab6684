// The pod: segmentation, feather maps and the frames it sends.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

#include "capture_node/pod.h"
#include "codec/image_codec.h"
#include "hull/mask_agreement.h"
#include "metrics/image_metrics.h"
#include "scene/scene_library.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::capture {
namespace {

using metrics::maskIoU;

// Every camera of the ring, the shaded back included: a stripe missing
// from one mask carves a tunnel through the hull.
TEST(Segmentation, RecoversTheTrueMaskFromTheBackgroundPlate) {
  const scene::SyntheticScene scene;
  for (uint64_t frame : {3, 30}) {
    for (const auto& cam : scene::SyntheticScene::cameraRig(8, 320, 240)) {
      const auto view = scene.render(cam, frame);
      const Image8 mask = segmentForeground(view.color, scene.backgroundPlate(cam));
      size_t truth = 0, found = 0;
      for (size_t i = 0; i < mask.pixels.size(); ++i) {
        truth += view.mask.pixels[i] != 0;
        found += view.mask.pixels[i] != 0 && mask.pixels[i] != 0;
      }
      EXPECT_GT(maskIoU(mask, view.mask), 0.97) << "camera " << cam.id << ", frame " << frame;
      EXPECT_GT(static_cast<double>(found) / static_cast<double>(truth), 0.99)
          << "camera " << cam.id << ", frame " << frame << ": true foreground lost";
    }
  }
}

// The studio (a floor that takes the subject's shadow, a stand, lights
// that flicker 12% frame to frame, an empty plate): issue 44's targets,
// every camera's mask at IoU 0.97 or more against the truth, and at most
// 1% of the shadow's pixels taken for the subject. A plain difference from
// the plate, the segmenter before the model, fails both: the flicker moves
// every pixel and the shadow is as far from the plate as a subject.
TEST(Segmentation, TheStudiosShadowAndFlickerAreBackground) {
  const scene::ScenePreset* studio = scene::findScene("studio");
  ASSERT_NE(studio, nullptr);
  // The board set down after the plate is the rig's to reject (below).
  scene::SceneOptions options = studio->scene;
  options.late_prop = false;
  const scene::SyntheticScene scene(options);
  double worst_iou = 1, plain_worst_iou = 1;
  size_t shadow = 0, shadow_taken = 0, plain_shadow_taken = 0;
  for (const auto& cam : scene::SyntheticScene::cameraRig(studio->cameras, 320, 240)) {
    const BackgroundModel background(scene.backgroundPlate(cam));
    for (uint64_t frame : {3, 17, 30, 44}) {
      const auto view = scene.render(cam, frame);
      SegmentationStats stats;
      const Image8 mask = background.segment(view.color, &stats);
      EXPECT_NEAR(stats.gain, scene.lightGain(frame), 0.01) << "camera " << cam.id;
      worst_iou = std::min(worst_iou, maskIoU(mask, view.mask));
      // The plain difference: every channel's from the plate, summed.
      Image8 plain(320, 240, 1);
      const Image8 plate = scene.backgroundPlate(cam);
      for (size_t p = 0; p < plain.pixels.size(); ++p) {
        int sum = 0;
        for (int k = 0; k < 3; ++k)
          sum += std::abs(int(view.color.pixels[3 * p + k]) - int(plate.pixels[3 * p + k]));
        plain.pixels[p] = sum > 15 ? 255 : 0;
      }
      plain_worst_iou = std::min(plain_worst_iou, maskIoU(plain, view.mask));
      for (size_t i = 0; i < mask.pixels.size(); ++i) {
        if (!view.shadow.pixels[i]) continue;
        ++shadow;
        shadow_taken += mask.pixels[i] != 0;
        plain_shadow_taken += plain.pixels[i] != 0;
      }
    }
  }
  ASSERT_GT(shadow, 1000u);
  const double taken = static_cast<double>(shadow_taken) / static_cast<double>(shadow);
  const double plain_taken = static_cast<double>(plain_shadow_taken) / static_cast<double>(shadow);
  EXPECT_GE(worst_iou, 0.97) << "the plain difference's worst: " << plain_worst_iou;
  EXPECT_LE(taken, 0.01) << "the plain difference took " << plain_taken;
  EXPECT_LT(plain_worst_iou, 0.9) << "the studio should defeat a plain difference";
}

// The studio's checkerboard, set down after the plate, differs from the
// plate as much as the subject: each camera that sees it keeps it in its
// mask. It stands outside the capture volume, so no other camera's
// foreground meets its rays there, and the rig's agreement removes it,
// leaving every camera at IoU 0.97 or more; the subject's own pieces stay.
TEST(Segmentation, TheRigRejectsAPropSetDownAfterThePlate) {
  const scene::ScenePreset* studio = scene::findScene("studio");
  ASSERT_NE(studio, nullptr);
  ASSERT_TRUE(studio->scene.late_prop);
  const scene::SyntheticScene scene(studio->scene);
  const auto rig = scene::SyntheticScene::cameraRig(studio->cameras, 320, 240);
  hull::HullOptions options;  // the synthetic capture volume
  for (uint64_t frame : {5, 33}) {
    std::vector<hull::HullView> views;
    std::vector<scene::RenderedView> truth;
    for (const auto& cam : rig) {
      truth.push_back(scene.render(cam, frame));
      const Image8 mask = BackgroundModel(scene.backgroundPlate(cam)).segment(truth.back().color);
      views.push_back({cam, mask, featherMap(mask)});
    }
    const auto agreed = hull::agreeAcrossCameras(views, options);
    size_t fooled = 0, pieces_removed = 0;
    for (size_t c = 0; c < rig.size(); ++c) {
      const double before = maskIoU(views[c].mask, truth[c].mask);
      const double after = maskIoU(agreed[c].mask, truth[c].mask);
      fooled += before < 0.97;
      pieces_removed += agreed[c].pieces_removed;
      EXPECT_GE(after, 0.97) << "camera " << c << ", frame " << frame << " (alone " << before
                             << ")";
      EXPECT_GE(after, before - 0.002) << "camera " << c << ": agreement cut the subject";
    }
    EXPECT_GE(fooled, 2u) << "frame " << frame << ": the board should fool the cameras that see it";
    EXPECT_GE(pieces_removed, fooled);
  }
}

// Temporal consistency: with the frame before's mask, a pixel whose truth
// did not change flips between subject and background less often (the
// studio's flicker and a real sensor's noise move the pixels nearest the
// plate's colour across the line every frame), and the masks stay as
// close to the truth.
TEST(Segmentation, ThePreviousMaskHoldsTheSubjectsPixels) {
  scene::SceneOptions options = scene::findScene("studio")->scene;
  options.late_prop = false;
  // A real sensor's noise, more than a still plate's model expects: the
  // subject's pixels nearest the plate's colour cross the line at random.
  options.noise_amplitude = 12;
  const scene::SyntheticScene scene(options);
  size_t flips_alone = 0, flips_held = 0;
  double worst_alone = 1, worst_held = 1;
  for (const auto& cam : scene::SyntheticScene::cameraRig(4, 240, 180)) {
    const BackgroundModel background(scene.backgroundPlate(cam));
    Image8 alone_before, held_before, truth_before;
    for (uint64_t frame = 20; frame < 32; ++frame) {
      const auto view = scene.render(cam, frame);
      const Image8 alone = background.segment(view.color);
      const Image8 held =
          background.segment(view.color, nullptr, held_before.empty() ? nullptr : &held_before);
      worst_alone = std::min(worst_alone, maskIoU(alone, view.mask));
      worst_held = std::min(worst_held, maskIoU(held, view.mask));
      if (!truth_before.empty()) {
        for (size_t p = 0; p < alone.pixels.size(); ++p) {
          if (view.mask.pixels[p] != truth_before.pixels[p]) continue;
          flips_alone += alone.pixels[p] != alone_before.pixels[p];
          flips_held += held.pixels[p] != held_before.pixels[p];
        }
      }
      alone_before = alone;
      held_before = held;
      truth_before = view.mask;
    }
  }
  EXPECT_LT(static_cast<double>(flips_held), 0.5 * static_cast<double>(flips_alone))
      << flips_held << " flips held, " << flips_alone << " alone";
  EXPECT_GE(worst_held, worst_alone) << "the held masks' worst IoU";
}

// A rig whose calibrations are off (the calibration-error scene's): each
// camera's picture sits a few pixels from where the others' hull projects.
// Agreement moves the others' hull onto the mask first (and says by how
// much), so it cuts nothing of the subject.
TEST(Segmentation, TheRigsAgreementForgivesACalibrationsOffset) {
  const scene::ScenePreset* preset = scene::findScene("calibration-error");
  ASSERT_NE(preset, nullptr);
  const scene::SyntheticScene scene(preset->scene);
  std::vector<hull::HullView> views;
  std::vector<Image8> truth;
  for (const auto& cam : scene::SyntheticScene::cameraRig(preset->cameras, 320, 240)) {
    truth.push_back(scene.render(cam, 12).mask);
    const Camera reported =
        scene::reportedCalibration(cam, preset->calibration_error_degrees,
                                   preset->calibration_error_metres, preset->scene.seed);
    views.push_back({reported, truth.back(), featherMap(truth.back())});
  }
  const auto agreed = hull::agreeAcrossCameras(views, hull::HullOptions{});
  int moved = 0;
  for (size_t c = 0; c < views.size(); ++c) {
    EXPECT_GE(maskIoU(agreed[c].mask, truth[c]), 0.995) << "camera " << c;
    moved += agreed[c].shift != glm::ivec2(0, 0);
  }
  EXPECT_GE(moved, 1) << "the calibrations' offsets show as moves";
}

// Fewer than three cameras: no others' hull to judge by, masks unchanged.
TEST(Segmentation, TwoCamerasCannotOutvoteEachOther) {
  const scene::SyntheticScene scene;
  std::vector<hull::HullView> views;
  for (const auto& cam : scene::SyntheticScene::cameraRig(2, 160, 120)) {
    const auto view = scene.render(cam, 4);
    Image8 mask = view.mask;
    *mask.at(3, 3) = 255;  // a stray piece nobody can vouch for
    views.push_back({cam, mask, featherMap(mask)});
  }
  const auto agreed = hull::agreeAcrossCameras(views, hull::HullOptions{});
  for (size_t c = 0; c < views.size(); ++c) {
    EXPECT_EQ(agreed[c].mask.pixels, views[c].mask.pixels);
    EXPECT_EQ(agreed[c].pieces_removed, 0u);
  }
}

TEST(Feather, IsTheDistanceToTheSilhouetteBorder) {
  Image8 mask(41, 41, 1, 0);
  for (uint32_t y = 10; y <= 30; ++y) {
    for (uint32_t x = 10; x <= 30; ++x) *mask.at(x, y) = 255;
  }
  const Image8 feather = featherMap(mask);
  EXPECT_EQ(*feather.at(5, 5), 0);
  EXPECT_EQ(*feather.at(10, 20), 1);   // border pixel: one pixel from the background
  EXPECT_EQ(*feather.at(20, 20), 11);  // centre of a 21-pixel square
}

TEST(Pod, EncodedFrameCarriesStampsAndDecodablePlanes) {
  const scene::SyntheticScene scene;
  const auto cam = scene::SyntheticScene::cameraRig(4, 160, 120)[3];
  PodCapture capture = capturePodFrame(scene, cam, scene.backgroundPlate(cam), 42, 3);
  const auto outgoing = encodePodFrame(capture, 3, {protocol::Codec::kLz4PlanarDelta, kFullFrame});
  // The planes are borrowed, not copied: the frame is several parts.
  EXPECT_GT(outgoing.parts().size(), 1u);
  const auto bytes = outgoing.flatten();
  protocol::StreamDecoder decoder;
  decoder.feed(bytes);
  ASSERT_TRUE(decoder.hasFrame());
  const protocol::Frame wire = decoder.takeFrame();  // the decoded planes point into it
  protocol::PodFrame frame;
  ASSERT_TRUE(protocol::decodeFrame(wire, frame).isOk());
  EXPECT_EQ(frame.frame_id, 42u);
  ASSERT_EQ(frame.stamps.size(), 4u);
  for (const auto& s : frame.stamps) EXPECT_LE(s.start_ns, s.end_ns);
  ASSERT_EQ(frame.planes.size(), 3u);
  auto color = decodePlane(frame.planes[0]);
  ASSERT_TRUE(color.isOk());
  EXPECT_EQ(color->pixels, capture.view.color.pixels);
  EXPECT_LT(bytes.size(), capture.view.color.pixels.size())
      << "LZ4 with the delta filter must compress";
}

}  // namespace
}  // namespace holofuse::capture

namespace holofuse::capture {
namespace {

TEST(Pod, SendsOnlyTheForegroundRectangleWithItsOffset) {
  const scene::SyntheticScene scene;
  const Camera cam = scene::SyntheticScene::cameraRig(4, 160, 120)[1];
  PodCapture capture = capturePodFrame(scene, cam, scene.backgroundPlate(cam), 7, 1);
  const PixelRect rect = foregroundRect(capture.mask, 8);
  ASSERT_FALSE(rect.empty());
  const auto bytes = encodePodFrame(capture, 1, {protocol::Codec::kLz4PlanarDelta, 8}).flatten();
  protocol::StreamDecoder decoder;
  decoder.feed(bytes);
  ASSERT_TRUE(decoder.hasFrame());
  const protocol::Frame wire = decoder.takeFrame();
  protocol::PodFrame pod;
  ASSERT_TRUE(protocol::decodeFrame(wire, pod).isOk());
  EXPECT_EQ(pod.offset_x, rect.x);
  EXPECT_EQ(pod.offset_y, rect.y);
  for (const auto& plane : pod.planes) {
    EXPECT_EQ(plane.width, rect.width);
    EXPECT_EQ(plane.height, rect.height);
  }
  auto color = decodePlane(pod.planes[0]);
  ASSERT_TRUE(color.isOk());
  EXPECT_EQ(color->pixels, cropImage(capture.view.color, rect).pixels);
  // Smaller on the wire than the whole frame.
  const auto whole =
      encodePodFrame(capture, 1, {protocol::Codec::kLz4PlanarDelta, kFullFrame}).flatten();
  EXPECT_LT(bytes.size(), whole.size());
}

}  // namespace
}  // namespace holofuse::capture
