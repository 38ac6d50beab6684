// What modelling only the subject saves on the fusion server (docs/design.md
// section 5): the visual hull carved coarse to fine inside the valid region
// against the dense grid over the same region, and the grid the whole
// capture volume would be, at two voxel sizes, 8 pods of the synthetic
// scene at 320x240 through the pods' own segmentation; and the same carve
// with its grid on the Vulkan device (`fusion_server --hull-device
// vulkan`), where one opens. Prints ratios measured in one run; the
// machine is noisy.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <memory>
#include <vector>

#include "bench_timing.h"
#include "capture_node/pod.h"
#include "hull/visual_hull.h"
#include "hull/vulkan_hull_grid.h"
#include "scene/synthetic_scene.h"

using namespace holofuse;
using bench::Clock;
using bench::median;

// A mesh's vertices by the lattice edges they sit on, in order: surfaces
// compare whatever order their vertices were numbered in.
static std::vector<uint64_t> sortedKeys(const Mesh& mesh) {
  std::vector<uint64_t> keys = mesh.vertex_keys;
  std::sort(keys.begin(), keys.end());
  return keys;
}

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::max(2, std::atoi(argv[1])) : 4;
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(8, 320, 240);
  std::vector<std::vector<hull::HullView>> groups;
  for (int f = 0; f < frames; ++f) {
    std::vector<hull::HullView> views;
    for (const auto& camera : cameras) {
      capture::PodCapture pod =
          capture::capturePodFrame(scene, camera, scene.backgroundPlate(camera),
                                   30 + static_cast<uint64_t>(f), static_cast<uint16_t>(camera.id));
      views.push_back({camera, pod.mask, pod.feather});
    }
    groups.push_back(std::move(views));
  }
  std::shared_ptr<hull::VulkanHullGrid> device;
  try {
    device = hull::VulkanHullGrid::open();
  } catch (const std::exception& e) {
    std::printf("no Vulkan device opened (%s): the CPU only\n", e.what());
  }
  std::printf("8 pods at 320x240, %d frames of the synthetic subject%s%s\n\n", frames,
              device ? "; device: " : "", device ? device->deviceName().c_str() : "");
  std::printf("%8s %-13s %10s %16s %12s %10s\n", "voxel", "hull", "ms", "points sampled",
              "triangles", "same mesh");
  for (double voxel : {0.02, 0.01}) {
    hull::HullOptions options;
    options.voxel_size = voxel;
    const glm::dvec3 volume = options.volume_max - options.volume_min;
    const double volume_points = std::ceil(volume.x / voxel + 1) * std::ceil(volume.y / voxel + 1) *
                                 std::ceil(volume.z / voxel + 1);
    std::vector<double> ms[2], whole_ms, device_ms;
    size_t device_triangles = 0, device_same_edges = 0, device_vertices = 0;
    double sampled[2] = {0, 0}, region_points = 0;
    size_t triangles[2] = {0, 0};
    bool same = true, same_as_whole = true;
    for (int repeat = 0; repeat < 2; ++repeat) {  // the first round warms the caches
      for (const auto& views : groups) {
        // The dense grid over the whole capture volume: what the valid
        // region saves (timed once per frame, after the warm-up).
        hull::HullOptions whole = options;
        whole.hierarchy_levels = 0;
        whole.valid_region = false;
        Mesh whole_mesh;
        if (repeat == 1) {
          const auto t0 = Clock::now();
          whole_mesh = hull::carveVisualHull(views, whole);
          whole_ms.push_back(bench::ms(t0, Clock::now()));
        }
        Mesh meshes[2];
        for (int hierarchical = 0; hierarchical < 2; ++hierarchical) {
          hull::HullOptions o = options;
          if (!hierarchical) o.hierarchy_levels = 0;
          hull::HullStats stats;
          const auto t0 = Clock::now();
          meshes[hierarchical] = hull::carveVisualHull(views, o, &stats);
          const double elapsed = bench::ms(t0, Clock::now());
          if (repeat == 0) continue;
          ms[hierarchical].push_back(elapsed);
          sampled[hierarchical] += static_cast<double>(stats.cells_visited()) / frames;
          region_points += hierarchical ? 0.0 : static_cast<double>(stats.grid_points) / frames;
          triangles[hierarchical] = meshes[hierarchical].triangleCount();
        }
        if (device) {  // the hierarchical carve on the device
          hull::HullOptions o = options;
          o.surface = hull::deviceSurface(device);
          const auto t0 = Clock::now();
          const Mesh on_device = hull::carveVisualHull(views, o);
          const double elapsed = bench::ms(t0, Clock::now());
          if (repeat == 1) {
            device_ms.push_back(elapsed);
            device_triangles = on_device.triangleCount();
            const auto keys = sortedKeys(meshes[1]), device_keys = sortedKeys(on_device);
            std::vector<uint64_t> common;
            std::set_intersection(keys.begin(), keys.end(), device_keys.begin(), device_keys.end(),
                                  std::back_inserter(common));
            device_same_edges += common.size();
            device_vertices += device_keys.size();
          }
        }
        same = same && meshes[0].indices == meshes[1].indices &&
               meshes[0].positions == meshes[1].positions;
        if (repeat == 1) {  // the same surface, its vertices numbered in another order
          same_as_whole = same_as_whole &&
                          whole_mesh.triangleCount() == meshes[0].triangleCount() &&
                          sortedKeys(whole_mesh) == sortedKeys(meshes[0]);
        }
      }
    }
    std::printf("%6.0f mm %-13s %10.1f %16.0f %12s %10s\n", voxel * 1000, "whole volume",
                median(whole_ms), volume_points, "", same_as_whole ? "as region" : "DIFFERS");
    std::printf("%6.0f mm %-13s %10.1f %16.0f %12zu %10s\n", voxel * 1000, "valid region",
                median(ms[0]), region_points, triangles[0], "");
    std::printf("%6.0f mm %-13s %10.1f %16.0f %12zu %10s\n", voxel * 1000, "hierarchical",
                median(ms[1]), sampled[1], triangles[1], same ? "yes" : "NO");
    if (device) {
      std::printf("%6.0f mm %-13s %10.1f %16s %12zu %9.2f%%\n", voxel * 1000, "on the device",
                  median(device_ms), "", device_triangles,
                  100.0 * static_cast<double>(device_same_edges) /
                      static_cast<double>(std::max<size_t>(device_vertices, 1)));
      std::printf(
          "         on the device: coarse to fine with fusion_server --hull-device vulkan (carve "
          "and marching cubes in compute passes); its \"same mesh\" is the share of its vertices "
          "on the CPU mesh's grid edges\n");
    }
    std::printf(
        "         the valid region samples %.1fx fewer points than the whole volume, %.1fx faster; "
        "coarse to "
        "fine %.1fx fewer again (target >= 5x at the same Chamfer: the same mesh), %.1fx "
        "faster\n\n",
        volume_points / std::max(region_points, 1.0),
        median(whole_ms) / std::max(median(ms[0]), 1e-9), region_points / std::max(sampled[1], 1.0),
        median(ms[0]) / std::max(median(ms[1]), 1e-9));
  }
  return 0;
}
