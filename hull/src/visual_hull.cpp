#include "hull/visual_hull.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <tuple>
#include <utility>

#include "geometry/marching_cubes.h"

namespace holofuse::hull {
namespace {

struct Rect {
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // inclusive
  bool empty() const { return x1 < x0; }
};

// The silhouette's bounding rectangle (image/image.h), inclusive bounds.
Rect silhouetteRect(const Image8& mask) {
  const PixelRect r = foregroundRect(mask);
  if (r.empty()) return {};
  return {static_cast<int>(r.x), static_cast<int>(r.y), static_cast<int>(r.x + r.width - 1),
          static_cast<int>(r.y + r.height - 1)};
}

float sampleBilinear(const std::vector<float>& image, int w, int h, double u, double v) {
  // Pixel centres sit at .5.
  const double x = std::clamp(u - 0.5, 0.0, w - 1.0), y = std::clamp(v - 0.5, 0.0, h - 1.0);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
  const double fx = x - x0, fy = y - y0;
  const double a = image[y0 * w + x0] * (1 - fx) + image[y0 * w + x1] * fx;
  const double b = image[y1 * w + x0] * (1 - fx) + image[y1 * w + x1] * fx;
  return static_cast<float>(a * (1 - fy) + b * fy);
}

enum class CellClass { kInside, kOutside, kBoundary };

// Foreground pixels of a mask, summed: sums[(y + 1) * (w + 1) + x + 1]
// counts those in [0, x] x [0, y], so any rectangle's count takes four
// reads.
std::vector<uint32_t> foregroundSums(const Image8& mask) {
  const size_t w = mask.width, h = mask.height;
  std::vector<uint32_t> sums((w + 1) * (h + 1), 0);
  for (size_t y = 0; y < h; ++y) {
    uint32_t row = 0;
    for (size_t x = 0; x < w; ++x) {
      row += mask.pixels[y * w + x] != 0 ? 1u : 0u;
      sums[(y + 1) * (w + 1) + x + 1] = sums[y * (w + 1) + x + 1] + row;
    }
  }
  return sums;
}

// Where the cube [p0, p1] lies against every silhouette, exactly as the
// grid points inside it would be carved. Its image lies within the convex
// hull of its projected corners, so within their bounding box. A point's
// silhouette distance is the bilinear blend of the four pixels around it
// (pixel centres at .5, clamped at the border), so every point of the box
// takes a convex combination of the pixels in the box grown to those
// neighbours. The signed distance of a foreground pixel is at least +0.5
// and of a background pixel at most -0.5 (silhouetteSignedDistance): if
// every pixel there is foreground, every point is inside for this camera;
// if none is, every point is outside. Points off the image count as
// outside, as in the carve. Tests (test_fusion) hold the result to the
// dense grid's, vertex for vertex.
CellClass classifyCell(const glm::dvec3& p0, const glm::dvec3& p1,
                       const std::vector<HullView>& views,
                       const std::vector<std::vector<uint32_t>>& foreground_sums) {
  bool inside_all = true;
  for (size_t i = 0; i < views.size(); ++i) {
    const Camera& cam = views[i].camera;
    // Lens distortion bends straight edges: the corner bound holds for a
    // pinhole only, so such cameras settle nothing.
    if (!cam.distortion.empty()) return CellClass::kBoundary;
    double x_min = std::numeric_limits<double>::max(), y_min = x_min, x_max = -x_min,
           y_max = -x_min;
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 corner((k & 1) ? p1.x : p0.x, (k & 2) ? p1.y : p0.y, (k & 4) ? p1.z : p0.z);
      const auto q = cam.project(corner);
      if (!q || !std::isfinite(q->x) || !std::isfinite(q->y))
        return CellClass::kBoundary;  // crosses the camera plane
      x_min = std::min(x_min, q->x);
      x_max = std::max(x_max, q->x);
      y_min = std::min(y_min, q->y);
      y_max = std::max(y_max, q->y);
    }
    // The grid points inside may project an ulp past the corners' box:
    // grow it by far more than that, so the image-border tests stay
    // conservative.
    constexpr double kRounding = 1e-6;
    x_min -= kRounding;
    y_min -= kRounding;
    x_max += kRounding;
    y_max += kRounding;
    const double w = cam.width, h = cam.height;
    if (x_max < 0 || y_max < 0 || x_min >= w || y_min >= h)
      return CellClass::kOutside;  // wholly off the image
    // Some points off the image are outside: the rest decide only "outside".
    const bool off_image = x_min < 0 || y_min < 0 || x_max >= w || y_max >= h;
    auto firstPixel = [](double u, double size) {
      return static_cast<int>(std::clamp(u - 0.5, 0.0, size - 1));
    };
    auto lastPixel = [](double u, double size) {
      return std::min(static_cast<int>(std::clamp(u - 0.5, 0.0, size - 1)) + 1,
                      static_cast<int>(size) - 1);
    };
    const int x0 = firstPixel(x_min, w), x1 = lastPixel(x_max, w), y0 = firstPixel(y_min, h),
              y1 = lastPixel(y_max, h);
    const std::vector<uint32_t>& sums = foreground_sums[i];
    const size_t stride = cam.width + 1;
    const uint32_t foreground = sums[(y1 + 1) * stride + x1 + 1] - sums[y0 * stride + x1 + 1] -
                                sums[(y1 + 1) * stride + x0] + sums[y0 * stride + x0];
    if (foreground == 0) return CellClass::kOutside;
    if (off_image || foreground < static_cast<uint32_t>((x1 - x0 + 1) * (y1 - y0 + 1)))
      inside_all = false;
  }
  return inside_all ? CellClass::kInside : CellClass::kBoundary;
}

// What one top cell's subtree settled without sampling, and the voxels
// the surface may cross (their corners are sampled).
struct CellVerdicts {
  struct Settled {
    glm::ivec3 a, b;  // inclusive grid point range
    float value;
  };
  std::vector<Settled> settled;
  std::vector<glm::ivec3> voxels;
  size_t cells_classified = 0;
};

// Classifies the cell [a, a + size] (clipped to the grid) and, where the
// surface may cross it, its children down to voxels.
CellVerdicts classifyTopCell(const glm::ivec3& top_a, int top_size, const ScalarGrid& grid,
                             const std::vector<HullView>& views,
                             const std::vector<std::vector<uint32_t>>& foreground_sums) {
  const glm::ivec3 n(grid.nx, grid.ny, grid.nz);
  const float s = static_cast<float>(grid.spacing);
  CellVerdicts verdicts;
  struct Cell {
    glm::ivec3 a;
    int size;
  };
  std::vector<Cell> stack = {{top_a, top_size}};
  while (!stack.empty()) {
    const Cell cell = stack.back();
    stack.pop_back();
    const glm::ivec3 b = glm::min(cell.a + cell.size, n - 1);
    if (cell.size == 1) {
      verdicts.voxels.push_back(cell.a);
      continue;
    }
    const glm::dvec3 p0 = grid.point(cell.a.x, cell.a.y, cell.a.z), p1 = grid.point(b.x, b.y, b.z);
    ++verdicts.cells_classified;
    CellClass c = classifyCell(p0, p1, views, foreground_sums);
    // The grid's outer layer is forced outside afterwards: an inside cell on
    // it must be refined, or its points keep a placeholder next to the
    // forced border.
    const bool on_border = cell.a.x == 0 || cell.a.y == 0 || cell.a.z == 0 || b.x == n.x - 1 ||
                           b.y == n.y - 1 || b.z == n.z - 1;
    if (c == CellClass::kInside && on_border) c = CellClass::kBoundary;
    if (c != CellClass::kBoundary) {
      verdicts.settled.push_back({cell.a, b, c == CellClass::kInside ? s : -s});
      continue;
    }
    const int half = cell.size / 2;
    for (int dz = 0; dz < 2; ++dz) {
      for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
          const glm::ivec3 a = cell.a + half * glm::ivec3(dx, dy, dz);
          if (a.x < n.x - 1 && a.y < n.y - 1 && a.z < n.z - 1) stack.push_back({a, half});
        }
      }
    }
  }
  return verdicts;
}

