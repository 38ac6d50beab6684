// The scenes the texture-field tests run on (test_field_passes.cpp,
// test_montage_passes.cpp): the synthetic rig's truth, and a sphere with a
// ghost view; with the one Vulkan device they share.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "geometry/marching_cubes.h"
#include "render_client/reference/blend.h"
#include "render_client/renderer.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::render::test {

inline VulkanContext& context() {
  static VulkanContext ctx;
  return ctx;
}

struct Scene {
  std::string name;
  Mesh mesh;
  std::vector<reference::PodView> views;
};

inline Scene syntheticScene(int cameras, uint32_t w, uint32_t h, uint64_t frame) {
  const scene::SyntheticScene scene;
  Scene s{"synthetic " + std::to_string(cameras) + " cameras", scene.truthMesh(frame, 0.015), {}};
  for (const auto& cam : scene::SyntheticScene::cameraRig(cameras, w, h)) {
    const auto truth = scene.render(cam, frame);
    s.views.push_back({cam, truth.color, truth.mask, featherMap(truth.mask)});
  }
  return s;
}

inline std::vector<ViewImages> viewImages(const Scene& scene) {
  std::vector<ViewImages> views;
  for (const auto& v : scene.views) views.push_back({v.camera, v.color, v.mask, v.feather});
  return views;
}

// A sphere seen by 8 cameras, one of which sees a "ghost" (other colours).
inline Scene ghostSphere(double radius = 0.5) {
  Scene s{"sphere with a ghost view", {}, {}};
  s.mesh = marchingCubes(sampleGrid(glm::dvec3(-0.6), 0.03, 41, 41, 41,
                                    [&](const glm::dvec3& p) { return radius - glm::length(p); }));
  for (int i = 0; i < 8; ++i) {
    const double a = 2 * M_PI * i / 8;
    reference::PodView view;
    view.camera = lookAtCamera(static_cast<uint32_t>(i), {3 * std::sin(a), 0.3, 3 * std::cos(a)},
                               glm::dvec3(0.0), {0, 1, 0}, 128, 96, 40.0);
    const auto depth = reference::rasterizeDepth(s.mesh, view.camera);
    view.color = Image8(128, 96, 3, 0);
    view.mask = Image8(128, 96, 1, 0);
    for (size_t p = 0; p < depth.depth.size(); ++p) {
      if (depth.depth[p] == reference::kNoDepth) continue;
      view.mask.pixels[p] = 255;
      const uint32_t x = static_cast<uint32_t>(p % 128), y = static_cast<uint32_t>(p / 128);
      const glm::dvec3 dir = view.camera.rayDirection(x + 0.5, y + 0.5);
      const glm::dvec3 hit =
          view.camera.center() + dir * (depth.depth[p] / glm::dot(dir, view.camera.forward()));
      const bool ghost = i == 3;
      view.color.pixels[3 * p + 0] = ghost ? 30 : static_cast<uint8_t>(128 + 120 * hit.y);
      view.color.pixels[3 * p + 1] = ghost ? 220 : static_cast<uint8_t>(128 + 120 * hit.x);
      view.color.pixels[3 * p + 2] = ghost ? 40 : static_cast<uint8_t>(128 + 120 * hit.z);
    }
    s.views.push_back(std::move(view));
  }
  return s;
}

// The three scenes of the field-pass tests: 4 cameras at 160x120, 7 at
// 128x96 of which camera 3 sees none of the subject (the GPU skips its depth
// map, the reference does not; the results must agree), and a sphere seen
// by 8 cameras, one of them a ghost.

}  // namespace holofuse::render::test
