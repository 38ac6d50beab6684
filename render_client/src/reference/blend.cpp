#include "render_client/reference/blend.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "geometry/depth_raster.h"
#include "render_client/reference/texture_fields.h"
#include "shaders/config.h"

namespace holofuse::render::reference {
namespace {

// Where the ray o + t d meets triangle (a, b, c): barycentrics of b and c
// (Moller-Trumbore), or false when it misses the triangle's plane.
bool rayBarycentrics(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a,
                     const glm::dvec3& b, const glm::dvec3& c, double& u, double& v) {
  const glm::dvec3 e1 = b - a, e2 = c - a, p = glm::cross(d, e2);
  const double det = glm::dot(e1, p);
  if (std::abs(det) < 1e-300) return false;
  const glm::dvec3 s = o - a, q = glm::cross(s, e1);
  u = glm::dot(s, p) / det;
  v = glm::dot(d, q) / det;
  return std::isfinite(u) && std::isfinite(v);
}

// Each pixel of the user's view the mesh covers, with its triangle's
// corners and the barycentrics of the pixel's ray on it (exact, so
// perspective-correct as a rasteriser's interpolation).
struct CoveredPixel {
  size_t pixel = 0;
  uint32_t ia = 0, ib = 0, ic = 0;
  double ba = 0, bu = 0, bv = 0;
  int32_t triangle = 0;
};
template <typename Visit>
void forEachCoveredPixel(const Mesh& mesh, const Camera& user, Visit visit) {
  std::vector<int32_t> triangle_of;
  (void)rasterizeDepth(mesh, user, 0.05, &triangle_of);
  for (uint32_t y = 0; y < user.height; ++y) {
    for (uint32_t x = 0; x < user.width; ++x) {
      CoveredPixel c;
      c.pixel = static_cast<size_t>(y) * user.width + x;
      c.triangle = triangle_of[c.pixel];
      if (c.triangle < 0) continue;
      const size_t t = static_cast<size_t>(c.triangle);
      c.ia = mesh.indices[3 * t];
      c.ib = mesh.indices[3 * t + 1];
      c.ic = mesh.indices[3 * t + 2];
      if (!rayBarycentrics(user.center(), user.rayDirection(x + 0.5, y + 0.5),
                           glm::dvec3(mesh.positions[c.ia]), glm::dvec3(mesh.positions[c.ib]),
                           glm::dvec3(mesh.positions[c.ic]), c.bu, c.bv)) {
        continue;
      }
      c.ba = 1.0 - c.bu - c.bv;
      visit(c);
    }
  }
}

// Colour in 0..1 into pixel of an RGBA picture, opaque.
void writeOpaque(Image8& out, size_t pixel, const glm::dvec3& colour) {
  for (int k = 0; k < 3; ++k) {
    out.pixels[4 * pixel + k] =
        static_cast<uint8_t>(std::lround(std::clamp(colour[k], 0.0, 1.0) * 255.0));
  }
  out.pixels[4 * pixel + 3] = 255;
}

// Where p lands in the pod's image as texture coordinates, with its depth
// along the pod's axis; false behind the pod or off the image.
bool textureCoordinates(const Camera& camera, const glm::dvec3& p, double& u, double& v,
                        double& depth) {
  const auto pixel = camera.project(p);
  if (!pixel || pixel->z <= 1e-6) return false;
  u = pixel->x / camera.width;
  v = pixel->y / camera.height;
  depth = pixel->z;
  return u >= 0.0 && u <= 1.0 && v >= 0.0 && v <= 1.0;
}

// Bilinear between texel centres, clamped at the border, as a GPU samples:
// fetch(i) gives texel i of a width x height image.
template <typename Fetch>
glm::dvec4 bilinear(uint32_t width, uint32_t height, double u, double v, Fetch fetch) {
  const int w = static_cast<int>(width), h = static_cast<int>(height);
  const double x = u * w - 0.5, y = v * h - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto texel = [&](int tx, int ty) {
    tx = std::clamp(tx, 0, w - 1);
    ty = std::clamp(ty, 0, h - 1);
    return fetch(static_cast<size_t>(ty) * w + tx);
  };
  return (texel(x0, y0) * (1 - fx) + texel(x0 + 1, y0) * fx) * (1 - fy) +
         (texel(x0, y0 + 1) * (1 - fx) + texel(x0 + 1, y0 + 1) * fx) * fy;
}

glm::dvec3 unitOrZero(const glm::dvec3& v) {
  const double l = glm::length(v);
  return l > 1e-30 && std::isfinite(l) ? v / l : glm::dvec3(0.0);
}

// The per-fragment blends past best_views cameras: the cameras each
// vertex's fragments weigh, as shaders/view_candidates.comp.glsl picks
// them: those that see the vertex first, then by the mode's weight
// without the per-fragment terms, the first best_views.
std::vector<std::vector<size_t>> viewCandidates(const Mesh& mesh, const std::vector<PodView>& views,
                                                const std::vector<DepthMap>& maps,
                                                const std::vector<bool>& takes_part,
                                                const Camera& user, const BlendOptions& options) {
  std::vector<std::vector<size_t>> out(mesh.vertexCount());
  const double alpha = std::max(options.alpha, 0.0), beta = std::max(options.beta, 0.0);
  std::vector<std::pair<double, size_t>> ranked;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    const glm::dvec3 p(mesh.positions[v]);
    const glm::dvec3 n = mesh.normals.size() == mesh.positions.size()
                             ? unitOrZero(glm::dvec3(mesh.normals[v]))
                             : glm::dvec3(0.0);
    const glm::dvec3 d_v = unitOrZero(user.center() - p);
    ranked.clear();
    for (size_t i = 0; i < views.size(); ++i) {
      if (!takes_part[i]) continue;
      const Camera& camera = views[i].camera;
      const glm::dvec3 d_k = unitOrZero(camera.center() - p);
      const double obliqueness = std::clamp(glm::dot(d_k, n), 0.0, 1.0);
      double score = obliqueness;
      if (options.fragment_mode && obliqueness > 0) {
        const double direction = std::clamp(0.5 * (glm::dot(d_k, d_v) + 1.0), 0.0, 1.0);
        const double log_w = alpha * std::log(obliqueness) +
                             (beta > 0 ? beta * std::log(std::max(direction, 1e-30)) : 0.0);
        score = std::exp(log_w / (1 + alpha + beta));
        if (!std::isfinite(score)) score = 0;
      }
      const auto pixel = camera.project(p);
      if (pixel && pixel->z > 0 && pixel->x >= 0 && pixel->y >= 0 && pixel->x < camera.width &&
          pixel->y < camera.height) {
        const uint32_t px = static_cast<uint32_t>(pixel->x), py = static_cast<uint32_t>(pixel->y);
        const bool seen = views[i].mask.pixels[size_t{py} * camera.width + px] != 0 &&
                          pixel->z <= maps[i].at(px, py) + options.depth_tolerance;
        if (seen) score += 2.0;
      }
      ranked.emplace_back(score, i);
    }
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    for (size_t k = 0; k < ranked.size() && k < static_cast<size_t>(options.best_views); ++k)
      out[v].push_back(ranked[k].second);
  }
  return out;
}

}  // namespace