// The fine grid of `n` points from `lo`, filled coarse to fine. Settled
// cells give their points a placeholder of one voxel inside or outside;
// the corners of every voxel the surface may cross get the exact signed
// distance, whatever a neighbouring cell settled. Settled cells never
// disagree on a point they share (classifyCell is exact for the points it
// settles), so the grid is the same whatever order the cells are visited
// in: the top cells are classified side by side, then the placeholders
// are written, then the exact points are sampled side by side.
template <typename Distance>
ScalarGrid sampleHierarchically(const glm::dvec3& lo, double s, const glm::ivec3& n, int levels,
                                const std::vector<HullView>& views,
                                const std::vector<std::vector<uint32_t>>& foreground_sums,
                                Distance&& signedDistance, HullStats& stats) {
  ScalarGrid grid;
  grid.nx = n.x;
  grid.ny = n.y;
  grid.nz = n.z;
  grid.origin = lo;
  grid.spacing = s;
  grid.values.assign(static_cast<size_t>(n.x) * n.y * n.z, 0.0f);
  auto index = [&](int x, int y, int z) { return (static_cast<size_t>(z) * n.y + y) * n.x + x; };
  const int top = 1 << levels;
  std::vector<glm::ivec3> tops;
  for (int z = 0; z < n.z - 1; z += top) {
    for (int y = 0; y < n.y - 1; y += top) {
      for (int x = 0; x < n.x - 1; x += top) tops.push_back({x, y, z});
    }
  }
  std::vector<CellVerdicts> verdicts(tops.size());
  tbb::parallel_for(size_t{0}, tops.size(), [&](size_t i) {
    verdicts[i] = classifyTopCell(tops[i], top, grid, views, foreground_sums);
  });
  std::vector<uint8_t> exact(grid.values.size(), 0);
  for (const CellVerdicts& v : verdicts) {
    stats.cells_classified += v.cells_classified;
    for (const auto& settled : v.settled) {
      for (int z = settled.a.z; z <= settled.b.z; ++z) {
        for (int y = settled.a.y; y <= settled.b.y; ++y) {
          float* row = &grid.values[index(settled.a.x, y, z)];
          std::fill(row, row + (settled.b.x - settled.a.x + 1), settled.value);
        }
      }
    }
    for (const glm::ivec3& a : v.voxels) {
      const glm::ivec3 b = glm::min(a + 1, n - 1);
      for (int z = a.z; z <= b.z; ++z) {
        for (int y = a.y; y <= b.y; ++y) {
          for (int x = a.x; x <= b.x; ++x) exact[index(x, y, z)] = 1;
        }
      }
    }
  }
  // Each grid plane's exact points, sampled on its own.
  std::vector<size_t> sampled(static_cast<size_t>(n.z), 0);
  tbb::parallel_for(0, n.z, [&](int z) {
    for (int y = 0; y < n.y; ++y) {
      for (int x = 0; x < n.x; ++x) {
        const size_t i = index(x, y, z);
        if (!exact[i]) continue;
        grid.values[i] = static_cast<float>(signedDistance(grid.point(x, y, z)));
        ++sampled[z];
      }
    }
  });
  for (size_t count : sampled) stats.points_sampled += count;
  return grid;
}

