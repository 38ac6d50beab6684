// The visual hull's grid on a Vulkan device: the coarse-to-fine carve of
// hull::fillHullGrid as compute passes (shaders/hull_*.comp.glsl), one
// level per pass with the lists and their dispatch sizes kept on the
// device. Set as HullOptions::grid_fill, the server carves with it
// (`fusion_server --hull-device vulkan`); marching cubes stays on the host.
#pragma once

#include <memory>
#include <mutex>
#include <string>

#include "gpu/vulkan_context.h"
#include "hull/visual_hull.h"

namespace holofuse::hull {

class VulkanHullGrid {
 public:
  // The context outlives this.
  explicit VulkanHullGrid(gpu::VulkanContext& context);
  // On a context of its own (gpu::VulkanContext's device_selector); throws
  // where no Vulkan device opens.
  static std::shared_ptr<VulkanHullGrid> open(const std::string& device_selector = "");
  ~VulkanHullGrid();
  VulkanHullGrid(const VulkanHullGrid&) = delete;
  VulkanHullGrid& operator=(const VulkanHullGrid&) = delete;

  // The grid of `input`, as fillHullGrid fills it: the same occupancy,
  // values in float. One carve at a time on the device (callers from
  // several threads wait their turn); a grid the device's packing cannot
  // hold (1024 points a side or more, or more voxels than one dispatch
  // reaches) is filled on the CPU instead and counted in cpuFallbacks().
  ScalarGrid fill(const HullGridInput& input, HullStats& stats);

  size_t cpuFallbacks() const;
  const std::string& deviceName() const { return context_.deviceName(); }
  bool cpuDevice() const { return context_.cpuDevice(); }

 private:
  struct Passes;
  VulkanHullGrid(std::unique_ptr<gpu::VulkanContext> owned);
  std::unique_ptr<gpu::VulkanContext> owned_context_;  // before context_: destroyed after it
  gpu::VulkanContext& context_;
  std::unique_ptr<Passes> passes_;
  mutable std::mutex mutex_;
  size_t cpu_fallbacks_ = 0;
};

// grid_fill for HullOptions: carves on `grid`, which the function keeps alive.
HullGridFill deviceGridFill(std::shared_ptr<VulkanHullGrid> grid);

}  // namespace holofuse::hull