glm::dvec4 sampleBilinear(const PodView& view, double u, double v) {
  // Colour weighted by the mask (premultiplied), then divided by the
  // coverage: the foreground's colours only.
  const glm::dvec4 sum = bilinear(view.color.width, view.color.height, u, v, [&](size_t i) {
    const double a = view.mask.pixels[i] / 255.0;
    return glm::dvec4(a * view.color.pixels[3 * i] / 255.0,
                      a * view.color.pixels[3 * i + 1] / 255.0,
                      a * view.color.pixels[3 * i + 2] / 255.0, a);
  });
  return sum.a > 1e-6 ? glm::dvec4(glm::dvec3(sum) / sum.a, sum.a)
                      : glm::dvec4(0.0, 0.0, 0.0, sum.a);
}

double sampleFeather(const PodView& view, double u, double v) {
  // Without a map, the GPU's stand-in: 255 over the mask (Renderer::setViews).
  const bool sent = !view.feather.pixels.empty();
  if (sent && (view.feather.width != view.mask.width || view.feather.height != view.mask.height ||
               view.feather.channels != 1)) {
    throw std::invalid_argument("reference blend: camera " + std::to_string(view.camera.id) +
                                "'s feather map is not one grey plane the size of its mask");
  }
  return bilinear(view.mask.width, view.mask.height, u, v,
                  [&](size_t i) {
                    return glm::dvec4(sent ? view.feather.pixels[i]
                                           : (view.mask.pixels[i] != 0 ? 255.0 : 0.0));
                  })
      .x;
}

