// The synthetic scene, segmentation and feather maps.
#include <gtest/gtest.h>

#include "capture_node/pod.h"
#include "capture_node/scene_library.h"
#include "capture_node/segmentation.h"
#include "capture_node/synthetic_scene.h"
#include "common/image_codec.h"

namespace holofuse::capture {
namespace {

double maskIoU(const Image8& a, const Image8& b) {
  size_t inter = 0, uni = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    const bool x = a.pixels[i] != 0, y = b.pixels[i] != 0;
    inter += x && y;
    uni += x || y;
  }
  return uni ? static_cast<double>(inter) / static_cast<double>(uni) : 1.0;
}

TEST(SyntheticScene, IsDeterministicAndMoves) {
  const SyntheticScene scene;
  const auto cams = SyntheticScene::cameraRig(4, 160, 120);
  const auto a = scene.render(cams[0], 10), b = scene.render(cams[0], 10),
             c = scene.render(cams[0], 15);
  EXPECT_EQ(a.color.pixels, b.color.pixels);
  EXPECT_NE(a.mask.pixels, c.mask.pixels);
  size_t fg = 0;
  for (uint8_t m : a.mask.pixels) fg += m != 0;
  EXPECT_GT(fg, a.mask.pixels.size() / 20) << "the subject should fill a good part of the view";
  EXPECT_LT(fg, a.mask.pixels.size() / 2);
}

TEST(SyntheticScene, CamerasSeeDifferentGainsOfTheSameSurface) {
  const SyntheticScene scene;
  EXPECT_NE(scene.cameraGain(0), scene.cameraGain(1));
}

TEST(SyntheticScene, TruthMeshMatchesTheRenderedSilhouette) {
  const SyntheticScene scene;
  const Mesh mesh = scene.truthMesh(7, 0.02);
  ASSERT_GT(mesh.triangleCount(), 1000u);
  const auto cam = SyntheticScene::cameraRig(4, 160, 120)[1];
  const auto view = scene.render(cam, 7);
  size_t inside = 0;
  for (const auto& p : mesh.positions) {
    const auto px = cam.project(glm::dvec3(p));
    ASSERT_TRUE(px);
    const int x = static_cast<int>(px->x), y = static_cast<int>(px->y);
    if (x < 0 || y < 0 || x >= 160 || y >= 120) continue;
    // A surface vertex lies in the silhouette or within a pixel of it.
    bool near = false;
    for (int dy = -1; dy <= 1 && !near; ++dy) {
      for (int dx = -1; dx <= 1 && !near; ++dx) {
        const int u = std::clamp(x + dx, 0, 159), v = std::clamp(y + dy, 0, 119);
        near = *view.mask.at(u, v) != 0;
      }
    }
    inside += near;
  }
  EXPECT_GT(static_cast<double>(inside) / mesh.vertexCount(), 0.99);
}

// Every camera of the ring, the shaded back included: a stripe missing
// from one mask carves a tunnel through the hull.
TEST(Segmentation, RecoversTheTrueMaskFromTheBackgroundPlate) {
  const SyntheticScene scene;
  for (uint64_t frame : {3, 30}) {
    for (const auto& cam : SyntheticScene::cameraRig(8, 320, 240)) {
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

TEST(SyntheticScene, RingPosesAtThePodsAnglesAreThePods) {
  const auto rig = SyntheticScene::cameraRig(6, 160, 120);
  for (size_t i = 0; i < rig.size(); ++i) {
    const Camera pose = SyntheticScene::ringPose(60.0 * static_cast<double>(i), 99, 160, 120);
    EXPECT_NEAR(glm::length(pose.center() - rig[i].center()), 0.0, 1e-12) << i;
    EXPECT_NEAR(glm::dot(pose.forward(), rig[i].forward()), 1.0, 1e-12) << i;
    EXPECT_EQ(pose.id, 99u);
  }
  // Between pods 0 and 1: as far from both.
  const Camera between = SyntheticScene::ringPose(30.0, 0, 160, 120);
  EXPECT_NEAR(glm::length(between.center() - rig[0].center()),
              glm::length(between.center() - rig[1].center()), 1e-12);
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
  const SyntheticScene scene;
  const auto cam = SyntheticScene::cameraRig(4, 160, 120)[3];
  PodCapture capture = capturePodFrame(scene, cam, scene.backgroundPlate(cam), 42, 3);
  const auto outgoing = encodePodFrame(capture, 3, protocol::Codec::kLz4PlanarDelta);
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
  const SyntheticScene scene;
  const Camera cam = SyntheticScene::cameraRig(4, 160, 120)[1];
  PodCapture capture = capturePodFrame(scene, cam, scene.backgroundPlate(cam), 7, 1);
  const PixelRect rect = foregroundRect(capture.mask, 8);
  ASSERT_FALSE(rect.empty());
  const auto bytes = encodePodFrame(capture, 1, protocol::Codec::kLz4PlanarDelta, 8).flatten();
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
  const auto whole = encodePodFrame(capture, 1, protocol::Codec::kLz4PlanarDelta).flatten();
  EXPECT_LT(bytes.size(), whole.size());
}

TEST(SceneLibrary, NamesEveryScenarioAndRefusesUnknownOnes) {
  for (const char* name : {"clean", "calibration-error", "colour-imbalance", "fast-motion",
                           "viewpoint-jump", "few-cameras", "many-cameras"}) {
    ASSERT_NE(findScene(name), nullptr) << name;
    EXPECT_NE(sceneNames().find(name), std::string::npos);
  }
  EXPECT_EQ(findScene("cleanish"), nullptr);
  EXPECT_EQ(findScene("few-cameras")->cameras, 4);
  EXPECT_EQ(findScene("many-cameras")->cameras, 16);
  EXPECT_EQ(findScene("viewpoint-jump")->view_jump_degrees, 90.0);
}

TEST(SceneLibrary, ReportedCalibrationIsOffByExactlyTheStatedError) {
  const auto rig = SyntheticScene::cameraRig(8, 160, 120);
  for (const Camera& truth : rig) {
    const Camera reported = reportedCalibration(truth, 0.6, 0.008, 1);
    EXPECT_NEAR(glm::length(reported.center() - truth.center()), 0.008, 1e-9);
    // The angle of the relative rotation: trace = 1 + 2 cos(angle).
    const glm::dmat3 relative = reported.rotation * glm::transpose(truth.rotation);
    const double trace = relative[0][0] + relative[1][1] + relative[2][2];
    EXPECT_NEAR(glm::degrees(std::acos(std::clamp((trace - 1) / 2, -1.0, 1.0))), 0.6, 1e-6);
    EXPECT_EQ(reportedCalibration(truth, 0.0, 0.0, 1).rotation, truth.rotation);
  }
  // Deterministic, and different per camera.
  EXPECT_EQ(reportedCalibration(rig[2], 0.6, 0.008, 1).translation,
            reportedCalibration(rig[2], 0.6, 0.008, 1).translation);
  EXPECT_NE(reportedCalibration(rig[2], 0.6, 0.008, 1).center() - rig[2].center(),
            reportedCalibration(rig[3], 0.6, 0.008, 1).center() - rig[3].center());
}

TEST(SceneLibrary, ImbalanceAndSpecularChangeWhatCamerasSeeAndSpeedMovesTheClock) {
  const ScenePreset& clean = *findScene("clean");
  const ScenePreset& imbalance = *findScene("colour-imbalance");
  const SyntheticScene a(clean.scene), b(imbalance.scene);
  const glm::dvec3 deviation_a = a.cameraGain(3) - glm::dvec3(1.0),
                   deviation_b = b.cameraGain(3) - glm::dvec3(1.0);
  EXPECT_NEAR(glm::length(deviation_b), 3.0 * glm::length(deviation_a), 1e-12);
  // The highlight brightens some of the subject, never darkens it.
  const Camera cam = SyntheticScene::cameraRig(8, 160, 120)[0];
  SceneOptions shiny = clean.scene, matte = clean.scene;
  shiny.specular = 0.45;
  shiny.noise_amplitude = matte.noise_amplitude = 0.0;
  const auto lit = SyntheticScene(shiny).render(cam, 5),
             flat = SyntheticScene(matte).render(cam, 5);
  int brighter = 0;
  for (size_t i = 0; i < lit.color.pixels.size(); ++i) {
    ASSERT_GE(lit.color.pixels[i], flat.color.pixels[i]);
    brighter += lit.color.pixels[i] > flat.color.pixels[i] + 20;
  }
  EXPECT_GT(brighter, 20);
  const SyntheticScene fast(findScene("fast-motion")->scene);
  EXPECT_DOUBLE_EQ(fast.timeOf(10), 4.0 * a.timeOf(10));
}

}  // namespace
}  // namespace holofuse::capture
