// The pod: segmentation, feather maps and the frames it sends.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

#include "capture_node/pod.h"
#include "common/image_codec.h"
#include "common/segmentation.h"
#include "metrics/image_metrics.h"
#include "scene/scene_library.h"
#include "scene/synthetic_scene.h"

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
  const scene::SyntheticScene scene(studio->scene);
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
