// The hull's grid on a Vulkan device (lavapipe here) against the CPU's:
// the same occupancy at every point, the exact values to float rounding,
// meshes within a voxel, and the grids the device cannot hold carved on
// the CPU, counted.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <tuple>
#include <vector>

#include "hull/synthetic_views.h"
#include "hull/visual_hull.h"
#include "hull/vulkan_hull_grid.h"

namespace holofuse::hull {
namespace {

using test::syntheticViews;

struct BothGrids {
  ScalarGrid cpu, device;
  HullStats cpu_stats, device_stats;
};

// Carves once, filling the grid both ways from the same input.
BothGrids carveBothWays(VulkanHullGrid& device, const std::vector<HullView>& views,
                        HullOptions options) {
  BothGrids both;
  options.surface = [&](const HullGridInput& input, HullStats& stats) {
    both.cpu = fillHullGrid(input, both.cpu_stats);
    both.device = device.fill(input, both.device_stats);
    stats = both.device_stats;
    return surfaceOfGrid(both.device);
  };
  carveVisualHull(views, options);
  return both;
}

// Distances (in voxels) within float rounding of the surface.
constexpr float kOnSurface = 1e-4f;

// Every point on the same side of the surface; where both sampled the
// exact distance, the same value to float rounding. The device samples at
// least the CPU's exact points: its cells settle a little more cautiously.
void expectSameOccupancy(const BothGrids& both, const std::string& what) {
  ASSERT_EQ(both.cpu.values.size(), both.device.values.size()) << what;
  ASSERT_GT(both.cpu.values.size(), 1000u) << what;
  const float s = static_cast<float>(both.cpu.spacing);
  size_t differ = 0, inside = 0, on_surface = 0;
  for (size_t i = 0; i < both.cpu.values.size(); ++i) {
    const float c = both.cpu.values[i], d = both.device.values[i];
    ASSERT_TRUE(std::isfinite(d)) << what << " point " << i;
    inside += c > 0;
    // Within float rounding of the surface either side will do.
    if (std::abs(c) < kOnSurface * s) {
      ++on_surface;
      continue;
    }
    if ((c > 0) != (d > 0)) ++differ;
    // +-s is a placeholder, or a point some camera does not see.
    if (std::abs(c) != s && std::abs(d) != s) {
      EXPECT_NEAR(d, c, 1e-4f * s + 1e-5f * std::abs(c)) << what << " point " << i;
    }
  }
  EXPECT_GT(inside, 100u) << what;
  EXPECT_EQ(differ, 0u) << what << ": points on the other side of the surface";
  EXPECT_LT(on_surface, both.cpu_stats.points_sampled / 100) << what;
  EXPECT_GE(both.device_stats.points_sampled, both.cpu_stats.points_sampled) << what;
  EXPECT_LT(both.device_stats.points_sampled, 2 * both.cpu_stats.points_sampled + 1000) << what;
}

TEST(VulkanHullGrid, FillsTheCpusOccupancyCoarseToFineAndDense) {
  gpu::VulkanContext context;
  VulkanHullGrid device(context);
  const auto views = syntheticViews(6, 12);
  for (double voxel : {0.02, 0.01}) {
    for (int levels : {4, 2, 0}) {
      HullOptions options;
      options.voxel_size = voxel;
      options.hierarchy_levels = levels;
      if (levels == 0 && voxel < 0.02) continue;  // the dense 10 mm grid is slow on the CPU
      expectSameOccupancy(carveBothWays(device, views, options),
                          std::to_string(voxel) + " m, " + std::to_string(levels) + " levels");
    }
  }
  EXPECT_EQ(device.cpuFallbacks(), 0u);
}

TEST(VulkanHullGrid, DistortedLensesSettleNothingAndSampleLikeTheCpu) {
  gpu::VulkanContext context;
  VulkanHullGrid device(context);
  auto views = syntheticViews(4, 3);
  views[1].camera.distortion = {0.05, -0.01, 0.001, -0.002, 0.003};
  HullOptions options;
  const BothGrids both = carveBothWays(device, views, options);
  expectSameOccupancy(both, "distorted");
}

TEST(VulkanHullGrid, ItsMeshIsTheCpusWithinAVoxel) {
  gpu::VulkanContext context;
  auto device = std::make_shared<VulkanHullGrid>(context);
  const auto views = syntheticViews(6, 20);
  HullOptions options;
  options.voxel_size = 0.01;
  expectSameOccupancy(carveBothWays(*device, views, options), "frame 20");
  const Mesh cpu = carveVisualHull(views, options);
  options.surface = deviceSurface(device);
  const Mesh gpu = carveVisualHull(views, options);
  ASSERT_GT(cpu.triangleCount(), 1000u);
  // Nearly every vertex sits on the same grid edge as one of the CPU's,
  // within a hundredth of a voxel of it; a point within float rounding
  // of the surface may move a few a little. Every vertex lies within a
  // voxel of the CPU's surface.
  std::map<uint64_t, glm::vec3> by_key;
  std::map<std::tuple<int, int, int>, std::vector<glm::vec3>> by_cell;
  const float s = static_cast<float>(options.voxel_size);
  auto cellOf = [&](const glm::vec3& p) {
    return std::make_tuple(static_cast<int>(std::floor(p.x / s)),
                           static_cast<int>(std::floor(p.y / s)),
                           static_cast<int>(std::floor(p.z / s)));
  };
  for (size_t i = 0; i < cpu.vertex_keys.size(); ++i) {
    by_key[cpu.vertex_keys[i]] = cpu.positions[i];
    by_cell[cellOf(cpu.positions[i])].push_back(cpu.positions[i]);
  }
  size_t same_edge = 0;
  double worst_same_edge = 0, worst = 0;
  for (size_t i = 0; i < gpu.vertex_keys.size(); ++i) {
    const glm::vec3 p = gpu.positions[i];
    if (const auto it = by_key.find(gpu.vertex_keys[i]); it != by_key.end()) {
      ++same_edge;
      worst_same_edge = std::max(worst_same_edge, static_cast<double>(glm::length(p - it->second)));
      continue;
    }
    double nearest = 1e9;
    const auto [cx, cy, cz] = cellOf(p);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (const auto it = by_cell.find({cx + dx, cy + dy, cz + dz}); it != by_cell.end())
            for (const glm::vec3& q : it->second)
              nearest = std::min(nearest, static_cast<double>(glm::length(p - q)));
    worst = std::max(worst, nearest);
  }
  EXPECT_GT(static_cast<double>(same_edge), 0.999 * static_cast<double>(gpu.vertex_keys.size()));
  EXPECT_LT(worst_same_edge, 1e-2 * options.voxel_size);
  EXPECT_LT(worst, options.voxel_size);
  EXPECT_NEAR(static_cast<double>(gpu.triangleCount()), static_cast<double>(cpu.triangleCount()),
              0.001 * static_cast<double>(cpu.triangleCount()));
  RecordProperty("vertices_on_other_edges", std::to_string(gpu.vertex_keys.size() - same_edge));
  RecordProperty("worst_same_edge_offset_um", std::to_string(worst_same_edge * 1e6));
}

// Marching cubes on the device numbers the vertices as the host's over
// the same (device's) grid, vertex for vertex, at the same places to
// float rounding; a corners' buffer too small for a frame is grown and
// the frame marched again on the device.
TEST(VulkanHullGrid, MarchesTheSurfaceAsTheHostDoesOverItsGrid) {
  gpu::VulkanContext context;
  VulkanHullGrid device(context);
  for (double voxel : {0.02, 0.01}) {
    for (uint64_t frame : {4, 9}) {
      const auto views = syntheticViews(6, frame);
      HullOptions options;
      options.voxel_size = voxel;
      Mesh marched, on_host;
      options.surface = [&](const HullGridInput& input, HullStats& stats) {
        marched = device.surface(input, stats);
        HullStats again;
        on_host = surfaceOfGrid(device.fill(input, again));
        return marched;
      };
      carveVisualHull(views, options);
      const std::string what = std::to_string(voxel) + " m, frame " + std::to_string(frame);
      ASSERT_GT(on_host.triangleCount(), 1000u) << what;
      EXPECT_EQ(marched.indices, on_host.indices) << what;
      ASSERT_EQ(marched.vertex_keys, on_host.vertex_keys) << what;
      ASSERT_EQ(marched.normals.size(), marched.positions.size()) << what;
      float worst = 0;
      for (size_t i = 0; i < marched.positions.size(); ++i)
        worst = std::max(worst, glm::length(marched.positions[i] - on_host.positions[i]));
      EXPECT_LT(worst, 1e-4f * static_cast<float>(voxel)) << what;
    }
  }
  EXPECT_EQ(device.cpuFallbacks(), 0u);
  // The first 10 mm frame (about 170k corners) outgrew the first buffer
  // (65536); the second fitted the grown one.
  EXPECT_EQ(device.remarches(), 1u);
}

TEST(VulkanHullGrid, AGridTooLargeForTheDeviceIsFilledOnTheCpuAndCounted) {
  gpu::VulkanContext context;
  VulkanHullGrid device(context);
  const auto views = syntheticViews(3, 1);
  HullGridInput input;
  input.views = &views;
  input.origin = glm::dvec3(-0.6, 0.9, 0.0);
  input.spacing = 0.0011;
  input.points = glm::ivec3(1100, 2, 2);  // more points on x than the packing holds
  for (const auto& v : views) input.distances.push_back(silhouetteSignedDistance(v));
  HullStats device_stats, cpu_stats;
  const ScalarGrid on_device = device.fill(input, device_stats);
  const ScalarGrid on_cpu = fillHullGrid(input, cpu_stats);
  EXPECT_EQ(device.cpuFallbacks(), 1u);
  EXPECT_EQ(on_device.values, on_cpu.values);
  EXPECT_EQ(device_stats.points_sampled, on_cpu.values.size());
}

}  // namespace
}  // namespace holofuse::hull
