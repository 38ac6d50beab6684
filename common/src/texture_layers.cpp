#include "common/texture_layers.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "common/depth_raster.h"

namespace holofuse {

namespace {

struct Ranked {
  double score = 0.0;
  uint8_t view = kNoLayerCamera;
};

// Bilinear colour at pixel position (x, y), pixel centres at .5.
glm::dvec3 sampleColor(const Image8& image, double x, double y) {
  const double fx = std::clamp(x - 0.5, 0.0, image.width - 1.0);
  const double fy = std::clamp(y - 0.5, 0.0, image.height - 1.0);
  const uint32_t x0 = static_cast<uint32_t>(fx), y0 = static_cast<uint32_t>(fy);
  const uint32_t x1 = std::min(x0 + 1, image.width - 1), y1 = std::min(y0 + 1, image.height - 1);
  const double ax = fx - x0, ay = fy - y0;
  glm::dvec3 out(0.0);
  for (int c = 0; c < 3; ++c) {
    const double top = (1 - ax) * image.at(x0, y0)[c] + ax * image.at(x1, y0)[c];
    const double bottom = (1 - ax) * image.at(x0, y1)[c] + ax * image.at(x1, y1)[c];
    out[c] = (1 - ay) * top + ay * bottom;
  }
  return out;
}

// Barycentric coordinates of p in triangle abc, clamped onto the triangle:
// a border texel takes the colour of the nearest edge's point, as the
// paper's border triangles copy the edge's interpolants.
glm::dvec3 clampedBarycentric(const glm::dvec2& p, const std::array<glm::dvec2, 3>& t) {
  const glm::dvec2 e0 = t[1] - t[0], e1 = t[2] - t[0], d = p - t[0];
  const double det = e0.x * e1.y - e1.x * e0.y;
  if (std::abs(det) < 1e-12) return glm::dvec3(1.0 / 3.0);
  const double b1 = (d.x * e1.y - e1.x * d.y) / det;
  const double b2 = (e0.x * d.y - d.x * e0.y) / det;
  glm::dvec3 b(1.0 - b1 - b2, b1, b2);
  b = glm::max(b, glm::dvec3(0.0));
  const double sum = b.x + b.y + b.z;
  return sum > 0 ? b / sum : glm::dvec3(1.0 / 3.0);
}

Status checkInputs(const Mesh& mesh, const std::vector<AtlasCell>& cells, uint32_t texels,
                   uint32_t square_texels, const std::vector<LayerView>& views) {
  auto refuse = [](const std::string& what) {
    return Status(StatusCode::kMalformed, "texture layers: " + what);
  };
  if (views.size() >= kNoLayerCamera)
    return refuse(std::to_string(views.size()) + " views; a layer names at most 254");
  if (cells.size() != mesh.triangleCount())
    return refuse(std::to_string(cells.size()) + " atlas cells for " +
                  std::to_string(mesh.triangleCount()) + " triangles");
  if (mesh.normals.size() != mesh.vertexCount()) return refuse("the mesh has no vertex normals");
  if (mesh.corner_uvs.size() != mesh.indices.size())
    return refuse("the mesh has no texture coordinates (TextureAtlas::layOut)");
  if (texels == 0 || square_texels == 0 || square_texels > texels)
    return refuse("an atlas of " + std::to_string(texels) + " texels with squares of " +
                  std::to_string(square_texels));
  for (const AtlasCell& cell : cells) {
    if (uint64_t{cell.x} + square_texels > texels || uint64_t{cell.y} + square_texels > texels)
      return refuse("a square at " + std::to_string(cell.x) + "," + std::to_string(cell.y) +
                    " outside the atlas");
  }
  for (size_t i = 0; i < views.size(); ++i) {
    const LayerView& v = views[i];
    const std::string name = "view " + std::to_string(i);
    if (v.camera == nullptr || v.color == nullptr) return refuse(name + " has no camera or colour");
    if (v.color->width != v.camera->width || v.color->height != v.camera->height ||
        v.color->channels < 3 || v.color->empty())
      return refuse(name + ": colour image does not match its camera");
    for (const Image8* plane : {v.mask, v.feather}) {
      if (plane != nullptr && (plane->width != v.camera->width ||
                               plane->height != v.camera->height || plane->channels != 1))
        return refuse(name + ": mask or feather does not match its camera");
    }
  }
  return Status();
}

}  // namespace

StatusOr<TextureLayers> buildTextureLayers(const Mesh& mesh, const std::vector<AtlasCell>& cells,
                                           uint32_t texels, uint32_t square_texels,
                                           const std::vector<LayerView>& views,
                                           const LayerOptions& options) {
  if (Status bad = checkInputs(mesh, cells, texels, square_texels, views); !bad.isOk()) return bad;
  const int layer_count = std::max(options.layers, 1);
  TextureLayers out;
  out.texels = texels;
  for (int l = 0; l < layer_count; ++l) {
    Image8 layer(texels, texels, 4);
    for (size_t i = 0; i < layer.pixels.size(); i += 4) {
      layer.pixels[i] = options.hole.r;
      layer.pixels[i + 1] = options.hole.g;
      layer.pixels[i + 2] = options.hole.b;
      layer.pixels[i + 3] = kNoLayerCamera;
    }
    out.layers.push_back(std::move(layer));
  }
  if (mesh.triangleCount() == 0) return out;

  const double tolerance =
      options.depth_tolerance > 0 ? options.depth_tolerance : std::max(meanEdgeLength(mesh), 1e-6);
  std::vector<DepthMap> depths;
  depths.reserve(views.size());
  for (const LayerView& v : views) depths.push_back(rasterizeDepth(mesh, *v.camera));

  std::vector<Ranked> ranked;
  ranked.reserve(views.size());
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const AtlasCell& cell = cells[t];
    // The texels' points from the triangle's own coordinates (layOut put
    // its inner triangle's corners there, in a receiver's order too).
    std::array<glm::dvec2, 3> inner;
    for (int k = 0; k < 3; ++k) inner[k] = glm::dvec2(mesh.corner_uvs[3 * t + k]) * double(texels);
    const uint32_t* corner = &mesh.indices[3 * t];
    for (uint32_t y = cell.y; y < cell.y + square_texels; ++y) {
      for (uint32_t x = cell.x; x < cell.x + square_texels; ++x) {
        if (!texelInHalf(cell, square_texels, x, y)) continue;
        ++out.texels_covered;
        const glm::dvec3 b = clampedBarycentric(glm::dvec2(x + 0.5, y + 0.5), inner);
        glm::dvec3 point(0.0), normal(0.0);
        for (int k = 0; k < 3; ++k) {
          point += b[k] * glm::dvec3(mesh.positions[corner[k]]);
          normal += b[k] * glm::dvec3(mesh.normals[corner[k]]);
        }
        const double length = glm::length(normal);
        if (!(length > 0)) continue;
        normal /= length;
        ranked.clear();
        for (size_t j = 0; j < views.size(); ++j) {
          const LayerView& v = views[j];
          const auto pixel = v.camera->project(point);
          if (!pixel || !(pixel->x >= 0 && pixel->y >= 0 && pixel->x < v.camera->width &&
                          pixel->y < v.camera->height))
            continue;
          const uint32_t px = static_cast<uint32_t>(pixel->x), py = static_cast<uint32_t>(pixel->y);
          // Volino and Hilton eq. 1: the depth map sees this point.
          if (!(std::abs(depths[j].at(px, py) - pixel->z) <= tolerance)) continue;
          if (v.mask != nullptr && v.mask->at(px, py)[0] < 128) continue;
          // Eq. 2 as a cosine: the point faces the camera.
          const double facing = glm::dot(normal, glm::normalize(v.camera->center() - point));
          if (!(facing > 0)) continue;
          double feather = 1.0;
          if (v.feather != nullptr && options.feather_ramp_px > 0)
            feather = std::min(1.0, v.feather->at(px, py)[0] / options.feather_ramp_px);
          if (!(feather > 0)) continue;
          ranked.push_back({facing * feather, static_cast<uint8_t>(j)});
        }
        if (ranked.empty()) continue;
        ++out.texels_seen;
        const size_t keep = std::min<size_t>(ranked.size(), layer_count);
        std::partial_sort(ranked.begin(), ranked.begin() + keep, ranked.end(),
                          [](const Ranked& a, const Ranked& c) {
                            return a.score > c.score || (a.score == c.score && a.view < c.view);
                          });
        for (size_t l = 0; l < keep; ++l) {
          const LayerView& v = views[ranked[l].view];
          const auto pixel = v.camera->project(point);
          const glm::dvec3 colour = sampleColor(*v.color, pixel->x, pixel->y);
          uint8_t* texel = out.layers[l].at(x, y);
          for (int c = 0; c < 3; ++c)
            texel[c] = static_cast<uint8_t>(std::clamp(std::lround(colour[c]), 0L, 255L));
          texel[3] = ranked[l].view;
        }
      }
    }
  }
  return out;
}