double sightAndFeather(const PodView& view, double u, double v, double depth, double stored_depth,
                       double mask, const BlendOptions& options) {
  if (mask < 0.5) return 0.0;
  if (depth > stored_depth * (1.0 + options.relative_depth_tolerance) + options.depth_slack)
    return 0.0;
  if (!(options.feather_width_px > 0)) return 1.0;
  return std::clamp(sampleFeather(view, u, v) / options.feather_width_px, 0.0, 1.0);
}

Image8 blendView(const Mesh& mesh, const std::vector<PodView>& views,
                 const std::vector<std::vector<double>>& all_weights, const Camera& user,
                 const BlendOptions& options, BlendPaths* paths) {
  const std::vector<std::vector<double>> weights =
      options.best_views > 0 ? keepBestViews(all_weights, options.best_views) : all_weights;
  BlendPaths counted;
  auto enabled = [&](size_t i) {
    return options.camera_enabled.empty() || options.camera_enabled.at(i);
  };
  // Each pod's depth map, for the fallback's occlusion test; a pod whose
  // mask is empty takes no part in it.
  std::vector<DepthMap> maps;
  std::vector<bool> sees_subject;
  for (const auto& view : views) {
    maps.push_back(rasterizeDepth(mesh, view.camera));
    sees_subject.push_back(std::any_of(view.mask.pixels.begin(), view.mask.pixels.end(),
                                       [](uint8_t m) { return m != 0; }));
  }
  // The cameras the GPU's arrays hold: those that see the subject (all of
  // them when none does), and of them the enabled ones weigh.
  const bool any_sees =
      std::any_of(sees_subject.begin(), sees_subject.end(), [](bool b) { return b; });
  std::vector<bool> takes_part(views.size());
  size_t active = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    active += !any_sees || sees_subject[i];
    takes_part[i] = enabled(i) && sees_subject[i];
  }
  // Past best_views cameras the per-fragment blends (normal, fragment, the
  // field modes' fallback) weigh each corner's candidates only.
  const bool candidates =
      options.best_views > 0 && active > static_cast<size_t>(options.best_views);
  const std::vector<std::vector<size_t>> listed =
      candidates ? viewCandidates(mesh, views, maps, takes_part, user, options)
                 : std::vector<std::vector<size_t>>();
  std::vector<size_t> every(views.size()), order;
  for (size_t i = 0; i < views.size(); ++i) every[i] = i;
  Image8 out(user.width, user.height, 4, 0);
  forEachCoveredPixel(mesh, user, [&](const CoveredPixel& covered) {
    const size_t pixel = covered.pixel;
    const uint32_t ia = covered.ia, ib = covered.ib, ic = covered.ic;
    const double ba = covered.ba, bu = covered.bu, bv = covered.bv;
    // The cameras this pixel weighs: its corners' candidates, each once.
    order.clear();
    for (const uint32_t corner : {ia, ib, ic}) {
      for (size_t i : candidates ? listed[corner] : std::vector<size_t>()) {
        if (std::find(order.begin(), order.end(), i) == order.end()) order.push_back(i);
      }
    }
    const std::vector<size_t>& weighed = candidates ? order : every;
    auto interpolate = [&](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
      return ba * a + bu * b + bv * c;
    };
    const glm::dvec3 p = interpolate(glm::dvec3(mesh.positions[ia]), glm::dvec3(mesh.positions[ib]),
                                     glm::dvec3(mesh.positions[ic]));
    glm::dvec3 n(0.0);
    if (mesh.normals.size() == mesh.positions.size()) {
      n = interpolate(glm::dvec3(mesh.normals[ia]), glm::dvec3(mesh.normals[ib]),
                      glm::dvec3(mesh.normals[ic]));
      const double length = glm::length(n);
      n = length > 1e-12 && std::isfinite(length) ? n / length : glm::dvec3(0.0);
    }
    glm::dvec3 sum(0.0);
    double total = 0;
    // The pod's depth map where the point lands in its image.
    auto storedDepth = [&](size_t i, double u, double v) {
      const Camera& camera = views[i].camera;
      const uint32_t px = std::min(static_cast<uint32_t>(u * camera.width), camera.width - 1);
      const uint32_t py = std::min(static_cast<uint32_t>(v * camera.height), camera.height - 1);
      return maps[i].at(px, py);
    };
    if (options.fragment_mode) {
      // Paper 004 eqs. 2 to 4, summed in the log domain against the
      // largest weight (as the shader does), the view term over 2^beta.
      const double eye_distance = glm::length(user.center() - p);
      const glm::dvec3 d_v =
          eye_distance > 1e-20 ? (user.center() - p) / eye_distance : glm::dvec3(0.0);
      double largest = -std::numeric_limits<double>::infinity();
      for (size_t i : weighed) {
        double u = 0, v = 0, depth = 0;
        if (!enabled(i) || !sees_subject[i] || !textureCoordinates(views[i].camera, p, u, v, depth))
          continue;
        const glm::dvec4 texel = sampleBilinear(views[i], u, v);
        const double sight =
            sightAndFeather(views[i], u, v, depth, storedDepth(i, u, v), texel.a, options);
        const double camera_distance = glm::length(views[i].camera.center() - p);
        const glm::dvec3 d_k = camera_distance > 1e-20
                                   ? (views[i].camera.center() - p) / camera_distance
                                   : glm::dvec3(0.0);
        const double obliqueness = std::min(glm::dot(d_k, n), 1.0);
        const double direction = std::min(0.5 * (glm::dot(d_k, d_v) + 1.0), 1.0);
        if (!(sight > 0) || !(obliqueness > 0) || (!(direction > 0) && options.beta > 0)) continue;
        const double log_w = std::log(sight) + options.alpha * std::log(obliqueness) +
                             (options.beta > 0 ? options.beta * std::log(direction) : 0.0);
        if (!std::isfinite(log_w)) continue;
        if (log_w > largest) {
          const double rescale = std::exp(largest - log_w);
          sum *= rescale;
          total *= rescale;
          largest = log_w;
        }
        const double w = std::exp(log_w - largest);
        sum += w * glm::dvec3(texel);
        total += w;
      }
    }
    // The interpolated fields.
    for (size_t i = 0; i < weights.size() && !options.fragment_mode; ++i) {
      double w = ba * weights[i][ia] + bu * weights[i][ib] + bv * weights[i][ic];
      double u = 0, v = 0, depth = 0;
      if (!enabled(i) || !(w > 0) || !textureCoordinates(views[i].camera, p, u, v, depth)) continue;
      const glm::dvec4 texel = sampleBilinear(views[i], u, v);
      // Never the pod's background; with the per-fragment test, also not
      // behind its depth map, and feathered towards its silhouette's edge.
      w *= options.fragment_test
               ? sightAndFeather(views[i], u, v, depth, storedDepth(i, u, v), texel.a, options)
               : (texel.a < 0.5 ? 0.0 : 1.0);
      if (!(w > 0)) continue;
      sum += w * glm::dvec3(texel);
      total += w;
    }
    // Step 10: the normal-weighted blend, each pod tested against its
    // depth map at this point.
    const bool by_fields = total > 1e-8;
    if (!by_fields) {
      sum = glm::dvec3(0.0);
      total = 0;
      for (size_t i : weighed) {
        const Camera& camera = views[i].camera;
        double u = 0, v = 0, depth = 0;
        if (!enabled(i) || !sees_subject[i] || !textureCoordinates(camera, p, u, v, depth))
          continue;
        if (depth > storedDepth(i, u, v) + options.depth_tolerance)
          continue;  // occluded from pod i
        const glm::dvec4 texel = sampleBilinear(views[i], u, v);
        if (texel.a < 0.5) continue;
        const double c = glm::dot(n, glm::normalize(camera.center() - p));
        const double w = c > 0 ? std::pow(c, options.alpha) : 0.0;
        sum += w * glm::dvec3(texel);
        total += w;
      }
    }
    const glm::dvec3 colour = total > 1e-8 ? sum / total : options.hole_color;
    ++(by_fields ? counted.fields : total > 1e-8 ? counted.fallback : counted.holes);
    writeOpaque(out, pixel, colour);
  });
  if (paths != nullptr) *paths = counted;
  return out;
}

