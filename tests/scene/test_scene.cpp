// The synthetic scenes: deterministic truth, the pods' ring, the presets.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <glm/glm.hpp>
#include <string>

#include "scene/scene_library.h"
#include "scene/synthetic_scene.h"

namespace holofuse::scene {
namespace {

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

// The live pods' closed-form renderer against the reference tracer, on
// every scene of the library (the colour-imbalance one shines) at frames
// across its motion, from every camera of its ring: the same mask and the
// same colours up to where the tracer's stopping tolerance moves a point
// across a texture edge. Stated tolerance: the mask differs on at most
// 0.05% of pixels, at most 0.1% of colour channels differ by more than 2
// grey levels, the mean difference is under 0.1 grey levels (measured
// here, the worst case of each: 0.005%, 0.064%, 0.070, the last where a
// ray meets an elbow and the two take the neighbouring limb's texture).
// The next frame's picture is far outside it, so the bound can tell.
TEST(SyntheticScene, ThePodsClosedFormRendererGivesTheTracersPicture) {
  for (const ScenePreset& preset : sceneLibrary()) {
    const SyntheticScene scene(preset.scene);
    for (const Camera& camera : SyntheticScene::cameraRig(preset.cameras, 160, 120)) {
      const CameraRenderer renderer(scene, camera);
      for (uint64_t frame : {3u, 30u, 71u}) {
        const RenderedView truth = scene.render(camera, frame);
        auto differences = [&](const RenderedView& view) {
          size_t mask = 0, over_2 = 0;
          double sum = 0;
          for (size_t i = 0; i < truth.mask.pixels.size(); ++i)
            mask += truth.mask.pixels[i] != view.mask.pixels[i];
          for (size_t i = 0; i < truth.color.pixels.size(); ++i) {
            const int d = std::abs(int(truth.color.pixels[i]) - int(view.color.pixels[i]));
            over_2 += d > 2;
            sum += d;
          }
          return std::array<double, 3>{100.0 * mask / truth.mask.pixels.size(),
                                       100.0 * over_2 / truth.color.pixels.size(),
                                       sum / truth.color.pixels.size()};
        };
        const auto fast = differences(renderer.render(frame));
        const std::string where = preset.name + ", camera " + std::to_string(camera.id) +
                                  ", frame " + std::to_string(frame);
        EXPECT_LE(fast[0], 0.05) << where << ": mask % differing";
        EXPECT_LE(fast[1], 0.1) << where << ": % of channels off by more than 2";
        EXPECT_LT(fast[2], 0.1) << where << ": mean difference";
        if (camera.id == 0) {
          const auto next = differences(renderer.render(frame + 1));
          EXPECT_GT(next[1], 0.1) << where << ": the next frame should be outside the tolerance";
        }
      }
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

TEST(SceneLibrary, NamesEveryScenarioAndRefusesUnknownOnes) {
  for (const char* name : {"clean", "calibration-error", "colour-imbalance", "fast-motion",
                           "viewpoint-jump", "few-cameras", "many-cameras", "studio"}) {
    ASSERT_NE(findScene(name), nullptr) << name;
    EXPECT_NE(sceneNames().find(name), std::string::npos);
  }
  EXPECT_EQ(findScene("cleanish"), nullptr);
  EXPECT_EQ(findScene("few-cameras")->cameras, 4);
  EXPECT_EQ(findScene("many-cameras")->cameras, 16);
  EXPECT_EQ(findScene("viewpoint-jump")->view_jump_degrees, 90.0);
}

// The studio: the subject's shadow on the floor is darker than the plate
// there by the light's share (to 35%) with the same chromaticity, and it
// is not the subject; a stand some cameras see is in the plate too; the
// lights' gain changes from frame to frame within 12%, the whole picture
// with it.
TEST(SceneLibrary, TheStudioHasAShadowAStandAndLightsThatFlicker) {
  const ScenePreset* studio = findScene("studio");
  ASSERT_NE(studio, nullptr);
  const SyntheticScene scene(studio->scene), clean;
  const auto rig = SyntheticScene::cameraRig(studio->cameras, 160, 120);
  size_t shadow_pixels = 0, stand_cameras = 0;
  double gain_low = 2, gain_high = 0;
  for (uint64_t frame = 0; frame < 40; ++frame) {
    gain_low = std::min(gain_low, scene.lightGain(frame));
    gain_high = std::max(gain_high, scene.lightGain(frame));
  }
  EXPECT_GE(gain_low, 0.88);
  EXPECT_LE(gain_high, 1.12);
  EXPECT_GT(gain_high - gain_low, 0.15) << "the lights flicker";
  for (const Camera& camera : rig) {
    const Image8 plate = scene.backgroundPlate(camera);
    // The stand (behind the ring at 202.5 degrees) in view: its middle
    // projects into the picture, where the plate is the stand's dark grey.
    const auto middle = camera.project(glm::dvec3(-1.3, 0.45, -3.14));
    if (middle && middle->x >= 0 && middle->y >= 0 && middle->x < 160 && middle->y < 120) {
      const uint8_t* px =
          plate.at(static_cast<uint32_t>(middle->x), static_cast<uint32_t>(middle->y));
      EXPECT_LT(px[0] + px[1] + px[2], 3 * 80) << "camera " << camera.id << " sees the stand";
      ++stand_cameras;
    }
    const uint64_t frame = 12;
    const RenderedView view = scene.render(camera, frame);
    ASSERT_EQ(view.shadow.width, 160u);
    const double light = scene.lightGain(frame);
    for (size_t i = 0; i < view.shadow.pixels.size(); ++i) {
      if (!view.shadow.pixels[i]) continue;
      EXPECT_EQ(view.mask.pixels[i], 0) << "a shadow is not the subject";
      ++shadow_pixels;
      const uint8_t* seen = &view.color.pixels[3 * i];
      const uint8_t* empty = &plate.pixels[3 * i];
      double seen_sum = 0, empty_sum = 0;
      for (int k = 0; k < 3; ++k) seen_sum += seen[k], empty_sum += empty[k];
      EXPECT_NEAR(seen_sum / (light * empty_sum), 0.35 / (0.35 + 0.65 * 0.808), 0.08);
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(seen[k] / seen_sum, empty[k] / empty_sum, 0.05) << "same chromaticity";
    }
  }
  EXPECT_GT(shadow_pixels, 200u) << "the subject casts a shadow some cameras see";
  EXPECT_GE(stand_cameras, 2u);
  EXPECT_LT(stand_cameras, rig.size()) << "the stand is in view of some cameras, not all";
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
}  // namespace holofuse::scene
