#include "eval/view_maps.h"

#include <array>
#include <optional>

namespace holofuse::eval {

FloatMap signedErrorMap(const Image8& rendered, const Image8& truth, const Image8& mask) {
  FloatMap map{{"error.R", "error.G", "error.B"}, std::vector<float>(mask.pixels.size() * 3, 0.0f)};
  if (rendered.width != mask.width || rendered.height != mask.height || rendered.channels < 3 ||
      truth.width != mask.width || truth.height != mask.height || truth.channels < 3)
    return map;
  for (size_t p = 0; p < mask.pixels.size(); ++p) {
    if (mask.pixels[p] == 0) continue;
    for (size_t c = 0; c < 3; ++c) {
      map.values[p * 3 + c] = (static_cast<float>(rendered.pixels[p * rendered.channels + c]) -
                               static_cast<float>(truth.pixels[p * truth.channels + c])) /
                              255.0f;
    }
  }
  return map;
}

namespace {

// Perspective-correct barycentrics of the pixel centre (x, y) in the
// triangle whose corners project to image points with camera depths z.
std::optional<std::array<double, 3>> barycentrics(const std::array<glm::dvec3, 3>& corner, double x,
                                                  double y) {
  const glm::dvec2 a(corner[0]), b(corner[1]), c(corner[2]), p(x, y);
  const double area = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
  if (std::abs(area) < 1e-12) return std::nullopt;
  std::array<double, 3> l = {((b.x - p.x) * (c.y - p.y) - (c.x - p.x) * (b.y - p.y)) / area,
                             ((c.x - p.x) * (a.y - p.y) - (a.x - p.x) * (c.y - p.y)) / area, 0.0};
  l[2] = 1.0 - l[0] - l[1];
  double sum = 0;
  for (int k = 0; k < 3; ++k) {
    l[k] /= corner[k].z;  // screen-space weights over depth, renormalised
    sum += l[k];
  }
  if (!(sum > 0)) return std::nullopt;
  for (double& v : l) v /= sum;
  return l;
}

}  // namespace

FloatMap viewWeightMap(const Mesh& mesh, const Camera& view,
                       const std::vector<int32_t>& triangle_of, const std::vector<float>& weights,
                       const std::vector<uint32_t>& camera_ids) {
  const size_t cameras = camera_ids.size(), pixels = triangle_of.size();
  FloatMap map;
  if (cameras == 0 || weights.size() != mesh.vertexCount() * cameras ||
      pixels != static_cast<size_t>(view.width) * view.height)
    return map;
  std::vector<float> dense(pixels * cameras, 0.0f);
  std::vector<uint8_t> weighs(cameras, 0);
  for (size_t p = 0; p < pixels; ++p) {
    if (triangle_of[p] < 0) continue;
    const size_t t = static_cast<size_t>(triangle_of[p]);
    std::array<glm::dvec3, 3> corner;
    std::array<uint32_t, 3> vertex;
    bool projected = true;
    for (int k = 0; k < 3; ++k) {
      vertex[k] = mesh.indices[t * 3 + k];
      const auto image = view.project(glm::dvec3(mesh.positions[vertex[k]]));
      if (!image) {
        projected = false;
        break;
      }
      corner[k] =
          glm::dvec3(image->x, image->y, view.toCamera(glm::dvec3(mesh.positions[vertex[k]])).z);
    }
    if (!projected) continue;
    const double x = static_cast<double>(p % view.width) + 0.5,
                 y = static_cast<double>(p / view.width) + 0.5;
    const auto l = barycentrics(corner, x, y);
    if (!l) continue;
    for (size_t c = 0; c < cameras; ++c) {
      double w = 0;
      for (int k = 0; k < 3; ++k) w += (*l)[k] * weights[vertex[k] * cameras + c];
      dense[p * cameras + c] = static_cast<float>(w);
      weighs[c] |= w > 0;
    }
  }
  std::vector<size_t> kept;
  for (size_t c = 0; c < cameras; ++c) {
    if (!weighs[c]) continue;
    kept.push_back(c);
    map.channels.push_back("weight.camera" + std::to_string(camera_ids[c]));
  }
  map.values.resize(pixels * kept.size());
  for (size_t p = 0; p < pixels; ++p) {
    for (size_t k = 0; k < kept.size(); ++k)
      map.values[p * kept.size() + k] = dense[p * cameras + kept[k]];
  }
  return map;
}

}  // namespace holofuse::eval
