// The stylisation passes over the final picture (paper 000, section 6) on
// Vulkan against their CPU reference.
#include <gtest/gtest.h>

#include <cstdlib>

#include "field_scenes.h"
#include "render_client/light_probe.h"
#include "render_client/reference/stylise.h"
#include "render_client/renderer.h"

namespace holofuse::render {
namespace {

using test::context;
using test::ghostSphere;
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

// A probe from a 64x32 equirectangular map of one colour per direction.
template <typename Colour>
std::array<glm::vec3, 9> probeOf(Colour colour) {
  return projectEquirectangular(equirectangularMap(64, 32, colour)).coefficients;
}

class Relighting : public ::testing::Test {
 protected:
  Relighting() : scene_(ghostSphere()), renderer_(context(), 128, 96) {
    renderer_.setMesh(scene_.mesh);
    renderer_.setViews(viewImages(scene_));
  }
  Image8 render(bool relight, const std::array<glm::vec3, 9>& probe) {
    BlendSettings settings;
    settings.relight = relight;
    settings.light_probe = probe;
    renderer_.render(scene_.views[0].camera, settings);
    return renderer_.finishRender();
  }
  test::Scene scene_;
  Renderer renderer_;
};

// A 50% grey probe leaves the picture as it is, bit for bit (eq. 8's
// identity).
TEST_F(Relighting, AGreyProbeLeavesThePictureUnchanged) {
  const auto grey = probeOf([](glm::vec3) { return glm::vec3(0.5f); });
  const Image8 plain = render(false, grey);
  EXPECT_TRUE(render(true, grey).pixels == plain.pixels);
}

// One light in every direction: each channel of each pixel is eq. 8 of the
// plain picture's under that light, as the CPU computes it.
TEST_F(Relighting, AUniformProbeGivesEq8OfEveryPixel) {
  const glm::vec3 colour(0.8f, 0.3f, 0.55f);
  const auto probe = probeOf([&](glm::vec3) { return colour; });
  LightProbe cpu_probe;
  cpu_probe.coefficients = probe;
  const glm::vec3 light = probeLight(cpu_probe, {0, 0, 1});
  const Image8 plain = render(false, probe), relit = render(true, probe);
  size_t subject = 0, off = 0;
  for (size_t p = 0; p < size_t{128} * 96; ++p) {
    if (plain.pixels[4 * p + 3] == 0) continue;
    ++subject;
    for (int c = 0; c < 3; ++c) {
      const float t = static_cast<float>(plain.pixels[4 * p + c]) / 255.0f;
      const long expected = std::lround(relightChannel(t, light[c]) * 255.0f);
      off += std::abs(expected - long{relit.pixels[4 * p + c]}) > 1;
    }
  }
  ASSERT_GT(subject, 1000u);
  EXPECT_EQ(off, 0u) << "channels more than one level from the CPU's eq. 8";
  EXPECT_FALSE(relit.pixels == plain.pixels);
}

// Eqs. 6 and 7: under a sky (white above, black below) the top of the
// sphere, facing up in view space, lightens and its underside darkens.
TEST_F(Relighting, ASkyLightensTheTopAndDarkensTheUnderside) {
  const auto sky = probeOf([](glm::vec3 d) { return glm::vec3(d.y > 0 ? 1.0f : 0.0f); });
  const Image8 plain = render(false, sky), relit = render(true, sky);
  int top = 96, bottom = -1;
  for (int y = 0; y < 96; ++y) {
    for (int x = 0; x < 128; ++x) {
      if (plain.pixels[4 * (y * 128 + x) + 3] == 0) continue;
      top = std::min(top, y);
      bottom = std::max(bottom, y);
    }
  }
  ASSERT_LT(top, bottom);
  auto change = [&](int from, int to) {  // relit minus plain, mean over the rows' subject
    double sum = 0;
    size_t n = 0;
    for (int y = from; y < to; ++y) {
      for (int x = 0; x < 128; ++x) {
        const size_t p = static_cast<size_t>(y * 128 + x);
        if (plain.pixels[4 * p + 3] == 0) continue;
        for (int c = 0; c < 3; ++c)
          sum += int{relit.pixels[4 * p + c]} - int{plain.pixels[4 * p + c]};
        n += 3;
      }
    }
    return sum / static_cast<double>(std::max<size_t>(n, 1));
  };
  const int third = (bottom - top) / 3;
  EXPECT_GT(change(top, top + third), 5.0);
  EXPECT_LT(change(bottom - third, bottom + 1), -5.0);
}

}  // namespace
}  // namespace holofuse::render