Image8 blendLayers(const Mesh& mesh, const LayeredViews& layers, const Camera& user,
                   const glm::dvec3& hole_color, BlendPaths* paths) {
  Status usable = checkLayeredViews(layers);
  if (usable.isOk()) usable = checkLayerCoordinates(mesh);
  if (!usable.isOk()) throw std::invalid_argument(usable.message());
  BlendPaths counted;
  const int texels = static_cast<int>(layers.layers.front().width);
  Image8 out(user.width, user.height, 4, 0);
  forEachCoveredPixel(mesh, user, [&](const CoveredPixel& covered) {
    const size_t pixel = covered.pixel, t = static_cast<size_t>(covered.triangle);
    const uint32_t ia = covered.ia, ib = covered.ib, ic = covered.ic;
    const double ba = covered.ba, bu = covered.bu, bv = covered.bv;
    const glm::dvec3 p = ba * glm::dvec3(mesh.positions[ia]) + bu * glm::dvec3(mesh.positions[ib]) +
                         bv * glm::dvec3(mesh.positions[ic]);
    glm::dvec3 n(0.0);
    if (mesh.normals.size() == mesh.positions.size()) {
      n = unitOrZero(ba * glm::dvec3(mesh.normals[ia]) + bu * glm::dvec3(mesh.normals[ib]) +
                     bv * glm::dvec3(mesh.normals[ic]));
    }
    const glm::dvec2 uv = ba * glm::dvec2(mesh.corner_uvs[3 * t]) +
                          bu * glm::dvec2(mesh.corner_uvs[3 * t + 1]) +
                          bv * glm::dvec2(mesh.corner_uvs[3 * t + 2]);
    const glm::dvec3 d_v = unitOrZero(user.center() - p);
    // The nearest texel names the layer's camera; the bilinear taps of
    // that camera give its colour.
    const int nx = std::clamp(static_cast<int>(std::floor(uv.x * texels)), 0, texels - 1);
    const int ny = std::clamp(static_cast<int>(std::floor(uv.y * texels)), 0, texels - 1);
    const double fx = uv.x * texels - 0.5, fy = uv.y * texels - 0.5;
    const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
    glm::dvec3 sum(0.0), first(0.0);
    double total = 0;
    bool any = false;
    for (const Image8& layer : layers.layers) {
      const uint8_t camera = layer.at(nx, ny)[3];
      if (camera == kNoLayerCamera) continue;
      glm::dvec3 colour(0.0);
      double weight = 0;
      for (int k = 0; k < 4; ++k) {
        const int tx = std::clamp(x0 + (k & 1), 0, texels - 1);
        const int ty = std::clamp(y0 + (k >> 1), 0, texels - 1);
        const uint8_t* texel = layer.at(tx, ty);
        if (texel[3] != camera) continue;
        const double w =
            ((k & 1) ? fx - x0 : 1.0 - (fx - x0)) * ((k >> 1) ? fy - y0 : 1.0 - (fy - y0));
        colour += w * glm::dvec3(texel[0], texel[1], texel[2]) / 255.0;
        weight += w;
      }
      if (!(weight > 1e-12)) continue;
      colour /= weight;
      if (!any) first = colour;
      any = true;
      // Eq. 3, raised to HOLOFUSE_LAYER_VIEW_POWER.
      const glm::dvec3 d_j = unitOrZero(layers.camera_centers[camera] - p);
      const double w =
          std::pow(std::max(glm::dot(d_j, n) * glm::dot(d_j, d_v), 0.0), HOLOFUSE_LAYER_VIEW_POWER);
      sum += w * colour;
      total += w;
    }
    // Eq. 4, normalised; the first layer where no weight is left.
    const glm::dvec3 colour = total > 1e-8 ? sum / total : any ? first : hole_color;
    ++(total > 1e-8 ? counted.fields : any ? counted.fallback : counted.holes);
    writeOpaque(out, pixel, colour);
  });
  if (paths != nullptr) *paths = counted;
  return out;
}

}  // namespace holofuse::render::reference
