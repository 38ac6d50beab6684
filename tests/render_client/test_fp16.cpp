// fp16 storage of positions and normals (paper 000's memory saving): the
// error it brings to the texture fields, measured on the synthetic subject
// against the same pipeline in full precision, stated as test properties
// and bounded.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/packing.hpp>

#include "capture_node/synthetic_scene.h"
#include "render_client/reference/texture_fields.h"
#include "render_client/reference/visibility.h"

namespace holofuse::render::reference {
namespace {

glm::vec3 throughHalf(const glm::vec3& v) {
  return glm::vec3(glm::unpackHalf1x16(glm::packHalf1x16(v.x)), glm::unpackHalf1x16(glm::packHalf1x16(v.y)),
                   glm::unpackHalf1x16(glm::packHalf1x16(v.z)));
}

TEST(Fp16Storage, PositionAndNormalRoundingChangesTheFieldsLittle) {
  const capture::SyntheticScene scene;
  const Mesh full = scene.truthMesh(6, 0.015);
  Mesh half = full;
  double position_error = 0, normal_error = 0;
  for (size_t v = 0; v < half.vertexCount(); ++v) {
    half.positions[v] = throughHalf(full.positions[v]);
    half.normals[v] = throughHalf(full.normals[v]);
    position_error = std::max(position_error, static_cast<double>(glm::length(half.positions[v] - full.positions[v])));
    normal_error = std::max(normal_error, static_cast<double>(glm::length(half.normals[v] - full.normals[v])));
  }
  std::vector<PodView> views;
  std::vector<Camera> cameras;
  for (const auto& cam : capture::SyntheticScene::cameraRig(4, 320, 240)) {
    const auto truth = scene.render(cam, 6);
    views.push_back({cam, truth.color, truth.mask});
    cameras.push_back(cam);
  }
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
  EXPECT_LT(static_cast<double>(flips) / pairs, 0.005) << "visibility changes only at its boundaries";
  EXPECT_LT(weight_error / pairs, 0.005);
}

}  // namespace
}  // namespace holofuse::render::reference
