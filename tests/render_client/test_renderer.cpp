// The Vulkan renderer (lavapipe in CI) against the synthetic truth: from a
// pod camera's own pose the blend must reproduce that camera's true image.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "codec/image_codec.h"
#include "render_client/client.h"
#include "render_client/renderer.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::render {
namespace {

struct Fixture {
  scene::SyntheticScene scene;
  std::vector<Camera> cameras = scene::SyntheticScene::cameraRig(4, 200, 150);
  std::vector<ViewImages> views;
  std::vector<scene::RenderedView> truth;
  Mesh mesh;
  explicit Fixture(uint64_t frame) {
    mesh = scene.truthMesh(frame, 0.012);
    for (const auto& cam : cameras) {
      truth.push_back(scene.render(cam, frame));
      views.push_back({cam, truth.back().color, truth.back().mask, featherMap(truth.back().mask)});
    }
  }
};

VulkanContext& context() {
  static VulkanContext ctx;
  return ctx;
}

// A frame in two submissions (Renderer::render in montage4d): the second,
// submitted behind the first while it may still run, sees both the first's
// results and what the host wrote between the two; waiting waits for both.
// Three rounds reuse the fences.
TEST(VulkanContext, ASubmissionBehindTheOneInFlightSeesItsResultsAndTheHostsWrites) {
  VulkanContext& ctx = context();
  constexpr VkDeviceSize kBytes = 1 << 16;
  const VkBufferUsageFlags usage =
      VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  Buffer device_side = ctx.createBuffer(kBytes, usage), host_side = ctx.createBuffer(kBytes, usage),
         both = ctx.createBuffer(2 * kBytes, usage);
  for (uint32_t round = 1; round <= 3; ++round) {
    SCOPED_TRACE(round);
    const uint32_t from_device = 0x01010101u * round, from_host = 0x10101010u * round;
    ctx.submit([&](VkCommandBuffer cmd) {
      vkCmdFillBuffer(cmd, device_side.buffer, 0, kBytes, from_device);
    });
    std::vector<uint32_t> words(kBytes / 4, from_host);
    std::memcpy(host_side.mapped, words.data(), kBytes);
    ctx.submitBehind([&](VkCommandBuffer cmd) {
      VkMemoryBarrier filled{};
      filled.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
      filled.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
      filled.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
      vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0,
                           1, &filled, 0, nullptr, 0, nullptr);
      const VkBufferCopy first{0, 0, kBytes}, second{0, kBytes, kBytes};
      vkCmdCopyBuffer(cmd, device_side.buffer, both.buffer, 1, &first);
      vkCmdCopyBuffer(cmd, host_side.buffer, both.buffer, 1, &second);
      transferWritesToHost(cmd);
    });
    ctx.waitForSubmitted();
    EXPECT_TRUE(ctx.submissionDone());
    std::vector<uint32_t> out(2 * kBytes / 4);
    std::memcpy(out.data(), both.mapped, 2 * kBytes);
    EXPECT_EQ(std::count(out.begin(), out.begin() + kBytes / 4, from_device),
              static_cast<long>(kBytes / 4));
    EXPECT_EQ(std::count(out.begin() + kBytes / 4, out.end(), from_host),
              static_cast<long>(kBytes / 4));
  }
  for (Buffer* b : {&device_side, &host_side, &both}) ctx.destroy(*b);
}

