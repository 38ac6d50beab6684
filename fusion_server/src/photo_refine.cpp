#include "fusion_server/photo_refine.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "geometry/depth_raster.h"

namespace holofuse::fusion {
namespace {

// Bilinear RGB at pixel coordinates (centres at .5), clamped at the border.
glm::dvec3 sampleRgb(const Image8& image, double x, double y) {
  const double fx = x - 0.5, fy = y - 0.5;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  const int w = static_cast<int>(image.width), h = static_cast<int>(image.height);
  glm::dvec3 sum(0.0);
  for (int k = 0; k < 4; ++k) {
    const int dx = k & 1, dy = k >> 1;
    const int px = std::clamp(x0 + dx, 0, w - 1), py = std::clamp(y0 + dy, 0, h - 1);
    const double weight = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
    const uint8_t* p = image.at(static_cast<uint32_t>(px), static_cast<uint32_t>(py));
    sum += weight * glm::dvec3(p[0], p[1], p[2]);
  }
  return sum;
}

bool insideImage(const glm::dvec3& pixel, const Camera& camera) {
  return pixel.x >= 0 && pixel.y >= 0 && pixel.x < camera.width && pixel.y < camera.height;
}

uint8_t maskAt(const Image8& mask, const glm::dvec3& pixel) {
  return mask.pixels[static_cast<size_t>(pixel.y) * mask.width + static_cast<size_t>(pixel.x)];
}

// Every view has its colour image, and both it and its mask are whole
// images of its camera; says which camera is not.
void checkImages(const std::vector<hull::HullView>& views, const std::vector<Image8>& colors) {
  if (colors.size() != views.size())
    throw std::invalid_argument("photo refinement: one colour image per view");
  for (size_t i = 0; i < views.size(); ++i) {
    const Camera& c = views[i].camera;
    if (colors[i].width != c.width || colors[i].height != c.height || colors[i].channels < 3 ||
        views[i].mask.width != c.width || views[i].mask.height != c.height) {
      throw std::invalid_argument("photo refinement: camera " + std::to_string(c.id) +
                                  "'s colour and mask are not whole " + std::to_string(c.width) +
                                  "x" + std::to_string(c.height) + " images");
    }
  }
}

// Neighbouring vertices move together: each offset averaged with its
// neighbours' (one ring), passes times, so that single noisy picks do not
// dent the surface.
void smoothOffsets(const Mesh& hull, int passes, std::vector<double>& offset) {
  const size_t n = hull.vertexCount();
  std::vector<std::vector<uint32_t>> neighbours(n);
  for (size_t t = 0; t < hull.triangleCount(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = hull.indices[3 * t + k], b = hull.indices[3 * t + (k + 1) % 3];
      neighbours[a].push_back(b);
      neighbours[b].push_back(a);
    }
  }
  std::vector<double> smoothed(n);
  for (int pass = 0; pass < passes; ++pass) {
    for (size_t v = 0; v < n; ++v) {
      double sum = offset[v];
      for (uint32_t u : neighbours[v]) sum += offset[u];
      smoothed[v] = sum / static_cast<double>(1 + neighbours[v].size());
    }
    offset.swap(smoothed);
  }
}

PhotoRefineStats statsOf(const std::vector<double>& offset, const std::vector<char>& restored_once,
                         double step, int silhouette_rounds) {
  PhotoRefineStats stats;
  stats.silhouette_rounds = silhouette_rounds;
  double total = 0;
  for (const double moved : offset) {
    total += moved;
    if (moved > 0.5 * step) ++stats.vertices_moved;
  }
  stats.mean_offset = total / static_cast<double>(offset.size());
  stats.vertices_restored =
      static_cast<size_t>(std::count(restored_once.begin(), restored_once.end(), 1));
  return stats;
}

}  // namespace

Mesh refineByPhotoConsistency(const Mesh& hull, const std::vector<hull::HullView>& views,
                              const std::vector<Image8>& colors, const PhotoRefineOptions& options,
                              PhotoRefineStats* stats) {
  checkImages(views, colors);
  Mesh out = hull;
  if (stats) *stats = {};
  const size_t n = hull.vertexCount();
  const double max_depth = options.depth_voxels * options.voxel_size;
  if (!(max_depth > 0) || options.steps < 1 || n == 0 || views.size() < 2) return out;
  std::vector<DepthMap> depth;
  std::vector<std::vector<int32_t>> front_triangle(views.size());
  for (size_t i = 0; i < views.size(); ++i)
    depth.push_back(rasterizeDepth(hull, views[i].camera, 0.05, &front_triangle[i]));
  const double step = max_depth / options.steps;
  const double slack = step;  // a vertex lies within a step of the depth map's surface
  std::vector<double> offset(n, 0.0);
  std::vector<char> restored_once(n, 0);
  std::vector<std::pair<double, size_t>> facing;
  std::vector<glm::dvec3> colours;
  for (size_t v = 0; v < n; ++v) {
    const glm::dvec3 p(hull.positions[v]);
    glm::dvec3 normal(hull.normals[v]);
    const double length = glm::length(normal);
    if (!(length > 1e-12)) continue;
    normal /= length;
    // The cameras that see the vertex (in the image, in the mask, not
    // behind the hull's own depth map), best facing first.
    facing.clear();
    for (size_t i = 0; i < views.size(); ++i) {
      const auto q = views[i].camera.project(p);
      if (!q || !insideImage(*q, views[i].camera) || maskAt(views[i].mask, *q) == 0) continue;
      const size_t pixel = static_cast<size_t>(q->y) * depth[i].width + static_cast<size_t>(q->x);
      if (q->z > depth[i].depth[pixel] + slack) continue;
      const double cosine = glm::dot(normal, glm::normalize(views[i].camera.center() - p));
      if (cosine >= options.min_facing) facing.emplace_back(cosine, i);
    }
    if (facing.size() < 2) continue;
    const glm::dvec3 tangent = glm::normalize(
        glm::cross(normal, std::abs(normal.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
    const glm::dvec3 bitangent = glm::cross(normal, tangent);
    std::sort(facing.begin(), facing.end(),
              [](const auto& a, const auto& b) { return a.first > b.first; });
    facing.resize(std::min(facing.size(), static_cast<size_t>(std::max(options.views, 2))));
    // Colour variance among them at each depth inward; the least wins (the
    // hull's own surface on a tie).
    double best_cost = std::numeric_limits<double>::infinity(), surface_cost = 0;
    int best_step = 0;
    for (int s = 0; s <= options.steps; ++s) {
      const glm::dvec3 candidate = p - normal * (step * s);
      bool inside = true;
      colours.clear();
      for (size_t i = 0; i < views.size() && inside; ++i) {
        const auto q = views[i].camera.project(candidate);
        if (q && insideImage(*q, views[i].camera) && maskAt(views[i].mask, *q) == 0) inside = false;
      }
      if (!inside) break;  // past a silhouette: outside the hull
      // A 3x3 patch on the plane through the candidate, facing along the
      // normal, its points a pixel of the best camera apart: every camera
      // samples the same nine surface points (a plane sweep's patch), so
      // that one pixel's match by chance does not decide.
      const Camera& best = views[facing.front().second].camera;
      const double spacing = glm::length(candidate - best.center()) / best.fx;
      for (const auto& [cosine, i] : facing) {
        for (int j = 0; j < 9; ++j) {
          const glm::dvec3 point =
              candidate + spacing * (double(j % 3 - 1) * tangent + double(j / 3 - 1) * bitangent);
          const auto q = views[i].camera.project(point);
          if (!q || !insideImage(*q, views[i].camera)) break;
          colours.push_back(sampleRgb(colors[i], q->x, q->y));
        }
      }
      if (colours.size() != 9 * facing.size()) break;
      double cost = 0;
      for (int j = 0; j < 9; ++j) {
        glm::dvec3 mean(0.0);
        for (size_t k = 0; k < facing.size(); ++k)
          mean += colours[9 * k + j] / static_cast<double>(facing.size());
        for (size_t k = 0; k < facing.size(); ++k)
          cost += glm::dot(colours[9 * k + j] - mean, colours[9 * k + j] - mean);
      }
      if (s == 0) surface_cost = cost;
      if (cost < best_cost) {
        best_cost = cost;
        best_step = s;
      }
    }
    // Move only where the colours agree clearly better inside: the hull's
    // own surface wins unless a candidate halves its disagreement, and by
    // more than a grey level per sample (less is the images' rounding).
    const double samples = 9.0 * static_cast<double>(facing.size());
    const bool clearly = best_cost < 0.5 * surface_cost && surface_cost - best_cost > samples;
    offset[v] = clearly ? step * best_step : 0.0;
  }
  smoothOffsets(hull, options.smoothing_passes, offset);
  // Silhouette consistency: the refined surface must still cover every
  // pixel of every mask that the hull covered (a photo hull stays a subset
  // of the visual hull that explains the silhouettes; Kutulakos and Seitz
  // 2000). Where a mask pixel is left bare, the triangle the hull showed
  // there goes back, and the check runs again.
  const auto place = [&] {
    for (size_t v = 0; v < n; ++v) {
      const glm::dvec3 normal(hull.normals[v]);
      const double length = glm::length(normal);
      out.positions[v] =
          length > 1e-12 && offset[v] > 0
              ? glm::vec3(glm::dvec3(hull.positions[v]) - normal / length * offset[v])
              : hull.positions[v];
    }
  };
  place();
  size_t restored = 1;
  for (int round = 0; round < options.silhouette_rounds && restored > 0; ++round) {
    restored = 0;
    if (stats) stats->silhouette_rounds = round + 1;
    for (size_t i = 0; i < views.size(); ++i) {
      const DepthMap refined = rasterizeDepth(out, views[i].camera);
      for (size_t pixel = 0; pixel < refined.depth.size(); ++pixel) {
        if (views[i].mask.pixels[pixel] == 0 || refined.depth[pixel] != kNoDepth) continue;
        const int32_t t = front_triangle[i][pixel];
        if (t < 0) continue;
        for (int k = 0; k < 3; ++k) {
          const uint32_t v = hull.indices[3 * static_cast<size_t>(t) + k];
          if (offset[v] > 0 && !restored_once[v]) {
            restored_once[v] = 1;
            ++restored;
          }
          offset[v] = 0;
        }
      }
    }
    place();
  }
  // Still bare after the last round (rare): the hull itself, unrefined.
  if (restored > 0) {
    out = hull;
    std::fill(offset.begin(), offset.end(), 0.0);
  }
  if (stats) *stats = statsOf(offset, restored_once, step, stats->silhouette_rounds);
  computeVertexNormals(out);
  return out;
}

}  // namespace holofuse::fusion
