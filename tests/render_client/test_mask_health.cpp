// The client's mask health: each camera's IoU with the hull stays that
// camera's, also when a frame comes without one of them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "render_client/mask_health.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::render {
namespace {

// Each camera's true picture and mask of the scene at `frame`.
std::vector<ViewImages> viewsOf(const scene::SyntheticScene& scene,
                                const std::vector<Camera>& cameras, uint64_t frame) {
  std::vector<ViewImages> views;
  for (const auto& camera : cameras) {
    const auto truth = scene.render(camera, frame);
    views.push_back({camera, truth.color, truth.mask, featherMap(truth.mask)});
  }
  return views;
}

// A group the server sent without a late pod reaches the client without
// that camera's view: the sample must not shift the next camera's value
// into its column.
TEST(MaskHealth, EachValueStaysWithItsCameraWhenAFrameLacksOne) {
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(4, 64, 48);
  const Mesh mesh = scene.truthMesh(10, 0.02);
  std::vector<ViewImages> views = viewsOf(scene, cameras, 10);
  // Camera 2's mask holds nothing of the subject the others see.
  std::fill(views[2].mask.pixels.begin(), views[2].mask.pixels.end(), 0);
  MaskHealthSampler sampler(0);
  sampler.offer(10, 1, mesh, views);
  sampler.summary();  // the first sample measured before the second is offered
  sampler.offer(11, 2, mesh, {views[0], views[1], views[3]});
  std::vector<uint32_t> ids;
  const HealthOverTime health = sampler.summary(&ids);
  ASSERT_EQ(ids,
            (std::vector<uint32_t>{cameras[0].id, cameras[1].id, cameras[2].id, cameras[3].id}));
  ASSERT_EQ(health.frame_ids, (std::vector<uint64_t>{10, 11}));
  ASSERT_EQ(health.cameras.size(), 4u);
  EXPECT_LT(health.cameras[2].agreement[0], 0.05) << "an empty mask";
  EXPECT_EQ(health.cameras[2].agreement[1], -1.0) << "not in the frame: not measured";
  for (const size_t c : {0u, 1u, 3u}) {
    EXPECT_GT(health.cameras[c].agreement[0], 0.7) << c;
    EXPECT_GT(health.cameras[c].agreement[1], 0.7) << c << ": its own value, in its own column";
    EXPECT_TRUE(health.cameras[c].concern.empty()) << c << ": " << health.cameras[c].concern;
  }
  EXPECT_EQ(health.cameras[2].bad_frames, (std::vector<uint64_t>{10}));
  EXPECT_FALSE(health.cameras[2].concern.empty());
}

// A client may render for days: the samples stay bounded, spread over the
// whole run, and the interval doubles each time they are halved.
TEST(MaskHealth, ALongRunKeepsBoundedSamplesSpreadOverTheRun) {
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(2, 32, 24);
  const Mesh mesh = scene.truthMesh(0, 0.06);
  const std::vector<ViewImages> views = viewsOf(scene, cameras, 0);
  constexpr uint64_t kIntervalNs = 1000, kOffers = 1100;
  MaskHealthSampler sampler(kIntervalNs);
  for (uint64_t frame = 0; frame < kOffers; ++frame) {
    sampler.offer(frame, 1 + frame * kIntervalNs, mesh, views);
    sampler.summary();  // measured before the next is offered
  }
  const HealthOverTime health = sampler.summary();
  // 512 samples at every frame, halved; 256 more at every second, halved
  // again; then every fourth.
  EXPECT_EQ(sampler.intervalNs(), 4 * kIntervalNs);
  ASSERT_LT(health.frame_ids.size(), MaskHealthSampler::kSamplesKept);
  ASSERT_GT(health.frame_ids.size(), MaskHealthSampler::kSamplesKept / 2);
  EXPECT_EQ(health.frame_ids.front(), 0u);
  EXPECT_GE(health.frame_ids.back(), kOffers - 4) << "the latest frames are sampled too";
  for (size_t k = 1; k < health.frame_ids.size(); ++k) {
    const uint64_t gap = health.frame_ids[k] - health.frame_ids[k - 1];
    EXPECT_TRUE(gap >= 2 && gap <= 2 * 4)
        << "at most twice the last interval: frames " << health.frame_ids[k - 1] << " and "
        << health.frame_ids[k];
  }
  ASSERT_EQ(health.cameras.size(), 2u);
  EXPECT_EQ(health.cameras[0].agreement.size(), health.frame_ids.size());
}

}  // namespace
}  // namespace holofuse::render
