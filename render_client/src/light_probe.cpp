#include "render_client/light_probe.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace holofuse::render {

std::array<float, 9> shBasis(const glm::vec3& d) {
  // Green 2003's normalisation constants of the real basis.
  return {0.282095f,
          0.488603f * d.y,
          0.488603f * d.z,
          0.488603f * d.x,
          1.092548f * d.x * d.y,
          1.092548f * d.y * d.z,
          0.315392f * (3.0f * d.z * d.z - 1.0f),
          1.092548f * d.x * d.z,
          0.546274f * (d.x * d.x - d.y * d.y)};
}

glm::vec3 equirectangularDirection(uint32_t x, uint32_t y, uint32_t width, uint32_t height) {
  const double theta = std::numbers::pi * (y + 0.5) / height;  // from +y
  const double phi = 2.0 * std::numbers::pi * (x + 0.5) / width;
  return glm::vec3(static_cast<float>(std::sin(theta) * std::sin(phi)),
                   static_cast<float>(std::cos(theta)),
                   static_cast<float>(-std::sin(theta) * std::cos(phi)));
}

ImageValues equirectangularMap(uint32_t width, uint32_t height,
                               const std::function<glm::vec3(const glm::vec3&)>& colour) {
  ImageValues map;
  map.width = width;
  map.height = height;
  map.channels = 3;
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x) {
      const glm::vec3 c = colour(equirectangularDirection(x, y, width, height));
      map.values.insert(map.values.end(), {c.r, c.g, c.b});
    }
  }
  return map;
}

LightProbe projectEquirectangular(const ImageValues& map) {
  LightProbe probe;
  if (map.width == 0 || map.height == 0 || map.channels == 0) return probe;
  // Each pixel's colour times the basis integrated over its solid angle:
  // kSubRows bands of latitude per row, each weighed by its exact solid
  // angle (so the sphere sums to 4 pi and a constant map gives band 0);
  // across the columns the centres integrate bands 0 to 2 exactly.
  constexpr int kSubRows = 4;
  const uint32_t rows = map.height * kSubRows;
  std::array<glm::dvec3, 9> sum{};
  for (uint32_t y = 0; y < map.height; ++y) {
    std::array<std::vector<float>, 9> basis_sums;  // per column, the row's integral
    for (auto& b : basis_sums) b.assign(map.width, 0.0f);
    for (int s = 0; s < kSubRows; ++s) {
      const uint32_t row = y * kSubRows + static_cast<uint32_t>(s);
      const double weight =
          2.0 * std::numbers::pi / map.width *
          (std::cos(std::numbers::pi * row / rows) - std::cos(std::numbers::pi * (row + 1) / rows));
      for (uint32_t x = 0; x < map.width; ++x) {
        const auto basis = shBasis(equirectangularDirection(x, row, map.width, rows));
        for (size_t k = 0; k < basis.size(); ++k)
          basis_sums[k][x] += static_cast<float>(weight) * basis[k];
      }
    }
    for (uint32_t x = 0; x < map.width; ++x) {
      const float* v = &map.values[(static_cast<size_t>(y) * map.width + x) * map.channels];
      const glm::dvec3 colour = map.channels >= 3 ? glm::dvec3(v[0], v[1], v[2]) : glm::dvec3(v[0]);
      for (size_t k = 0; k < sum.size(); ++k)
        sum[k] += static_cast<double>(basis_sums[k][x]) * colour;
    }
  }
  for (size_t k = 0; k < sum.size(); ++k) probe.coefficients[k] = glm::vec3(sum[k]);
  return probe;
}

StatusOr<LightProbe> loadLightProbe(const std::string& path) {
  auto map = readImageValues(path);
  if (!map.isOk()) return map.status();
  if (map->width < 2 * map->height - 1 || map->width > 2 * map->height + 1) {
    return Status(StatusCode::kMalformed,
                  path + ": an equirectangular light probe is twice as wide as high, not " +
                      std::to_string(map->width) + "x" + std::to_string(map->height));
  }
  return projectEquirectangular(*map);
}

glm::vec3 probeLight(const LightProbe& probe, const glm::vec3& n) {
  const auto basis = shBasis(n);
  glm::vec3 light(0.0f);
  for (size_t k = 0; k < basis.size(); ++k) light += basis[k] * probe.coefficients[k];
  return glm::clamp(light, 0.0f, 1.0f);
}

float relightChannel(float t, float l) {
  const float lifted = t > 0.0f ? std::pow(t, 1.5f - l) : 0.0f;
  return std::clamp(t + std::abs(1.0f - 2.0f * l) * (lifted - t), 0.0f, 1.0f);
}

}  // namespace holofuse::render
