#include "render_client/reference/visibility.h"

#include <algorithm>
#include <cmath>

namespace holofuse::render::reference {
namespace {

// The pyramid holds 8-bit RGB values as doubles, each level the 2x2 box
// average of the one below (what GPU mip generation of a UNORM image does);
// samples are converted to Lab after bilinear filtering.
using RgbImage = std::vector<glm::dvec3>;

struct Pyramid {
  std::vector<RgbImage> levels;
  std::vector<uint32_t> widths, heights;
};

Pyramid buildPyramid(const Image8& color, int levels) {
  Pyramid pyramid;
  RgbImage base(static_cast<size_t>(color.width) * color.height);
  for (uint32_t y = 0; y < color.height; ++y) {
    for (uint32_t x = 0; x < color.width; ++x) {
      const uint8_t* px = color.at(x, y);
      base[static_cast<size_t>(y) * color.width + x] = glm::dvec3(px[0], px[1], px[2]);
    }
  }
  pyramid.levels.push_back(std::move(base));
  pyramid.widths.push_back(color.width);
  pyramid.heights.push_back(color.height);
  for (int l = 1; l < levels; ++l) {
    const uint32_t pw = pyramid.widths.back(), ph = pyramid.heights.back();
    const uint32_t w = std::max(1u, pw / 2), h = std::max(1u, ph / 2);
    RgbImage next(static_cast<size_t>(w) * h);
    const RgbImage& prev = pyramid.levels.back();
    for (uint32_t y = 0; y < h; ++y) {
      for (uint32_t x = 0; x < w; ++x) {
        glm::dvec3 sum(0.0);
        for (uint32_t dy = 0; dy < 2; ++dy) {
          for (uint32_t dx = 0; dx < 2; ++dx) {
            const uint32_t u = std::min(2 * x + dx, pw - 1), v = std::min(2 * y + dy, ph - 1);
            sum += prev[static_cast<size_t>(v) * pw + u];
          }
        }
        next[static_cast<size_t>(y) * w + x] = sum / 4.0;
      }
    }
    pyramid.levels.push_back(std::move(next));
    pyramid.widths.push_back(w);
    pyramid.heights.push_back(h);
  }
  return pyramid;
}

glm::dvec3 labOf(const glm::dvec3& rgb);

// Lab of the bilinear sample at full-resolution pixel coordinates (u, v)
// on level l.
glm::dvec3 sampleLevel(const Pyramid& p, int l, double u, double v) {
  const double scale = std::ldexp(1.0, -l);
  const double x = std::clamp(u * scale - 0.5, 0.0, p.widths[l] - 1.0);
  const double y = std::clamp(v * scale - 0.5, 0.0, p.heights[l] - 1.0);
  const uint32_t x0 = static_cast<uint32_t>(x), y0 = static_cast<uint32_t>(y);
  const uint32_t x1 = std::min(x0 + 1, p.widths[l] - 1), y1 = std::min(y0 + 1, p.heights[l] - 1);
  const double fx = x - x0, fy = y - y0;
  const auto& img = p.levels[l];
  const uint32_t w = p.widths[l];
  const glm::dvec3 a = img[y0 * w + x0] * (1 - fx) + img[y0 * w + x1] * fx;
  const glm::dvec3 b = img[y1 * w + x0] * (1 - fx) + img[y1 * w + x1] * fx;
  return labOf(a * (1 - fy) + b * fy);
}

double linearize(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }
double labF(double t) {
  return t > 216.0 / 24389.0 ? std::cbrt(t) : (24389.0 / 27.0 * t + 16.0) / 116.0;
}

glm::dvec3 labOf(const glm::dvec3& rgb) {
  const double r = linearize(rgb.x / 255.0), g = linearize(rgb.y / 255.0),
               b = linearize(rgb.z / 255.0);
  // sRGB (D65) to XYZ, normalised by the D65 white.
  const double x = (0.4124564 * r + 0.3575761 * g + 0.1804375 * b) / 0.95047;
  const double y = (0.2126729 * r + 0.7151522 * g + 0.0721750 * b) / 1.0;
  const double z = (0.0193339 * r + 0.1191920 * g + 0.9503041 * b) / 1.08883;
  const double fx = labF(x), fy = labF(y), fz = labF(z);
  return glm::dvec3(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)) / 100.0;
}

}  // namespace

glm::dvec3 srgbToLab(const uint8_t* rgb) { return labOf(glm::dvec3(rgb[0], rgb[1], rgb[2])); }