// The valid region: the bounds of the points of a coarse lattice that
// fall inside every camera's silhouette rectangle (empty: lo above hi).
// Each plane of the lattice is tested on its own.
std::pair<glm::dvec3, glm::dvec3> validRegion(const std::vector<HullView>& views,
                                              const std::vector<Rect>& rects,
                                              const HullOptions& options) {
  const double step = options.valid_region_step;
  std::vector<double> planes;
  for (double z = options.volume_min.z; z <= options.volume_max.z; z += step) planes.push_back(z);
  constexpr double kMax = std::numeric_limits<double>::max();
  std::vector<std::pair<glm::dvec3, glm::dvec3>> bounds(planes.size(),
                                                        {glm::dvec3(kMax), glm::dvec3(-kMax)});
  tbb::parallel_for(size_t{0}, planes.size(), [&](size_t k) {
    auto& [lo, hi] = bounds[k];
    for (double y = options.volume_min.y; y <= options.volume_max.y; y += step) {
      for (double x = options.volume_min.x; x <= options.volume_max.x; x += step) {
        const glm::dvec3 p(x, y, planes[k]);
        bool inside_all = true;
        for (size_t i = 0; i < views.size() && inside_all; ++i) {
          const auto proj = views[i].camera.project(p);
          // A lattice point within one step of the rectangle may still carry
          // surface: test against the rectangle grown by the step's footprint.
          const double margin = proj ? step * views[i].camera.fx / proj->z : 0;
          inside_all = proj && proj->x >= rects[i].x0 - margin &&
                       proj->x <= rects[i].x1 + 1 + margin && proj->y >= rects[i].y0 - margin &&
                       proj->y <= rects[i].y1 + 1 + margin;
        }
        if (!inside_all) continue;
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
      }
    }
  });
  std::pair<glm::dvec3, glm::dvec3> region = {glm::dvec3(kMax), glm::dvec3(-kMax)};
  for (const auto& [lo, hi] : bounds) {
    region.first = glm::min(region.first, lo);
    region.second = glm::max(region.second, hi);
  }
  return region;
}

}  // namespace

