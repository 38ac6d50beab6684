// The visual hull on a Vulkan device: the coarse-to-fine carve of
// hull::fillHullGrid as compute passes (shaders/hull_*.comp.glsl), one
// level per pass with the lists and their dispatch sizes kept on the
// device, then marching cubes over the cubes the surface may cross. Set
// as HullOptions::surface, the server carves with it (`fusion_server
// --hull-device vulkan`).
#pragma once

#include <array>
#include <atomic>
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
  // The closed grid's surface (hull::surfaceOfGrid of the device's grid):
  // marched on the device, its vertices numbered on the host in the order
  // a scan of the whole grid reaches them, normals area weighted; a frame
  // with more triangles than the device's buffer held is marched again
  // into a larger one. The dense grid (levels <= 0) is marched on the host.
  Mesh surface(const HullGridInput& input, HullStats& stats);

  size_t cpuFallbacks() const;
  // Frames whose corners outgrew the device's buffer and were marched
  // again into a larger one.
  size_t remarches() const;
  const std::string& deviceName() const { return context_.deviceName(); }
  bool cpuDevice() const { return context_.cpuDevice(); }

 private:
  struct Passes;
  VulkanHullGrid(std::unique_ptr<gpu::VulkanContext> owned);
  // The passes for `input` (the caller holds mutex_); with surface, the
  // grid closed and marched: false when the corners overflowed.
  bool carve(const HullGridInput& input, HullStats& stats, bool surface);
  ScalarGrid readGrid(const HullGridInput& input) const;
  void growBuffers(const std::array<VkDeviceSize, 10>& bytes);
  void marchAgain();
  Mesh readSurface() const;
  std::unique_ptr<gpu::VulkanContext> owned_context_;  // before context_: destroyed after it
  gpu::VulkanContext& context_;
  std::unique_ptr<Passes> passes_;
  std::mutex mutex_;  // the device's buffers: one carve at a time
  std::atomic<size_t> cpu_fallbacks_{0}, remarches_{0};
};

// HullOptions::surface carved on `grid`, which the function keeps alive.
HullSurface deviceSurface(std::shared_ptr<VulkanHullGrid> grid);

}  // namespace holofuse::hull
