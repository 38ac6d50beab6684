// What the renderer refuses, as errors a caller checks before it hands
// over data from outside: each names what is wrong, and what the renderer
// takes passes.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "render_client/renderer.h"
#include "shaders/config.h"

namespace holofuse::render {
namespace {

ViewImages view(uint32_t id, uint32_t w, uint32_t h) {
  ViewImages v;
  v.camera.id = id;
  v.camera.width = w;
  v.camera.height = h;
  v.color = Image8(w, h, 3);
  v.mask = Image8(w, h, 1);
  return v;
}

TEST(RenderChecks, ViewsOfOneSizeWithMatchingImagesPassAndOthersAreNamed) {
  std::vector<ViewImages> views = {view(0, 64, 48), view(1, 64, 48)};
  EXPECT_TRUE(checkViews(views).isOk());
  EXPECT_TRUE(checkViews({}).isOk()) << "no views: nothing to blend, nothing wrong";
  views[1].feather = Image8(64, 48, 1);
  EXPECT_TRUE(checkViews(views).isOk()) << "a feather map of the views' size";

  auto resized = views;
  resized[1] = view(7, 32, 24);
  const Status size = checkViews(resized);
  ASSERT_FALSE(size.isOk());
  EXPECT_NE(size.message().find("camera 7"), std::string::npos) << size.message();
  EXPECT_NE(size.message().find("64x48"), std::string::npos) << size.message();

  auto grey_colour = views;
  grey_colour[0].color = Image8(64, 48, 1);
  EXPECT_NE(checkViews(grey_colour).message().find("camera 0"), std::string::npos);

  auto bad_feather = views;
  bad_feather[1].feather = Image8(10, 10, 1);
  const Status feather = checkViews(bad_feather);
  ASSERT_FALSE(feather.isOk());
  EXPECT_NE(feather.message().find("feather"), std::string::npos) << feather.message();

  std::vector<ViewImages> many;
  for (uint32_t i = 0; i <= HOLOFUSE_MAX_CAMERAS; ++i) many.push_back(view(i, 8, 8));
  const Status too_many = checkViews(many);
  ASSERT_FALSE(too_many.isOk());
  EXPECT_NE(too_many.message().find(std::to_string(many.size()) + " cameras"), std::string::npos)
      << too_many.message();
}

TEST(RenderChecks, HalfPrecisionRefusesAVertexItCannotHold) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 2, 3}, {65504, -65504, 0}};
  EXPECT_TRUE(checkMesh(mesh, true).isOk()) << "65504 is a half's largest finite value";
  mesh.positions.push_back({0, 70000, 0});
  EXPECT_TRUE(checkMesh(mesh, false).isOk()) << "full precision holds it";
  const Status refused = checkMesh(mesh, true);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.message().find("vertex 3"), std::string::npos) << refused.message();
  mesh.positions.back() = {std::numeric_limits<float>::quiet_NaN(), 0, 0};
  EXPECT_FALSE(checkMesh(mesh, true).isOk()) << "not a number is in no range";
}

TEST(RenderChecks, Montage4dTakesItsRingsAndVertexLimitOtherModesDoNot) {
  BlendSettings settings;
  settings.mode = BlendMode::kMontage4D;
  EXPECT_TRUE(checkRenderable(1000, settings).isOk());
  settings.fields.geodesic_rings = kMaxGeodesicRings + 1;
  const Status rings = checkRenderable(1000, settings);
  ASSERT_FALSE(rings.isOk());
  EXPECT_NE(rings.message().find("geodesic rings"), std::string::npos) << rings.message();
  settings.fields.geodesic_rings = kMaxGeodesicRings;
  const Status vertices = checkRenderable(size_t{HOLOFUSE_MAX_FIELD_VERTICES} + 1, settings);
  ASSERT_FALSE(vertices.isOk());
  EXPECT_NE(vertices.message().find("vertices"), std::string::npos) << vertices.message();
  settings.mode = BlendMode::kNormal;
  settings.fields.geodesic_rings = kMaxGeodesicRings + 1;
  EXPECT_TRUE(checkRenderable(size_t{HOLOFUSE_MAX_FIELD_VERTICES} + 1, settings).isOk())
      << "normal has no geodesics";
}

}  // namespace
}  // namespace holofuse::render