Status checkLayeredViews(const LayeredViews& views) {
  auto refuse = [](const std::string& what) {
    return Status(StatusCode::kMalformed, "texture layers: " + what);
  };
  if (views.layers.empty() || views.layers.size() > kMaxRenderedLayers)
    return refuse(std::to_string(views.layers.size()) + " layers, not 1.." +
                  std::to_string(kMaxRenderedLayers));
  const Image8& first = views.layers.front();
  if (first.width == 0 || first.width != first.height || first.width > kMaxAtlasTexels)
    return refuse("a layer of " + std::to_string(first.width) + "x" + std::to_string(first.height) +
                  ", not a square of at most " + std::to_string(kMaxAtlasTexels));
  if (views.camera_centers.size() >= kNoLayerCamera)
    return refuse(std::to_string(views.camera_centers.size()) +
                  " cameras; a layer names at most 254");
  for (size_t l = 0; l < views.layers.size(); ++l) {
    const Image8& layer = views.layers[l];
    if (layer.width != first.width || layer.height != first.height || layer.channels != 4)
      return refuse("layer " + std::to_string(l) + " is not RGBA " + std::to_string(first.width) +
                    "x" + std::to_string(first.height));
    for (size_t i = 3; i < layer.pixels.size(); i += 4) {
      if (layer.pixels[i] != kNoLayerCamera && layer.pixels[i] >= views.camera_centers.size())
        return refuse("layer " + std::to_string(l) + " names camera index " +
                      std::to_string(layer.pixels[i]) + " of " +
                      std::to_string(views.camera_centers.size()));
    }
  }
  for (const glm::dvec3& centre : views.camera_centers) {
    if (!std::isfinite(centre.x) || !std::isfinite(centre.y) || !std::isfinite(centre.z))
      return refuse("a camera centre is not finite");
  }
  return Status();
}

Status checkLayerCoordinates(const Mesh& mesh) {
  auto refuse = [](const std::string& what) {
    return Status(StatusCode::kMalformed, "texture layers: " + what);
  };
  if (mesh.corner_uvs.size() != mesh.indices.size())
    return refuse("the mesh has " + std::to_string(mesh.corner_uvs.size()) +
                  " texture coordinates for " + std::to_string(mesh.indices.size()) + " corners");
  for (const glm::vec2& uv : mesh.corner_uvs) {
    if (!(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f))
      return refuse("a texture coordinate outside [0,1]");
  }
  return Status();
}

}  // namespace holofuse
