#include "texture/texture_layers.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>

#include "geometry/depth_raster.h"

namespace holofuse {

namespace {

// A camera that sees a texel's point: its score (Volino and Hilton eq. 2's
// cosine times the feather weight) and the point's position in its image.
struct Candidate {
  double score = 0.0;
  double x = 0.0, y = 0.0;
  uint8_t view = kNoLayerCamera;
};

// A row of the atlas: each texel's cameras, best first; texel x's are
// candidates[begin[x]] .. candidates[begin[x + 1] - 1].
struct RankedRow {
  std::vector<uint32_t> begin;
  std::vector<Candidate> candidates;
};

// The colour at pixel position (x, y), pixel centres at .5, by Catmull-Rom
// bicubic interpolation (Keys 1981, a = -1/2) over the 4x4 pixels around
// it. The layers resample each camera image once and the renderer samples
// the layers bilinearly again; bilinear here too blurred the picture
// twice (eval, 8 frames, H.264 layers: SSIM +0.011 on clean and +0.013 on
// many-cameras against bilinear, PSNR within 0.07 dB, 3% more bytes).
// With a mask, only the silhouette's pixels count, their weights
// renormalised (as the renderer's blend samples a camera, so a border
// texel does not take the background's colour); where the pixels inside
// weigh too little for the cubic's lobes, their bilinear mean. Its
// overshoot is clamped to 0..255 by the caller.
glm::dvec3 sampleColor(const Image8& image, const Image8* mask, double x, double y) {
  const double fx = x - 0.5, fy = y - 0.5;
  const int ix = static_cast<int>(std::floor(fx)), iy = static_cast<int>(std::floor(fy));
  const double tx = fx - ix, ty = fy - iy;
  auto weights = [](double t, double w[4]) {  // Keys' cubic at distances 1+t, t, 1-t, 2-t
    const double t2 = t * t, t3 = t2 * t;
    w[0] = 0.5 * (-t3 + 2 * t2 - t);
    w[1] = 0.5 * (3 * t3 - 5 * t2 + 2);
    w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
    w[3] = 0.5 * (t3 - t2);
  };
  double wx[4], wy[4];
  weights(tx, wx);
  weights(ty, wy);
  const double bx[4] = {0, 1 - tx, tx, 0}, by[4] = {0, 1 - ty, ty, 0};
  glm::dvec3 cubic(0.0), linear(0.0);
  double cubic_weight = 0, linear_weight = 0;
  for (int j = 0; j < 4; ++j) {
    const uint32_t yy = static_cast<uint32_t>(std::clamp(iy - 1 + j, 0, int(image.height) - 1));
    for (int i = 0; i < 4; ++i) {
      const uint32_t xx = static_cast<uint32_t>(std::clamp(ix - 1 + i, 0, int(image.width) - 1));
      const double inside = mask != nullptr ? mask->at(xx, yy)[0] / 255.0 : 1.0;
      const uint8_t* p = image.at(xx, yy);
      const glm::dvec3 c(p[0], p[1], p[2]);
      cubic += wx[i] * wy[j] * inside * c;
      cubic_weight += wx[i] * wy[j] * inside;
      linear += bx[i] * by[j] * inside * c;
      linear_weight += bx[i] * by[j] * inside;
    }
  }
  if (cubic_weight > 0.5) return cubic / cubic_weight;
  return linear_weight > 1e-9 ? linear / linear_weight : cubic;
}

// The point of triangle t nearest to p, as barycentrics, and its distance
// (0 inside): a texel just outside a triangle's footprint (a border
// texel bilinear sampling reads) takes the colour of the triangle's
// nearest point, as the paper's border triangles copy the edge's values.
double nearestOnTriangle(const glm::dvec2& p, const std::array<glm::dvec2, 3>& t, glm::dvec3& b) {
  const glm::dvec2 e0 = t[1] - t[0], e1 = t[2] - t[0], d = p - t[0];
  const double det = e0.x * e1.y - e1.x * e0.y;
  if (std::abs(det) > 1e-12) {
    const double b1 = (d.x * e1.y - e1.x * d.y) / det;
    const double b2 = (e0.x * d.y - d.x * e0.y) / det;
    if (b1 >= 0 && b2 >= 0 && b1 + b2 <= 1) {
      b = glm::dvec3(1.0 - b1 - b2, b1, b2);
      return 0.0;
    }
  }
  // Outside (or degenerate): the nearest point of the three edges.
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const glm::dvec2 a = t[k], c = t[(k + 1) % 3], ac = c - a;
    const double length2 = glm::dot(ac, ac);
    const double s = length2 > 0 ? std::clamp(glm::dot(p - a, ac) / length2, 0.0, 1.0) : 0.0;
    const double distance = glm::length(p - (a + s * ac));
    if (distance < best) {
      best = distance;
      b = glm::dvec3(0.0);
      b[k] = 1.0 - s;
      b[(k + 1) % 3] = s;
    }
  }
  return best;
}

// Which point of the surface each texel holds: the triangle whose atlas
// footprint is nearest within reach, and the barycentrics of its nearest
// point. A bilinear sample inside a footprint reads texels whose centres
// lie under one texel away on each axis, so reach is sqrt(2) texels; a
// texel between two footprints goes to the nearer (the layouts keep
// triangles of different patches further apart than that).
struct TexelSource {
  int32_t triangle = -1;
  double distance = std::numeric_limits<double>::infinity();
  glm::dvec3 barycentric{0.0};
};
std::vector<TexelSource> texelSources(const Mesh& mesh, uint32_t texels, uint64_t& contested) {
  constexpr double kReach = 1.41421356237;
  // Each triangle's corners in texels and the texels within reach of its
  // footprint, [x0, x1] x [y0, y1] (empty where x1 < x0).
  struct Footprint {
    std::array<glm::dvec2, 3> corners;
    int x0, y0, x1, y1;
  };
  const size_t triangles = mesh.triangleCount();
  std::vector<Footprint> footprints(triangles);
  tbb::parallel_for(size_t{0}, triangles, [&](size_t t) {
    Footprint& f = footprints[t];
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
    for (int k = 0; k < 3; ++k) {
      f.corners[k] = glm::dvec2(mesh.corner_uvs[3 * t + k]) * double(texels);
      lo = glm::min(lo, f.corners[k]);
      hi = glm::max(hi, f.corners[k]);
    }
    f.x0 = std::max(0, static_cast<int>(std::floor(lo.x - kReach)));
    f.y0 = std::max(0, static_cast<int>(std::floor(lo.y - kReach)));
    f.x1 = std::min<int>(texels - 1, static_cast<int>(std::ceil(hi.x + kReach)));
    f.y1 = std::min<int>(texels - 1, static_cast<int>(std::ceil(hi.y + kReach)));
  });
  // Bands of rows side by side, each visiting the triangles that reach it
  // in mesh order: every texel sees the triangles in the order one visit
  // of the whole mesh would, so the sources and the count of contested
  // texels are that visit's on any number of threads.
  constexpr uint32_t kBandRows = 16;
  const uint32_t bands = (texels + kBandRows - 1) / kBandRows;
  std::vector<std::vector<uint32_t>> band_triangles(bands);
  for (size_t t = 0; t < triangles; ++t) {
    const Footprint& f = footprints[t];
    if (f.x1 < f.x0 || f.y1 < f.y0) continue;
    for (uint32_t band = f.y0 / kBandRows; band <= f.y1 / kBandRows; ++band)
      band_triangles[band].push_back(static_cast<uint32_t>(t));
  }
  std::vector<TexelSource> sources(size_t{texels} * texels);
  std::atomic<uint64_t> overlaps{0};
  tbb::parallel_for(uint32_t{0}, bands, [&](uint32_t band) {
    const int band_y0 = static_cast<int>(band * kBandRows);
    const int band_y1 = std::min<int>(texels - 1, band_y0 + kBandRows - 1);
    uint64_t band_overlaps = 0;
    for (const uint32_t t : band_triangles[band]) {
      const Footprint& f = footprints[t];
      for (int y = std::max(f.y0, band_y0); y <= std::min(f.y1, band_y1); ++y) {
        for (int x = f.x0; x <= f.x1; ++x) {
          glm::dvec3 b;
          const double distance = nearestOnTriangle(glm::dvec2(x + 0.5, y + 0.5), f.corners, b);
          TexelSource& source = sources[size_t(y) * texels + x];
          if (distance == 0 && source.distance == 0) ++band_overlaps;  // two footprints overlap
          if (distance > kReach || distance >= source.distance) continue;
          source = {static_cast<int32_t>(t), distance, b};
        }
      }
    }
    overlaps += band_overlaps;
  });
  contested += overlaps;
  return sources;
}

Status checkInputs(const Mesh& mesh, uint32_t texels, const std::vector<LayerView>& views) {
  auto refuse = [](const std::string& what) {
    return Status(StatusCode::kMalformed, "texture layers: " + what);
  };
  if (views.size() >= kNoLayerCamera)
    return refuse(std::to_string(views.size()) + " views; a layer names at most 254");
  if (mesh.normals.size() != mesh.vertexCount()) return refuse("the mesh has no vertex normals");
  if (mesh.corner_uvs.size() != mesh.indices.size())
    return refuse("the mesh has no texture coordinates (TextureAtlas::layOut)");
  if (texels == 0 || texels > kMaxAtlasTexels)
    return refuse("an atlas of " + std::to_string(texels) + " texels");
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

// Appends the cameras that see the point `source` holds, best first (ties
// to the lower view): in front and inside the image, not hidden behind its
// depth map (Volino and Hilton eq. 1, with the renderer's one-sided
// tolerance: LayerOptions), inside its mask, facing it (eq. 2 as a
// cosine), weighted by the feather.
void rankCameras(const Mesh& mesh, const TexelSource& source, const std::vector<LayerView>& views,
                 const std::vector<DepthMap>& depths, double slack, const LayerOptions& options,
                 std::vector<Candidate>& out) {
  const glm::dvec3& b = source.barycentric;
  const uint32_t* corner = &mesh.indices[3 * size_t(source.triangle)];
  glm::dvec3 point(0.0), normal(0.0);
  for (int k = 0; k < 3; ++k) {
    point += b[k] * glm::dvec3(mesh.positions[corner[k]]);
    normal += b[k] * glm::dvec3(mesh.normals[corner[k]]);
  }
  const double length = glm::length(normal);
  if (!(length > 0)) return;
  normal /= length;
  const size_t first = out.size();
  for (size_t j = 0; j < views.size(); ++j) {
    const LayerView& v = views[j];
    const auto pixel = v.camera->project(point);
    if (!pixel || !(pixel->x >= 0 && pixel->y >= 0 && pixel->x < v.camera->width &&
                    pixel->y < v.camera->height))
      continue;
    const uint32_t px = static_cast<uint32_t>(pixel->x), py = static_cast<uint32_t>(pixel->y);
    // One-sided: a point a little in front of the map, where the surface
    // slopes away from the camera between pixel centres, is seen. With the
    // renderer's tolerance a layer holds the cameras the other modes blend
    // (eval, 8 frames, H.264 layers: clean within 0.07 dB of normal's PSNR
    // and above its SSIM).
    const double stored = depths[j].at(px, py);
    if (pixel->z > stored * (1.0 + options.relative_depth_tolerance) + slack) continue;
    if (v.mask != nullptr && v.mask->at(px, py)[0] < 128) continue;
    const double facing = glm::dot(normal, glm::normalize(v.camera->center() - point));
    if (!(facing > 0)) continue;
    double feather = 1.0;
    if (v.feather != nullptr && options.feather_ramp_px > 0)
      feather = std::min(1.0, v.feather->at(px, py)[0] / options.feather_ramp_px);
    if (!(feather > 0)) continue;
    out.push_back({facing * feather, pixel->x, pixel->y, static_cast<uint8_t>(j)});
  }
  std::sort(out.begin() + first, out.end(), [](const Candidate& a, const Candidate& c) {
    return a.score > c.score || (a.score == c.score && a.view < c.view);
  });
}

// The camera of each layer at each texel, in alpha: layer l takes the l-th
// ranked camera, or the camera of its left or upper neighbour in that
// layer where that one sees the point at least options.keep_share as
// squarely (a greedy stand-in for a seam term, Lempitsky and Ivanov 2007:
// fewer camera changes inside a chart, across rows as along them). A
// layer after the first holds a point only where its camera scores at
// least options.min_score_share of the best. Rows in order, each left to
// right, so both neighbours are final: the same bytes on any machine.
void chooseLayerCameras(std::vector<RankedRow>& rows, size_t layer_count,
                        const LayerOptions& options, std::vector<Image8>& layers) {
  const uint32_t texels = static_cast<uint32_t>(rows.size());
  for (uint32_t y = 0; y < texels; ++y) {
    RankedRow& row = rows[y];
    for (uint32_t x = 0; x < texels; ++x) {
      Candidate* ranked = row.candidates.data() + row.begin[x];
      const size_t count = row.begin[x + 1] - row.begin[x];
      if (count == 0) continue;
      const size_t keep = std::min(count, layer_count);
      const double best = ranked[0].score;
      for (size_t l = 0; l < keep; ++l) {
        const uint8_t left = x > 0 ? layers[l].at(x - 1, y)[3] : kNoLayerCamera;
        const uint8_t up = y > 0 ? layers[l].at(x, y - 1)[3] : kNoLayerCamera;
        for (const uint8_t neighbour : {left, up}) {
          if (options.keep_share >= 1.0 || ranked[l].view == left || ranked[l].view == up) break;
          if (neighbour == kNoLayerCamera) continue;
          const Candidate* kept =
              std::find_if(ranked + l + 1, ranked + count,
                           [&](const Candidate& c) { return c.view == neighbour; });
          if (kept != ranked + count && kept->score >= options.keep_share * ranked[l].score) {
            std::swap(ranked[l], ranked[kept - ranked]);
            break;
          }
        }
        if (l > 0 && ranked[l].score < options.min_score_share * best) break;
        layers[l].at(x, y)[3] = ranked[l].view;
      }
    }
  }
}

}  // namespace

StatusOr<TextureLayers> buildTextureLayers(const Mesh& mesh, uint32_t texels,
                                           const std::vector<LayerView>& views,
                                           const LayerOptions& options) {
  if (Status bad = checkInputs(mesh, texels, views); !bad.isOk()) return bad;
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

  const double slack =
      options.depth_slack > 0 ? options.depth_slack : std::max(meanEdgeLength(mesh), 1e-6);
  // Views side by side, then rows of texels side by side wherever a texel
  // is its own; the one pass that reads neighbours (the cameras' choice)
  // runs in order. The layers are the same bytes on any number of threads.
  std::vector<DepthMap> depths(views.size());
  tbb::parallel_for(size_t{0}, views.size(),
                    [&](size_t j) { depths[j] = rasterizeDepth(mesh, *views[j].camera); });

  const std::vector<TexelSource> sources = texelSources(mesh, texels, out.texels_contested);
  // Three passes: every texel's cameras ranked (rows side by side), the
  // cameras each layer takes (in order, since a texel may keep its left or
  // upper neighbour's), then the colours (rows side by side).
  std::vector<RankedRow> rows(texels);
  std::atomic<uint64_t> covered{0}, seen{0};
  tbb::parallel_for(uint32_t{0}, texels, [&](uint32_t y) {
    RankedRow& row = rows[y];
    row.begin.assign(size_t{texels} + 1, 0);
    uint64_t row_covered = 0, row_seen = 0;
    for (uint32_t x = 0; x < texels; ++x) {
      row.begin[x] = static_cast<uint32_t>(row.candidates.size());
      const TexelSource& source = sources[size_t{y} * texels + x];
      if (source.triangle < 0) continue;
      ++row_covered;
      const size_t before = row.candidates.size();
      rankCameras(mesh, source, views, depths, slack, options, row.candidates);
      if (row.candidates.size() > before) ++row_seen;
    }
    row.begin[texels] = static_cast<uint32_t>(row.candidates.size());
    covered += row_covered;
    seen += row_seen;
  });
  chooseLayerCameras(rows, layer_count, options, out.layers);
  tbb::parallel_for(uint32_t{0}, texels, [&](uint32_t y) {
    const RankedRow& row = rows[y];
    for (uint32_t x = 0; x < texels; ++x) {
      for (size_t l = 0; l < out.layers.size(); ++l) {
        uint8_t* texel = out.layers[l].at(x, y);
        if (texel[3] == kNoLayerCamera) break;
        const Candidate& c = row.candidates[row.begin[x] + l];
        const LayerView& v = views[c.view];
        const glm::dvec3 colour = sampleColor(*v.color, v.mask, c.x, c.y);
        for (int k = 0; k < 3; ++k)
          texel[k] = static_cast<uint8_t>(std::clamp(std::lround(colour[k]), 0L, 255L));
      }
    }
  });
  out.covered.resize(sources.size());
  for (size_t i = 0; i < sources.size(); ++i) out.covered[i] = sources[i].triangle >= 0;
  out.texels_covered = covered;
  out.texels_seen = seen;
  return out;
}

void fillUncoveredTexels(Image8& colour, const Image8& camera) {
  // Level 0 is the layer itself: RGB sums and the weight (1 where covered).
  // Every pass below runs rows side by side; a texel reads only the level
  // above or below it, in a fixed order: the same bytes on any thread count.
  struct Level {
    uint32_t width, height;
    std::vector<glm::vec4> texels;  // rgb * weight, weight
  };
  std::vector<Level> levels;
  Level base{colour.width, colour.height, {}};
  base.texels.resize(size_t{colour.width} * colour.height);
  tbb::parallel_for(uint32_t{0}, colour.height, [&](uint32_t y) {
    for (size_t i = size_t{y} * colour.width, end = i + colour.width; i < end; ++i) {
      if (camera.pixels[i] == kNoLayerCamera) continue;
      const uint8_t* c = &colour.pixels[3 * i];
      base.texels[i] = glm::vec4(c[0], c[1], c[2], 1.0f);
    }
  });
  levels.push_back(std::move(base));
  // Push: each level's texel the sum of the (up to) four below it.
  while (levels.back().width > 1 || levels.back().height > 1) {
    const Level& fine = levels.back();
    Level coarse{(fine.width + 1) / 2, (fine.height + 1) / 2, {}};
    coarse.texels.resize(size_t{coarse.width} * coarse.height);
    tbb::parallel_for(uint32_t{0}, coarse.height, [&](uint32_t y) {
      for (uint32_t x = 0; x < coarse.width; ++x) {
        glm::vec4 sum(0.0f);
        for (uint32_t fy = 2 * y; fy < std::min(2 * y + 2, fine.height); ++fy)
          for (uint32_t fx = 2 * x; fx < std::min(2 * x + 2, fine.width); ++fx)
            sum += fine.texels[size_t{fy} * fine.width + fx];
        coarse.texels[size_t{y} * coarse.width + x] = sum;
      }
    });
    levels.push_back(std::move(coarse));
  }
  // Pull: an empty texel takes its parent's mean, which has been filled.
  for (glm::vec4& t : levels.back().texels) {
    if (t.w > 0) t = glm::vec4(glm::vec3(t) / t.w, 1.0f);
  }
  for (size_t l = levels.size() - 1; l-- > 0;) {
    Level& fine = levels[l];
    const Level& coarse = levels[l + 1];
    tbb::parallel_for(uint32_t{0}, fine.height, [&](uint32_t y) {
      for (uint32_t x = 0; x < fine.width; ++x) {
        glm::vec4& t = fine.texels[size_t{y} * fine.width + x];
        const glm::vec4& parent = coarse.texels[size_t{y / 2} * coarse.width + x / 2];
        if (t.w > 0) {
          t = glm::vec4(glm::vec3(t) / t.w, 1.0f);
        } else if (parent.w > 0) {
          t = parent;
        }
      }
    });
  }
  const Level& filled = levels.front();
  tbb::parallel_for(uint32_t{0}, colour.height, [&](uint32_t y) {
    for (size_t i = size_t{y} * colour.width, end = i + colour.width; i < end; ++i) {
      if (camera.pixels[i] != kNoLayerCamera || !(filled.texels[i].w > 0)) continue;
      for (int c = 0; c < 3; ++c)
        colour.pixels[3 * i + c] =
            static_cast<uint8_t>(std::clamp(std::lround(filled.texels[i][c]), 0L, 255L));
    }
  });
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

void continueCamerasAcrossGutters(Image8& camera, const std::vector<uint8_t>& covered) {
  const size_t width = camera.width;
  if (covered.size() != camera.pixels.size() || width == 0) return;
  for (size_t i = 0; i < covered.size(); ++i) {
    if (covered[i]) continue;
    if (i >= width)
      camera.pixels[i] = camera.pixels[i - width];
    else if (i > 0)
      camera.pixels[i] = camera.pixels[i - 1];
  }
}

}  // namespace holofuse