std::vector<std::vector<Sight>> vertexSights(const Mesh& mesh, const std::vector<PodView>& views,
                                             const VisibilityOptions& options) {
  std::vector<std::vector<Sight>> sights(views.size(),
                                         std::vector<Sight>(mesh.vertexCount(), Sight::kBehind));
  for (size_t i = 0; i < views.size(); ++i) {
    const Camera& cam = views[i].camera;
    const DepthMap depth = rasterizeDepth(mesh, cam);
    const std::vector<uint8_t> edges = dilatedDiscontinuities(depth, options.discontinuity);
    for (size_t v = 0; v < mesh.vertexCount(); ++v) {
      const auto p = cam.project(glm::dvec3(mesh.positions[v]));
      Sight& s = sights[i][v];
      if (!p) {
        s = Sight::kBehind;
        continue;
      }
      if (!(p->x >= 0 && p->y >= 0 && p->x < cam.width && p->y < cam.height)) {
        s = Sight::kOutsideImage;
        continue;
      }
      const uint32_t x = static_cast<uint32_t>(p->x), y = static_cast<uint32_t>(p->y);
      const size_t pixel = static_cast<size_t>(y) * cam.width + x;
      if (views[i].mask.pixels[pixel] == 0) {
        s = Sight::kBackground;
      } else if (p->z > depth.depth[pixel] * (1.0 + options.relative_depth_tolerance)) {
        s = Sight::kOccluded;
      } else if (edges[pixel]) {
        s = Sight::kDiscontinuity;
      } else {
        s = Sight::kVisible;
      }
    }
  }
  return sights;
}

std::vector<std::vector<uint8_t>> majorityVote(const Mesh& mesh, const std::vector<PodView>& views,
                                               const std::vector<std::vector<Sight>>& sights,
                                               const VoteOptions& options) {
  const size_t n = views.size();
  const int levels = std::max(1, options.levels);
  std::vector<Pyramid> pyramids;
  for (const auto& view : views) pyramids.push_back(buildPyramid(view.color, levels));
  std::vector<std::vector<uint8_t>> trusted(n, std::vector<uint8_t>(mesh.vertexCount(), 0));
  std::vector<glm::dvec3> pixel(n);
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    std::vector<size_t> seen;
    for (size_t i = 0; i < n; ++i) {
      if (sights[i][v] != Sight::kVisible) continue;
      const auto p = views[i].camera.project(glm::dvec3(mesh.positions[v]));
      pixel[i] = glm::dvec3(p->x, p->y, 0.0);
      seen.push_back(i);
    }
    if (!(options.delta > 0)) {  // no vote
      for (size_t i : seen) trusted[i][v] = 1;
      continue;
    }
    const size_t x_count = seen.size();
    const size_t needed = x_count / 2;  // floor(X / 2)
    for (size_t i : seen) {
      for (int l = levels - 1; l >= 0 && !trusted[i][v]; --l) {
        const glm::dvec3 ci = sampleLevel(pyramids[i], l, pixel[i].x, pixel[i].y);
        size_t agree = 0;
        for (size_t j : seen) {
          if (j == i) continue;
          const glm::dvec3 cj = sampleLevel(pyramids[j], l, pixel[j].x, pixel[j].y);
          if (glm::length(ci - cj) < options.delta) ++agree;
        }
        if (agree >= needed) trusted[i][v] = 1;
      }
    }
  }
  return trusted;
}

std::vector<std::vector<uint8_t>> finalVisibility(
    const std::vector<std::vector<Sight>>& sights,
    const std::vector<std::vector<uint8_t>>& trusted) {
  std::vector<std::vector<uint8_t>> visible(sights.size());
  for (size_t i = 0; i < sights.size(); ++i) {
    visible[i].resize(sights[i].size());
    for (size_t v = 0; v < sights[i].size(); ++v) {
      visible[i][v] = sights[i][v] == Sight::kVisible && trusted[i][v];
    }
  }
  return visible;
}

std::vector<std::vector<uint8_t>> seamTriangles(const Mesh& mesh,
                                                const std::vector<std::vector<Sight>>& sights,
                                                const std::vector<std::vector<uint8_t>>& trusted) {
  std::vector<std::vector<uint8_t>> seams(sights.size(),
                                          std::vector<uint8_t>(mesh.triangleCount(), 0));
  for (size_t i = 0; i < sights.size(); ++i) {
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
      int in_view = 0, occluded = 0, seen = 0, seen_trusted = 0;
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = mesh.indices[3 * t + k];
        const Sight s = sights[i][v];
        const bool in = s == Sight::kVisible || s == Sight::kOccluded || s == Sight::kDiscontinuity;
        in_view += in;
        occluded += s == Sight::kOccluded || s == Sight::kDiscontinuity;
        if (s == Sight::kVisible) {
          ++seen;
          seen_trusted += trusted[i][v] != 0;
        }
      }
      uint8_t rules = 0;
      if (occluded > 0 && occluded < 3) rules |= kSeamOcclusion;
      if (seen_trusted > 0 && seen_trusted < seen) rules |= kSeamVote;
      if (in_view > 0 && in_view < 3) rules |= kSeamFieldOfView;
      seams[i][t] = rules;
    }
  }
  return seams;
}

std::vector<double> globalVisibility(const std::vector<std::vector<uint8_t>>& visible) {
  std::vector<double> score(visible.size(), 0.0);
  double best = 0;
  for (size_t i = 0; i < visible.size(); ++i) {
    score[i] = static_cast<double>(std::count(visible[i].begin(), visible[i].end(), 1));
    best = std::max(best, score[i]);
  }
  for (double& s : score) s = best > 0 ? s / best : 0.0;
  return score;
}

}  // namespace holofuse::render::reference
