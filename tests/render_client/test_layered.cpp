// Mode layered (Volino and Hilton 2016, section 3.2): the Vulkan blend of
// texture layers against its CPU reference, what it shows against the
// camera images, and what it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "geometry/depth_raster.h"
#include "geometry/marching_cubes.h"
#include "render_client/reference/blend.h"
#include "render_client/renderer.h"
#include "texture/texture_atlas.h"
#include "texture/texture_layers.h"

namespace holofuse::render {
namespace {

VulkanContext& context() {
  static VulkanContext ctx;
  return ctx;
}

constexpr int kGrid = 41;

// A sphere on a lattice (the hull's kind of mesh, its vertex keys lattice
// edges), painted by position, seen by a ring of cameras.
struct PaintedSphere {
  Mesh mesh;
  std::vector<reference::PodView> views;
  explicit PaintedSphere(int cameras) {
    mesh = marchingCubes(sampleGrid(glm::dvec3(-0.6), 0.03, kGrid, kGrid, kGrid,
                                    [](const glm::dvec3& p) { return 0.5 - glm::length(p); }));
    for (int i = 0; i < cameras; ++i) {
      const double a = 2 * M_PI * i / cameras;
      reference::PodView view;
      view.camera = lookAtCamera(static_cast<uint32_t>(i), {3 * std::sin(a), 0.4, 3 * std::cos(a)},
                                 glm::dvec3(0.0), {0, 1, 0}, 128, 96, 40.0);
      const DepthMap depth = rasterizeDepth(mesh, view.camera);
      view.color = Image8(128, 96, 3, 0);
      view.mask = Image8(128, 96, 1, 0);
      for (size_t p = 0; p < depth.depth.size(); ++p) {
        if (depth.depth[p] == kNoDepth) continue;
        view.mask.pixels[p] = 255;
        const uint32_t x = static_cast<uint32_t>(p % 128), y = static_cast<uint32_t>(p / 128);
        const glm::dvec3 dir = view.camera.rayDirection(x + 0.5, y + 0.5);
        const glm::dvec3 hit =
            view.camera.center() + dir * (depth.depth[p] / glm::dot(dir, view.camera.forward()));
        // A little view dependence, so that the layers' weights matter.
        const double shade = 0.1 * std::cos(a);
        view.color.pixels[3 * p + 0] = static_cast<uint8_t>(128 + 100 * (hit.y + shade));
        view.color.pixels[3 * p + 1] = static_cast<uint8_t>(128 + 100 * hit.x);
        view.color.pixels[3 * p + 2] = static_cast<uint8_t>(128 + 100 * hit.z);
      }
      views.push_back(std::move(view));
    }
  }

