// Relighting's CPU parts (paper 000, section 6.2): a light probe projected
// from an environment map, its light by direction, and eq. 8.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "image/image_io.h"
#include "render_client/light_probe.h"

namespace holofuse::render {
namespace {

namespace fs = std::filesystem;

// An equirectangular map of 64x32, each pixel's colour from its direction.
template <typename Colour>
ImageValues mapOf(Colour colour) {
  return equirectangularMap(64, 32, colour);
}

TEST(LightProbe, AGreyMapLightsEveryDirectionAlike) {
  const LightProbe probe = projectEquirectangular(mapOf([](glm::vec3) { return glm::vec3(0.5f); }));
  for (const glm::vec3 n : {glm::vec3(0, 1, 0), glm::vec3(0, -1, 0), glm::vec3(1, 0, 0),
                            glm::normalize(glm::vec3(1, -2, 3))}) {
    const glm::vec3 light = probeLight(probe, n);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(light[c], 0.5f, 1e-4f);
  }
}

// A sky: white above the horizon, black below. The band-limited light is
// bright looking up, dark looking down, half way on the horizon.
TEST(LightProbe, ASkyLightsFromAbove) {
  const LightProbe probe =
      projectEquirectangular(mapOf([](glm::vec3 d) { return glm::vec3(d.y > 0 ? 1.0f : 0.0f); }));
  EXPECT_GT(probeLight(probe, {0, 1, 0}).r, 0.85f);
  EXPECT_LT(probeLight(probe, {0, -1, 0}).r, 0.15f);
  EXPECT_NEAR(probeLight(probe, {1, 0, 0}).r, 0.5f, 0.02f);
  // A colour stays in its channel.
  const LightProbe red =
      projectEquirectangular(mapOf([](glm::vec3) { return glm::vec3(1, 0, 0); }));
  EXPECT_NEAR(probeLight(red, {0, 0, 1}).r, 1.0f, 1e-3f);
  EXPECT_NEAR(probeLight(red, {0, 0, 1}).g, 0.0f, 1e-3f);
}

// Eq. 8: 50% light leaves every 8-bit colour as it is; brighter light
// lightens, darker darkens; black and white stay.
TEST(LightProbe, Eq8LeavesColourUnderHalfLightAndLightensOrDarkensOtherwise) {
  for (int v = 0; v <= 255; ++v) {
    const float t = static_cast<float>(v) / 255.0f;
    EXPECT_EQ(std::lround(relightChannel(t, 0.5f) * 255.0f), v) << v;
    if (v > 0 && v < 255) {
      EXPECT_GT(relightChannel(t, 0.9f), t) << v;
      EXPECT_LT(relightChannel(t, 0.1f), t) << v;
    }
  }
  EXPECT_EQ(relightChannel(0.0f, 0.9f), 0.0f);
  EXPECT_EQ(relightChannel(1.0f, 0.1f), 1.0f);
}

// A probe file through OpenImageIO: a grey EXR reads as a neutral probe;
// a map of the wrong shape and a file that is no image are refused by name.
TEST(LightProbe, LoadsAnEnvironmentMapFileAndRefusesBadOnes) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_probe_" + std::to_string(getpid()));
  fs::create_directories(dir);
  Image8 grey(64, 32, 3);
  std::fill(grey.pixels.begin(), grey.pixels.end(), 128);
  ASSERT_TRUE(writeImage((dir / "grey.png").string(), grey).isOk());
  auto probe = loadLightProbe((dir / "grey.png").string());
  ASSERT_TRUE(probe.isOk()) << probe.status().toString();
  EXPECT_NEAR(probeLight(*probe, {0, 1, 0}).g, 128.0f / 255.0f, 1e-3f);
  Image8 square(32, 32, 3);
  ASSERT_TRUE(writeImage((dir / "square.png").string(), square).isOk());
  auto refused = loadLightProbe((dir / "square.png").string());
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("square.png: an equirectangular light probe"),
            std::string::npos)
      << refused.status().message();
  std::ofstream((dir / "junk.exr").string()) << "not an image";
  auto junk = loadLightProbe((dir / "junk.exr").string());
  ASSERT_FALSE(junk.isOk());
  EXPECT_NE(junk.status().message().find("junk.exr"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace holofuse::render
