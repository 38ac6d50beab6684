// Visual hull from silhouettes: the valid region (where every camera's
// silhouette bounding rectangle back-projects, paper 004), a signed distance
// sampled on a voxel grid inside it, and marching cubes. The grid is
// visited coarse to fine: a cell whose projected footprint lies wholly
// inside every silhouette, or wholly outside one, is settled without
// sampling its points; only cells the surface may cross are refined down to
// voxels, whose corners get the exact signed distance. Every voxel the
// surface crosses is such a cell, so marching cubes places the same vertices
// as on the dense grid.
#pragma once

#include <functional>
#include <vector>

#include "geometry/camera.h"
#include "geometry/marching_cubes.h"
#include "geometry/mesh.h"
#include "image/image.h"

namespace holofuse::hull {

struct HullView {
  Camera camera;
  Image8 mask;     // 255 foreground
  Image8 feather;  // distance inside the silhouette, pixels (0 outside)
};

// The voxel sizes a flag takes, metres.
inline constexpr double kMinVoxel = 0.0001, kMaxVoxel = 0.5;

struct HullStats;
struct HullGridInput;

// The carve from its input to the surface (vertex keys on the input's
// grid): the CPU's own (surfaceOfGrid of fillHullGrid), or a device's
// (hull/vulkan_hull_grid.h). Either gives the same occupancy.
using HullSurface = std::function<Mesh(const HullGridInput&, HullStats&)>;

struct HullOptions {
  double voxel_size = 0.02;                 // metres: the accuracy knob
  glm::dvec3 volume_min{-1.0, -0.1, -1.0};  // capture volume
  glm::dvec3 volume_max{1.0, 1.9, 1.0};
  double valid_region_step = 0.08;  // coarse step of the valid-region search
  // Coarse-to-fine: cells of 2^levels voxels are classified inside, outside
  // or boundary against every silhouette and only boundary cells are split;
  // 0 samples every grid point (the dense reference).
  int hierarchy_levels = 4;
  // false: carve the whole capture volume instead of the valid region (what
  // the region saves is measured against it: bench_hull).
  bool valid_region = true;
  // Who carves: empty is the CPU (surfaceOfGrid of fillHullGrid).
  HullSurface surface;
};

// Sets the capture volume and scales the valid-region search to it (40
// steps across its diagonal at most).
void setCaptureVolume(HullOptions& options, const glm::dvec3& volume_min,
                      const glm::dvec3& volume_max);

struct HullStats {
  glm::dvec3 region_min{0.0}, region_max{0.0};
  size_t grid_points = 0;       // of the fine grid over the valid region
  size_t cells_classified = 0;  // coarse and intermediate cells tested against the silhouettes
  size_t points_sampled = 0;    // fine grid points whose signed distance was evaluated
  size_t cells_visited() const { return cells_classified + points_sampled; }
  size_t triangles = 0;
};

// The grid stage's input: the fine grid over the valid region (origin on
// the capture volume's lattice) and each view's silhouette signed distance
// (silhouetteSignedDistance) and foreground counts (sums[(y + 1) * (w + 1)
// + x + 1] counts the mask's foreground in [0, x] x [0, y]; empty where
// levels <= 0).
struct HullGridInput {
  const std::vector<HullView>* views = nullptr;
  glm::dvec3 origin{0.0};
  double spacing = 0;
  glm::ivec3 points{0};
  int levels = 0;
  std::vector<std::vector<float>> distances;
  std::vector<std::vector<uint32_t>> foreground_sums;
};

// The CPU's grid: cells of 2^levels voxels classified against every
// silhouette and split where the surface may cross them; the corners of
// every voxel it may cross get the exact signed distance (metres, > 0
// inside), settled cells one voxel inside or outside. levels <= 0: every
// point exact.
ScalarGrid fillHullGrid(const HullGridInput& input, HullStats& stats);

// The grid's outer layer forced outside (so the surface is closed), then
// marching cubes.
Mesh surfaceOfGrid(ScalarGrid grid);

// Signed distance of each pixel to the silhouette border in pixels,
// positive inside: the feather map inside, the distance transform of the
// background outside. Sampled bilinearly by the carver.
std::vector<float> silhouetteSignedDistance(const HullView& view);

// The lattice of the capture volume that vertex keys are numbered on:
// points per axis, x fastest; a key is (point index) * 3 + edge axis.
glm::u64vec3 keyLattice(const HullOptions& options);

// The mesh's vertex_keys name the grid edge each vertex sits on, on the
// lattice of the capture volume (keyLattice): the same edge has the same
// key in every frame.
Mesh carveVisualHull(const std::vector<HullView>& views, const HullOptions& options,
                     HullStats* stats = nullptr);

}  // namespace holofuse::hull