  // The server's side: the atlas and L layers from the camera images.
  LayeredViews layered(int layers, uint32_t texels = 1024) {
    AtlasOptions options;
    options.texels = texels;
    options.lattice = glm::u64vec3(kGrid);
    TextureAtlas atlas(options);
    auto cells = atlas.layOut(mesh);
    EXPECT_TRUE(cells.isOk()) << cells.status().toString();
    std::vector<LayerView> sources;
    for (const auto& v : views) sources.push_back({&v.camera, &v.color, &v.mask, nullptr});
    LayerOptions layer_options;
    layer_options.layers = layers;
    auto built = buildTextureLayers(mesh, atlas.texels(), sources, layer_options);
    EXPECT_TRUE(built.isOk()) << built.status().toString();
    LayeredViews out;
    out.layers = std::move(built->layers);
    for (const auto& v : views) out.camera_centers.push_back(v.camera.center());
    return out;
  }
};

Camera userCamera(double degrees) {
  const double a = degrees * M_PI / 180;
  return lookAtCamera(99, {3 * std::sin(a), 0.9, 3 * std::cos(a)}, glm::dvec3(0.0), {0, 1, 0}, 160,
                      120, 35.0);
}

struct Comparison {
  size_t both = 0;
  double coverage = 0, close_share = 0, mean = 0;
};

Comparison compare(const Image8& a, const Image8& b) {
  Comparison c;
  size_t agree = 0, close = 0;
  double difference = 0;
  for (size_t p = 0; p < a.pixels.size(); p += 4) {
    const bool x = a.pixels[p + 3] != 0, y = b.pixels[p + 3] != 0;
    agree += x == y;
    if (!x || !y) continue;
    ++c.both;
    int worst = 0;
    for (int k = 0; k < 3; ++k) {
      const int d = std::abs(static_cast<int>(a.pixels[p + k]) - static_cast<int>(b.pixels[p + k]));
      difference += d / 3.0;
      worst = std::max(worst, d);
    }
    close += worst <= 2;
  }
  c.coverage = static_cast<double>(agree) / (a.pixels.size() / 4);
  c.close_share = c.both ? static_cast<double>(close) / c.both : 0;
  c.mean = c.both ? difference / c.both : 0;
  return c;
}

// The layers' picture on the GPU is the reference's, and close to the
// picture the camera images give (the layers resample them onto the
// surface; the difference is the atlas's resampling).
TEST(LayeredBlend, TheVulkanBlendOfLayersMatchesItsReferenceAndTheCameraImages) {
  PaintedSphere scene(6);
  Renderer renderer(context(), 160, 120);
  const LayeredViews layers = scene.layered(3);
  renderer.setMesh(scene.mesh);
  renderer.setLayers(layers);
  BlendSettings settings;
  settings.mode = BlendMode::kLayered;
  for (const double degrees : {10.0, 95.0}) {
    const Camera user = userCamera(degrees);
    const Image8 gpu = renderer.render(user, settings);
    reference::BlendPaths paths;
    const Image8 cpu =
        reference::blendLayers(scene.mesh, layers, user, glm::dvec3(settings.hole_color), &paths);
    EXPECT_GT(paths.fields, 2000u) << "most pixels weighed by eq. 3";
    EXPECT_LT(paths.holes, paths.fields / 50) << "the ring sees nearly all the sphere";
    const Comparison c = compare(gpu, cpu);
    RecordProperty("layered_coverage_agreement", std::to_string(c.coverage));
    RecordProperty("layered_within_2_grey_levels", std::to_string(c.close_share));
    RecordProperty("layered_mean_difference", std::to_string(c.mean));
    EXPECT_GT(c.both, 2000u);
    EXPECT_GT(c.coverage, 0.995) << degrees;
    EXPECT_GT(c.close_share, 0.98) << degrees;
    EXPECT_LT(c.mean, 0.5) << degrees;

    // Against the camera images, blended as mode normal does.
    reference::BlendOptions options;
    const Image8 from_images = reference::blendView(scene.mesh, scene.views, {}, user, options);
    const Comparison images = compare(gpu, from_images);
    RecordProperty("layered_vs_images_mean_difference", std::to_string(images.mean));
    EXPECT_GT(images.coverage, 0.995) << degrees;
    EXPECT_LT(images.mean, 4.0) << degrees << ": grey levels from the images' picture";
  }
  // The picture never holds NaN's colour (0 or garbage): every covered
  // pixel is the sphere's paint, well inside 0..255.
  const Image8 picture = renderer.render(userCamera(200), settings);
  size_t covered = 0;
  for (size_t p = 0; p < picture.pixels.size(); p += 4) {
    if (picture.pixels[p + 3] == 0) continue;
    ++covered;
    EXPECT_GT(picture.pixels[p + 1], 10) << "pixel " << p / 4;
  }
  EXPECT_GT(covered, 2000u);
}

// More layers than cameras leave the deeper layers empty and change
// nothing; layers without any camera give the hole colour; no layers, no
// coordinates, or a camera past the list are refused by name.
TEST(LayeredBlend, ExtremesGiveDefinedPicturesAndBadLayersAreRefused) {
  PaintedSphere scene(3);
  Renderer renderer(context(), 160, 120);
  BlendSettings settings;
  settings.mode = BlendMode::kLayered;
  settings.hole_color = glm::vec3(1.0f, 0.0f, 1.0f);
  const Camera user = userCamera(30);
  const LayeredViews three = scene.layered(3), eight = scene.layered(8);
  renderer.setMesh(scene.mesh);
  EXPECT_THROW(renderer.render(user, settings), std::invalid_argument) << "no layers yet";
  renderer.setLayers(three);
  const Image8 with_three = renderer.render(user, settings);
  renderer.setLayers(eight);
  const Image8 with_eight = renderer.render(user, settings);
  const Comparison same = compare(with_three, with_eight);
  EXPECT_EQ(same.coverage, 1.0);
  EXPECT_LT(same.mean, 0.01) << "layers 4 to 8 of three cameras are empty";

  LayeredViews unseen = three;
  for (Image8& layer : unseen.layers) {
    for (size_t i = 3; i < layer.pixels.size(); i += 4) layer.pixels[i] = kNoLayerCamera;
  }
  renderer.setLayers(unseen);
  const Image8 holes = renderer.render(user, settings);
  size_t covered = 0, magenta = 0;
  for (size_t p = 0; p < holes.pixels.size(); p += 4) {
    if (holes.pixels[p + 3] == 0) continue;
    ++covered;
    magenta += holes.pixels[p] == 255 && holes.pixels[p + 1] == 0 && holes.pixels[p + 2] == 255;
  }
  EXPECT_GT(covered, 1000u);
  EXPECT_EQ(magenta, covered) << "every covered pixel the hole colour";

  LayeredViews stranger = three;
  stranger.layers[0].pixels[3] = 7;  // three cameras: indices 0..2
  EXPECT_THROW(renderer.setLayers(stranger), std::invalid_argument);
  EXPECT_NE(checkLayeredViews(stranger).toString().find("camera index 7 of 3"), std::string::npos)
      << checkLayeredViews(stranger).toString();
  LayeredViews ragged = three;
  ragged.layers[1] = Image8(512, 512, 4, 0);
  EXPECT_NE(checkLayeredViews(ragged).toString().find("layer 1 is not RGBA 1024x1024"),
            std::string::npos);
  EXPECT_FALSE(checkLayeredViews(LayeredViews{}).isOk());

  Mesh bare = scene.mesh;
  bare.corner_uvs.clear();
  EXPECT_NE(checkLayerCoordinates(bare).toString().find("texture coordinates for"),
            std::string::npos);
  renderer.setLayers(three);
  renderer.setMesh(bare);
  EXPECT_THROW(renderer.render(user, settings), std::invalid_argument);
  Mesh outside = scene.mesh;
  outside.corner_uvs[5].x = 1.5f;
  EXPECT_NE(checkLayerCoordinates(outside).toString().find("outside [0,1]"), std::string::npos);
}

}  // namespace
}  // namespace holofuse::render
