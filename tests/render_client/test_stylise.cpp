// The stylisation passes over the final picture (paper 000, section 6) on
// Vulkan against their CPU reference.
#include <gtest/gtest.h>

#include <cstdlib>

#include "field_scenes.h"
#include "render_client/reference/stylise.h"
#include "render_client/renderer.h"

namespace holofuse::render {
namespace {

using test::context;
using test::syntheticScene;
using test::viewImages;

TEST(Stippling, RandomNumbersSpreadOverTheUnitInterval) {
  double sum = 0;
  int low = 0;
  for (uint32_t y = 0; y < 100; ++y) {
    for (uint32_t x = 0; x < 100; ++x) {
      const float u = reference::stippleRandom(x, y);
      ASSERT_GE(u, 0.0f);
      ASSERT_LT(u, 1.0f);
      sum += u;
      low += u < 0.1f;
    }
  }
  EXPECT_NEAR(sum / 10000, 0.5, 0.02);
  EXPECT_NEAR(low, 1000, 150);
}

// The Vulkan pass stipples the blend's own picture as the reference does:
// grey on the subject, the background untouched, equal but for rounding
// and a dot on a threshold.
TEST(Stippling, TheVulkanPassMatchesTheCpuReference) {
  const auto scene = syntheticScene(4, 160, 120, 4);
  Renderer renderer(context(), 160, 120);
  renderer.setMesh(scene.mesh);
  renderer.setViews(viewImages(scene));
  BlendSettings settings;
  renderer.render(scene.views[0].camera, settings);
  const Image8 plain = renderer.finishRender();
  settings.stylisation = Stylisation::kStipple;
  renderer.render(scene.views[0].camera, settings);
  const Image8 gpu = renderer.finishRender();
  const Image8 cpu = reference::stipple(plain);
  size_t subject = 0, close = 0, changed = 0;
  for (size_t p = 0; p < size_t{160} * 120; ++p) {
    const uint8_t* g = &gpu.pixels[4 * p];
    const uint8_t* c = &cpu.pixels[4 * p];
    if (plain.pixels[4 * p + 3] == 0) {
      for (int k = 0; k < 4; ++k) EXPECT_EQ(g[k], plain.pixels[4 * p + k]) << "background " << p;
      continue;
    }
    ++subject;
    EXPECT_EQ(g[0], g[1]);
    EXPECT_EQ(g[1], g[2]);
    EXPECT_EQ(g[3], plain.pixels[4 * p + 3]);
    close += std::abs(int{g[0]} - int{c[0]}) <= 1;
    changed += g[0] != plain.pixels[4 * p] || g[1] != plain.pixels[4 * p + 1];
  }
  ASSERT_GT(subject, 1000u);
  EXPECT_GT(static_cast<double>(close), 0.995 * static_cast<double>(subject));
  EXPECT_GT(static_cast<double>(changed), 0.9 * static_cast<double>(subject));
  // And back: without stylisation the picture is the blend's again.
  settings.stylisation = Stylisation::kNone;
  renderer.render(scene.views[0].camera, settings);
  EXPECT_TRUE(renderer.finishRender().pixels == plain.pixels);
}

}  // namespace
}  // namespace holofuse::render