TEST(Renderer, PodViewReproducesTheTrueImageInsideTheSilhouette) {
  Fixture f(4);
  Renderer renderer(context(), 200, 150);
  renderer.setMesh(f.mesh);
  renderer.setViews(f.views);
  const Image8 out = renderer.render(f.cameras[1], BlendSettings{});
  size_t inter = 0, uni = 0, n = 0;
  double squared = 0;
  for (uint32_t y = 0; y < 150; ++y) {
    for (uint32_t x = 0; x < 200; ++x) {
      const bool covered = out.at(x, y)[3] != 0, truth = *f.truth[1].mask.at(x, y) != 0;
      inter += covered && truth;
      uni += covered || truth;
      if (!covered || !truth) continue;
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(out.at(x, y)[c]) - f.truth[1].color.at(x, y)[c];
        squared += d * d;
      }
      n += 3;
    }
  }
  const double iou = static_cast<double>(inter) / static_cast<double>(uni);
  const double psnr = 10 * std::log10(255.0 * 255.0 / (squared / static_cast<double>(n)));
  EXPECT_GT(iou, 0.95);
  EXPECT_GT(psnr, 24.0) << "blend of the true images from a pod's pose";
}

// The client warms its renderer before it takes frames (the JIT of a first
// frame on lavapipe). Nothing of the warm-up (its mesh, views, fields,
// temporal field) may show in the first real frame, pixel for pixel.
TEST(Renderer, AWarmedUpRendererDrawsItsFirstMeshAsAFreshOneDoes) {
  Fixture f(4);
  for (const BlendMode mode : {BlendMode::kNormal, BlendMode::kMontage4D}) {
    BlendSettings settings;
    settings.mode = mode;
    Renderer fresh(context(), 200, 150), warmed(context(), 200, 150);
    warmed.warmUp(settings);
    std::vector<Image8> pictures;
    for (Renderer* renderer : {&fresh, &warmed}) {
      renderer->setMesh(f.mesh);
      renderer->setViews(f.views);
      pictures.push_back(renderer->render(f.cameras[1], settings));
    }
    size_t covered = 0, differing = 0;
    for (size_t i = 0; i < pictures[0].pixels.size(); ++i) {
      covered += (i % 4 == 3) && pictures[0].pixels[i] != 0;
      differing += pictures[0].pixels[i] != pictures[1].pixels[i];
    }
    EXPECT_GT(covered, 3000u) << blendModeName(mode) << ": the subject is in view";
    EXPECT_EQ(differing, 0u) << blendModeName(mode);
  }
}

TEST(Renderer, OcclusionTestKeepsHiddenCamerasOut) {
  // Camera 2 sits opposite camera 0: with the occlusion test it cannot paint
  // camera 0's side, so leaving it out changes almost nothing.
  Fixture f(9);
  Renderer renderer(context(), 200, 150);
  renderer.setMesh(f.mesh);
  renderer.setViews(f.views);
  BlendSettings all;
  BlendSettings without_opposite;
  without_opposite.camera_enabled = {true, true, false, true};
  const Image8 a = renderer.render(f.cameras[0], all);
  const Image8 b = renderer.render(f.cameras[0], without_opposite);
  size_t differ = 0, covered = 0;
  for (size_t i = 0; i < a.pixels.size(); i += 4) {
    if (a.pixels[i + 3] == 0) continue;
    ++covered;
    differ += std::abs(a.pixels[i] - b.pixels[i]) > 8;
  }
  EXPECT_LT(static_cast<double>(differ) / static_cast<double>(covered), 0.02);
  EXPECT_EQ(renderer.depthMapPasses(), 1u) << "depth maps are per mesh, not per view";
}

TEST(Renderer, SurfaceNoCameraSeesGetsTheHoleColour) {
  Fixture f(2);
  Renderer renderer(context(), 120, 90);
  renderer.setMesh(f.mesh);
  renderer.setViews(f.views);
  BlendSettings none;
  none.camera_enabled = {false, false, false, false};
  none.hole_color = {1.0f, 0.0f, 1.0f};
  const Image8 out = renderer.render(f.cameras[0], none);
  size_t covered = 0;
  for (size_t i = 0; i < out.pixels.size(); i += 4) {
    if (out.pixels[i + 3] == 0) continue;
    ++covered;
    EXPECT_EQ(out.pixels[i], 255);
    EXPECT_EQ(out.pixels[i + 1], 0);
  }
  EXPECT_GT(covered, 500u);
}

