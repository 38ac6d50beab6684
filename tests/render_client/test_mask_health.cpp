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

// A group the server sent without a late pod reaches the client without
// that camera's view: the sample must not shift the next camera's value
// into its column.
TEST(MaskHealth, EachValueStaysWithItsCameraWhenAFrameLacksOne) {
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(4, 64, 48);
  const Mesh mesh = scene.truthMesh(10, 0.02);
  std::vector<ViewImages> views;
  for (const auto& camera : cameras) {
    const auto truth = scene.render(camera, 10);
    views.push_back({camera, truth.color, truth.mask, featherMap(truth.mask)});
  }
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

}  // namespace
}  // namespace holofuse::render