void setCaptureVolume(HullOptions& options, const glm::dvec3& volume_min,
                      const glm::dvec3& volume_max) {
  options.volume_min = volume_min;
  options.volume_max = volume_max;
  options.valid_region_step =
      std::min(options.valid_region_step, glm::length(volume_max - volume_min) / 40);
}

std::vector<float> silhouetteSignedDistance(const HullView& view) {
  const int w = static_cast<int>(view.mask.width), h = static_cast<int>(view.mask.height);
  cv::Mat mask(h, w, CV_8UC1, const_cast<uint8_t*>(view.mask.pixels.data()));
  cv::Mat background = mask == 0;
  cv::Mat outside;
  cv::distanceTransform(background, outside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::vector<float> sd(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      // The border lies half a pixel from the centres on either side.
      sd[i] = view.mask.pixels[i] != 0 ? std::max<float>(view.feather.pixels[i], 1.0f) - 0.5f
                                       : -(outside.at<float>(y, x) - 0.5f);
    }
  }
  return sd;
}

glm::u64vec3 keyLattice(const HullOptions& options) {
  // The stride depends on the capture volume only (never on a frame's
  // region): a region's first point + its size - 1 stays below
  // ceil(extent / s) + 3 on every axis.
  return glm::u64vec3(glm::ceil((options.volume_max - options.volume_min) / options.voxel_size)) +
         glm::u64vec3(3);
}

ScalarGrid fillHullGrid(const HullGridInput& input, HullStats& stats) {
  const std::vector<HullView>& views = *input.views;
  const double s = input.spacing;
  // The hull's signed distance is approximated by the smallest of the
  // cameras' silhouette distances, each turned from pixels into metres at
  // the point's depth.
  auto signedDistance = [&](const glm::dvec3& p) {
    double value = std::numeric_limits<double>::max();
    for (size_t i = 0; i < views.size(); ++i) {
      const Camera& cam = views[i].camera;
      const auto proj = cam.project(p);
      // Written so that NaN (a hostile calibration) counts as outside.
      if (!proj || !(proj->x >= 0 && proj->y >= 0 && proj->x < cam.width && proj->y < cam.height))
        return -s;
      const double px = sampleBilinear(input.distances[i], static_cast<int>(cam.width),
                                       static_cast<int>(cam.height), proj->x, proj->y);
      value = std::min(value, px * proj->z / cam.fx);
    }
    return value;
  };
  const glm::ivec3 n = input.points;
  if (input.levels <= 0) {
    ScalarGrid grid = sampleGrid(input.origin, s, n.x, n.y, n.z, signedDistance);
    stats.points_sampled = grid.values.size();
    return grid;
  }
  return sampleHierarchically(input.origin, s, n, input.levels, views, input.foreground_sums,
                              signedDistance, stats);
}