TEST(Renderer, EmptyMeshGivesAnEmptyPictureAndMismatchedViewsAreRefused) {
  Fixture f(1);
  Renderer renderer(context(), 64, 48);
  renderer.setMesh(Mesh{});
  renderer.setViews(f.views);
  const Image8 out = renderer.render(f.cameras[0], BlendSettings{});
  for (size_t i = 3; i < out.pixels.size(); i += 4) ASSERT_EQ(out.pixels[i], 0);
  auto bad = f.views;
  bad[1].color = Image8(10, 10, 3);
  EXPECT_THROW(renderer.setViews(bad), std::invalid_argument);
}

// The viewpoint-jump scene's jump, as the live client makes it: before
// the jump frame the view is the pod's (or the orbit's), from it on the
// same view turned by 90 degrees around the ring, at the same distance
// from the subject, still looking at it.
// A bundle's image back into whole frames: a cropped rectangle with its
// feather map (protocol 1.2) is placed where it was cut, a bundle without
// one (a 1.1 server's) gives none, and a feather map of another size or
// format is refused naming the camera and both sizes.
TEST(ClientBundle, FeatherMapsArePlacedLikeTheColourAndAWrongOneIsRefused) {
  const Camera camera = scene::SyntheticScene::cameraRig(1, 40, 30)[0];
  const std::map<uint32_t, Camera> cameras = {{camera.id, camera}};
  Image8 color(12, 10, 3, 90), mask(12, 10, 1, 255), feather(12, 10, 1, 7);
  std::vector<std::vector<uint8_t>> storage(4);
  auto bundleOf = [&](const std::vector<std::pair<const Image8*, protocol::PlaneKind>>& planes) {
    protocol::TextureBundle bundle;
    protocol::BundleImage image;
    image.camera_id = camera.id;
    image.offset_x = 20;
    image.offset_y = 5;
    for (size_t k = 0; k < planes.size(); ++k) {
      image.planes.push_back(
          encodePlane(*planes[k].first, planes[k].second, protocol::Codec::kLz4, storage[k]));
    }
    bundle.images.push_back(std::move(image));
    return bundle;
  };
  using protocol::PlaneKind;
  auto views = viewsOfBundle(bundleOf({{&color, PlaneKind::kColor},
                                       {&mask, PlaneKind::kMask},
                                       {&feather, PlaneKind::kFeather}}),
                             cameras);
  ASSERT_TRUE(views.isOk()) << views.status().message();
  const Image8& placed = (*views)[0].feather;
  ASSERT_EQ(placed.width, 40u);
  ASSERT_EQ(placed.height, 30u);
  EXPECT_EQ(placed.at(20, 5)[0], 7);   // the rectangle's first pixel
  EXPECT_EQ(placed.at(31, 14)[0], 7);  // its last
  EXPECT_EQ(placed.at(19, 5)[0], 0);   // beside it: outside the silhouette
  EXPECT_EQ(placed.at(32, 14)[0], 0);

  auto old =
      viewsOfBundle(bundleOf({{&color, PlaneKind::kColor}, {&mask, PlaneKind::kMask}}), cameras);
  ASSERT_TRUE(old.isOk()) << old.status().message();
  EXPECT_TRUE((*old)[0].feather.empty())
      << "a 1.1 server's bundle: no feather map, the renderer feathers nothing";

  const Image8 whole_feather(40, 30, 1, 7), rgb_feather(12, 10, 3, 7);
  for (const Image8* wrong : {&whole_feather, &rgb_feather}) {
    auto refused = viewsOfBundle(
        bundleOf(
            {{&color, PlaneKind::kColor}, {&mask, PlaneKind::kMask}, {wrong, PlaneKind::kFeather}}),
        cameras);
    ASSERT_FALSE(refused.isOk());
    EXPECT_EQ(refused.status().code(), StatusCode::kMalformed);
    const std::string message = refused.status().message();
    EXPECT_NE(message.find("camera " + std::to_string(camera.id)), std::string::npos) << message;
    EXPECT_NE(message.find("feather map is " + std::to_string(wrong->width) + "x" +
                           std::to_string(wrong->height)),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("12x10"), std::string::npos) << message;
  }
}

