#include "render_client/reference/texture_fields.h"

#include <algorithm>
#include <cmath>

namespace holofuse::render::reference {
namespace {

glm::dvec3 unitOrZero(const glm::dvec3& v) {
  const double len = glm::length(v);
  return (std::isfinite(len) && len > 0) ? v / len : glm::dvec3(0.0);
}

Field zeros(size_t cameras, size_t vertices) {
  return Field(cameras, std::vector<double>(vertices, 0.0));
}

}  // namespace

double clampedPower(double x, double alpha) {
  if (!(x > 0) || !std::isfinite(alpha)) return 0.0;
  const double value = std::pow(std::min(x, 1.0), std::max(alpha, 0.0));
  return std::isfinite(value) ? value : 0.0;
}

Field holoportationField(const Mesh& mesh, const std::vector<Camera>& cameras,
                         const std::vector<std::vector<uint8_t>>& visible, double alpha) {
  Field field = zeros(cameras.size(), mesh.vertexCount());
  for (size_t i = 0; i < cameras.size(); ++i) {
    const glm::dvec3 center = cameras[i].center();
    for (size_t v = 0; v < mesh.vertexCount(); ++v) {
      if (!visible[i][v]) continue;
      const glm::dvec3 p(mesh.positions[v]);
      const glm::dvec3 n = unitOrZero(glm::dvec3(mesh.normals[v]));
      field[i][v] = clampedPower(glm::dot(n, unitOrZero(center - p)), alpha);
    }
  }
  return field;
}

Field montageTargetField(const Mesh& mesh, const std::vector<Camera>& cameras,
                         const std::vector<std::vector<uint8_t>>& visible,
                         const std::vector<double>& global_visibility, const Field& geodesic,
                         const glm::dvec3& user_eye, double beta) {
  Field field = zeros(cameras.size(), mesh.vertexCount());
  for (size_t i = 0; i < cameras.size(); ++i) {
    const glm::dvec3 center = cameras[i].center();
    const double g = std::clamp(global_visibility[i], 0.0, 1.0);
    for (size_t v = 0; v < mesh.vertexCount(); ++v) {
      if (!visible[i][v]) continue;
      const glm::dvec3 p(mesh.positions[v]);
      const double gamma =
          std::isfinite(geodesic[i][v]) ? std::clamp(geodesic[i][v], 0.0, 1.0) : 0.0;
      field[i][v] = g * gamma *
                    clampedPower(glm::dot(unitOrZero(p - user_eye), unitOrZero(p - center)), beta);
    }
  }
  return field;
}

double temporalLambda(double lambda_reference, double dt_seconds, double reference_fps) {
  const double lambda = std::clamp(lambda_reference, 0.0, 1.0);
  if (lambda >= 1.0) return 1.0;
  if (!(dt_seconds > 0) || !std::isfinite(dt_seconds)) return 0.0;
  const double frames = dt_seconds * reference_fps;
  return std::clamp(1.0 - std::pow(1.0 - lambda, frames), 0.0, 1.0);
}

void temporalUpdate(Field& temporal, const Field& target, double lambda,
                    const std::vector<std::vector<uint8_t>>& visible) {
  const double l = std::clamp(std::isfinite(lambda) ? lambda : 0.0, 0.0, 1.0);
  for (size_t i = 0; i < temporal.size(); ++i) {
    for (size_t v = 0; v < temporal[i].size(); ++v) {
      const bool seen = visible.empty() || visible[i][v];
      temporal[i][v] = seen ? (1.0 - l) * temporal[i][v] + l * target[i][v] : 0.0;
    }
  }
}

BlendWeights normalizeFields(const Field& temporal, const Field& geodesic,
                             const Field& normal_weighted) {
  const size_t cameras = temporal.size();
  const size_t vertices = cameras ? temporal[0].size() : 0;
  BlendWeights out;
  out.weight = zeros(cameras, vertices);
  out.hole.assign(vertices, 0);
  out.fallback.assign(vertices, 0);
  for (size_t v = 0; v < vertices; ++v) {
    double gamma_sum = 0, field_sum = 0;
    for (size_t i = 0; i < cameras; ++i) {
      gamma_sum += geodesic[i][v];
      field_sum += temporal[i][v];
    }
    const Field* source = &temporal;
    double sum = field_sum;
    if (!(gamma_sum >= 1.0) || !(field_sum > 1e-12)) {
      source = &normal_weighted;
      sum = 0;
      for (size_t i = 0; i < cameras; ++i) sum += normal_weighted[i][v];
      out.fallback[v] = 1;
    }
    if (!(sum > 1e-12) || !std::isfinite(sum)) {
      out.hole[v] = 1;
      continue;
    }
    for (size_t i = 0; i < cameras; ++i) out.weight[i][v] = (*source)[i][v] / sum;
  }
  return out;
}

Field keepBestViews(const Field& weights, int count) {
  const size_t cameras = weights.size();
  const size_t vertices = cameras ? weights[0].size() : 0;
  const size_t keep = static_cast<size_t>(std::max(count, 1));
  Field out = zeros(cameras, vertices);
  std::vector<size_t> order;
  for (size_t v = 0; v < vertices; ++v) {
    order.clear();
    for (size_t i = 0; i < cameras; ++i) {
      if (weights[i][v] > 0) order.push_back(i);
    }
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return weights[a][v] > weights[b][v]; });
    const bool dropped = order.size() > keep;
    if (dropped) order.resize(keep);
    double kept = 0;
    for (size_t i : order) kept += weights[i][v];
    for (size_t i : order) out[i][v] = dropped ? weights[i][v] / kept : weights[i][v];
  }
  return out;
}

}  // namespace holofuse::render::reference
