// fp16 storage of positions and normals (paper 000's memory saving): the
// error it brings to the texture fields, measured on the synthetic subject
// against the same pipeline in full precision, stated as test properties
// and bounded.
#include <gtest/gtest.h>

#include <cmath>

#include "render_client/reference/texture_fields.h"
#include "render_client/reference/visibility.h"
#include "render_client/renderer.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::render::reference {
namespace {

// The synthetic subject seen by a ring of `count` pods at frame 6, as
// views of type View ({camera, colour, mask}), and their cameras.
template <typename View>
std::pair<std::vector<View>, std::vector<Camera>> ring(const scene::SyntheticScene& scene,
                                                       int count, uint32_t width, uint32_t height) {
  std::pair<std::vector<View>, std::vector<Camera>> out;
  for (const auto& cam : scene::SyntheticScene::cameraRig(count, width, height)) {
    const auto truth = scene.render(cam, 6);
    out.first.push_back({cam, truth.color, truth.mask, featherMap(truth.mask)});
    out.second.push_back(cam);
  }
  return out;
}

TEST(Fp16Storage, PositionAndNormalRoundingChangesTheFieldsLittle) {
  const scene::SyntheticScene scene;
  const Mesh full = scene.truthMesh(6, 0.015);
  Mesh half = full;
  double position_error = 0, normal_error = 0;
  for (size_t v = 0; v < half.vertexCount(); ++v) {
    half.positions[v] = halfPrecision(full.positions[v]);
    half.normals[v] = halfPrecision(full.normals[v]);
    position_error = std::max(
        position_error, static_cast<double>(glm::length(half.positions[v] - full.positions[v])));
    normal_error =
        std::max(normal_error, static_cast<double>(glm::length(half.normals[v] - full.normals[v])));
  }
  const auto [views, cameras] = ring<PodView>(scene, 4, 320, 240);
  auto weightsOf = [&](const Mesh& mesh, std::vector<std::vector<uint8_t>>* visible_out) {
    const auto sights = vertexSights(mesh, views);
    const auto visible = finalVisibility(sights, majorityVote(mesh, views, sights));
    if (visible_out != nullptr) *visible_out = visible;
    const Field field = holoportationField(mesh, cameras, visible, 2.0);
    const Field ones(cameras.size(), std::vector<double>(mesh.vertexCount(), 1.0));
    return normalizeFields(field, ones, field);
  };
  std::vector<std::vector<uint8_t>> visible_full, visible_half;
  const auto w_full = weightsOf(full, &visible_full);
  const auto w_half = weightsOf(half, &visible_half);
  size_t flips = 0, pairs = 0;
  double weight_error = 0, worst = 0;
  for (size_t i = 0; i < cameras.size(); ++i) {
    for (size_t v = 0; v < full.vertexCount(); ++v) {
      ++pairs;
      flips += visible_full[i][v] != visible_half[i][v];
      const double e = std::abs(w_full.weight[i][v] - w_half.weight[i][v]);
      weight_error += e;
      worst = std::max(worst, e);
    }
  }
  RecordProperty("max_position_error_m", std::to_string(position_error));
  RecordProperty("max_normal_error", std::to_string(normal_error));
  RecordProperty("visibility_flips", std::to_string(static_cast<double>(flips) / pairs));
  RecordProperty("mean_weight_error", std::to_string(weight_error / pairs));
  RecordProperty("worst_weight_error", std::to_string(worst));
  // Half precision has an 11-bit significand: below 1 m a position moves at
  // most 2^-11 of its magnitude (0.5 mm at 1 m), a unit normal 2^-11.
  EXPECT_LT(position_error, 1.0e-3);
  EXPECT_LT(normal_error, 1.0e-3);
  EXPECT_LT(static_cast<double>(flips) / pairs, 0.005)
      << "visibility changes only at its boundaries";
  EXPECT_LT(weight_error / pairs, 0.005);
}

// The same storage on the GPU (Renderer::setHalfPrecisionVertices): every
// pass reads the halves, unpacked. So montage4d over two meshes (fields,
// temporal carry, blend) gives the same bits as full precision fed the
// rounded mesh, in half the vertex memory; against the unrounded mesh the
// picture changes by a fraction of a grey level, stated here.
TEST(Fp16Storage, HalfPrecisionVerticesOnTheGpuAreTheRoundedMeshBitForBit) {
  static VulkanContext context;
  const scene::SyntheticScene scene;
  const auto [views, cameras] = ring<ViewImages>(scene, 4, 160, 120);
  auto rounded = [](Mesh mesh) {
    for (size_t v = 0; v < mesh.vertexCount(); ++v) {
      mesh.positions[v] = halfPrecision(mesh.positions[v]);
      mesh.normals[v] = halfPrecision(mesh.normals[v]);
    }
    return mesh;
  };
  const std::vector<Mesh> meshes = {scene.truthMesh(6, 0.02), scene.truthMesh(7, 0.02)};
  Renderer half(context, 160, 120), full_rounded(context, 160, 120), full(context, 160, 120);
  half.setHalfPrecisionVertices(true);
  BlendSettings settings;
  settings.mode = BlendMode::kMontage4D;
  settings.fields.vote_delta = 0.15f;  // the vote's Lab search reads the halves too
  double difference = 0;
  size_t pixels = 0;
  for (size_t f = 0; f < meshes.size(); ++f) {
    half.setMesh(meshes[f]);
    full_rounded.setMesh(rounded(meshes[f]));
    full.setMesh(meshes[f]);
    for (Renderer* r : {&half, &full_rounded, &full}) r->setViews(views);
    const Image8 a = half.render(cameras[f], settings),
                 b = full_rounded.render(cameras[f], settings),
                 c = full.render(cameras[f], settings);
    EXPECT_EQ(a.pixels, b.pixels) << "mesh " << f;
    const FieldSnapshot fa = half.readFields(), fb = full_rounded.readFields();
    EXPECT_EQ(fa.sights, fb.sights) << "mesh " << f;
    EXPECT_EQ(fa.distances, fb.distances) << "mesh " << f;
    EXPECT_EQ(fa.weights, fb.weights) << "mesh " << f;
    EXPECT_EQ(2 * half.vertexBufferBytes(), full.vertexBufferBytes())
        << "half the vertex memory, mesh " << f;
    for (size_t p = 0; p < a.pixels.size(); p += 4) {
      for (size_t k = 0; k < 3; ++k) difference += std::abs(a.pixels[p + k] - c.pixels[p + k]);
      ++pixels;
    }
  }
  // A mesh past half precision's range is refused by name, and the previous
  // one stays: the same picture as before (holoportation: no temporal state).
  Mesh huge = meshes.back();
  for (auto& p : huge.positions) p *= 1e5f;
  BlendSettings baseline;
  baseline.mode = BlendMode::kHoloportation;
  const Image8 before = half.render(cameras[1], baseline);
  try {
    half.setMesh(huge);
    ADD_FAILURE() << "a mesh 100 km across was taken in half precision";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("half precision's range"), std::string::npos) << e.what();
  }
  EXPECT_EQ(half.render(cameras[1], baseline).pixels, before.pixels);
  const double mean = difference / (3.0 * static_cast<double>(pixels));
  RecordProperty("mean_pixel_difference_fp16_vs_fp32", std::to_string(mean));
  EXPECT_GT(mean, 0.0) << "half precision does round the synthetic subject's vertices";
  EXPECT_LT(mean, 0.5) << "grey levels per channel, over the whole picture";
}

}  // namespace
}  // namespace holofuse::render::reference