TEST(UserCamera, AViewpointJumpTurnsTheViewAroundTheRingAtItsFrame) {
  std::map<uint32_t, Camera> pods;
  for (const auto& cam : scene::SyntheticScene::cameraRig(8, 64, 48)) pods[cam.id] = cam;
  Bounds bounds;
  bounds.min = glm::vec3(-0.3f, 0.0f, -0.3f);
  bounds.max = glm::vec3(0.3f, 1.8f, 0.3f);
  const glm::dvec3 centre(0.0, 0.9, 0.0);
  ClientOptions options;
  options.width = 64;
  options.height = 48;
  options.run.view = "pod:0";
  options.jump_degrees = 90;
  options.jump_at_frame = 5;
  const Camera before = *userCamera(options, pods, bounds, 4);
  const Camera after = *userCamera(options, pods, bounds, 5);
  EXPECT_EQ(before.center(), pods[0].center()) << "the pod's own pose until the jump";
  // The ring is horizontal: the turn keeps height and distance from the axis.
  const glm::dvec3 b = before.center() - centre, a = after.center() - centre;
  EXPECT_NEAR(a.y, b.y, 1e-9);
  EXPECT_NEAR(glm::length(glm::dvec2(a.x, a.z)), glm::length(glm::dvec2(b.x, b.z)), 1e-9);
  const double turn = std::acos(
      glm::dot(glm::normalize(glm::dvec2(a.x, a.z)), glm::normalize(glm::dvec2(b.x, b.z))));
  EXPECT_NEAR(turn * 180.0 / M_PI, 90.0, 1e-6);
  // Two pods along the ring of 8 is 90 degrees: the turned view sits where
  // one of them does and looks the way it looks.
  const bool at_pod = glm::length(after.center() - pods[2].center()) < 1e-6 ||
                      glm::length(after.center() - pods[6].center()) < 1e-6;
  EXPECT_TRUE(at_pod) << after.center().x << " " << after.center().z;
  EXPECT_GT(glm::dot(after.forward(), glm::normalize(centre - after.center())), 0.9);
  // Only the pose turns: the pod's intrinsics stay.
  EXPECT_EQ(after.fx, pods[0].fx);
  EXPECT_EQ(after.fy, pods[0].fy);
  EXPECT_EQ(after.cx, pods[0].cx);
  EXPECT_EQ(after.cy, pods[0].cy);
  // The orbit jumps too, by the same angle on top of its own motion.
  options.run.view = "orbit";
  options.orbit_degrees_per_frame = 2;
  auto turnBetween = [&](size_t a, size_t b) {
    const glm::dvec3 oa = userCamera(options, pods, bounds, a)->center() - centre;
    const glm::dvec3 ob = userCamera(options, pods, bounds, b)->center() - centre;
    return std::acos(glm::dot(glm::normalize(glm::dvec2(oa.x, oa.z)),
                              glm::normalize(glm::dvec2(ob.x, ob.z)))) *
           180.0 / M_PI;
  };
  EXPECT_NEAR(turnBetween(3, 4), 2.0, 1e-6) << "before the jump, the orbit's own step";
  EXPECT_NEAR(turnBetween(4, 5), 92.0, 1e-6) << "the step and the jump";
  EXPECT_NEAR(turnBetween(5, 6), 2.0, 1e-6) << "after it, the orbit goes on from there";
  options.jump_degrees = 0;
  EXPECT_NEAR(turnBetween(4, 5), 2.0, 1e-6);
}

}  // namespace
}  // namespace holofuse::render