Mesh surfaceOfGrid(ScalarGrid grid) {
  const int nx = grid.nx, ny = grid.ny, nz = grid.nz;
  const float inside_at_most = static_cast<float>(-0.5 * grid.spacing);
  for (int z = 0; z < nz; ++z) {
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) {
        if (x == 0 || y == 0 || z == 0 || x == nx - 1 || y == ny - 1 || z == nz - 1) {
          float& v = grid.values[(static_cast<size_t>(z) * ny + y) * nx + x];
          v = std::min(v, inside_at_most);
        }
      }
    }
  }
  return marchingCubes(grid);
}

Mesh carveVisualHull(const std::vector<HullView>& views, const HullOptions& options,
                     HullStats* stats) {
  if (views.empty()) return {};
  std::vector<Rect> rects;
  for (const auto& v : views) {
    if (v.mask.width != v.camera.width || v.mask.height != v.camera.height ||
        v.feather.width != v.mask.width || v.feather.height != v.mask.height) {
      return {};  // images that do not match their calibration cannot be carved with
    }
    rects.push_back(silhouetteRect(v.mask));
    if (rects.back().empty()) return {};  // an empty silhouette carves everything away
  }
  const double step = options.valid_region_step;
  glm::dvec3 lo, hi;
  if (options.valid_region) {
    std::tie(lo, hi) = validRegion(views, rects, options);
    if (lo.x > hi.x) return {};
    lo = glm::max(lo - step, options.volume_min);
    hi = glm::min(hi + step, options.volume_max);
  } else {
    lo = options.volume_min;
    hi = options.volume_max;
  }
  // Snap the region onto the capture volume's voxel lattice, so a grid edge
  // has the same key in every frame however the region moves (the temporal
  // texture field follows vertices by these keys).
  const double s = options.voxel_size;
  const glm::ivec3 first = glm::ivec3(glm::floor((lo - options.volume_min) / s));
  lo = options.volume_min + s * glm::dvec3(first);

  HullGridInput input;
  input.views = &views;
  input.origin = lo;
  input.spacing = s;
  input.points = glm::ivec3(glm::ceil((hi - lo) / s)) + 1;
  input.levels = options.hierarchy_levels;
  input.distances.resize(views.size());
  if (input.levels > 0) input.foreground_sums.resize(views.size());
  tbb::parallel_for(size_t{0}, views.size(), [&](size_t i) {
    input.distances[i] = silhouetteSignedDistance(views[i]);
    if (input.levels > 0) input.foreground_sums[i] = foregroundSums(views[i].mask);
  });
  HullStats local;
  Mesh mesh =
      options.surface ? options.surface(input, local) : surfaceOfGrid(fillHullGrid(input, local));
  const glm::ivec3 n = input.points;
  // Local edge keys to keys on the capture volume's lattice.
  const glm::u64vec3 lattice = keyLattice(options);
  for (uint64_t& key : mesh.vertex_keys) {
    const uint64_t axis = key % 3, point = key / 3;
    const uint64_t x = point % n.x + first.x, y = (point / n.x) % n.y + first.y,
                   z = point / (uint64_t(n.x) * n.y) + first.z;
    key = ((z * lattice.y + y) * lattice.x + x) * 3 + axis;
  }
  if (stats != nullptr) {
    *stats = local;
    stats->region_min = lo;
    stats->region_max = hi;
    stats->grid_points = static_cast<size_t>(n.x) * n.y * n.z;
    stats->triangles = mesh.triangleCount();
  }
  return mesh;
}

}  // namespace holofuse::hull
