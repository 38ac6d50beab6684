// The texture-field compute passes of docs/design.md section 6 on Vulkan, one
// pipeline per stage (shaders/<stage>.comp.glsl): dilated depth
// discontinuities at the vertices, per-vertex visibility, majority voting,
// seams, geodesics and the fields. Each has a CPU reference in render/reference/ that
// the tests compare it with.
#pragma once

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "gpu/vulkan_context.h"
#include "render_client/render_settings.h"
#include "shaders/config.h"

namespace holofuse::render {

// The renderer's passes are built on the shared Vulkan context.
using gpu::Buffer;
using gpu::Image;
using gpu::transferWritesToHost;
using gpu::transitionImage;
using gpu::VulkanContext;

// C++ mirror of the GLSL Fan (compute_common.glsl): vertex c's view of one
// triangle (a, b, c) around it, unfolded into the plane (a at the origin,
// b at (ab, 0), c at (cx, cy) with cy >= 0). The geodesic passes read it
// instead of refetching three positions and redoing the same square roots
// in each of K passes for every camera.
struct GeodesicFan {
  uint32_t a, b;
  float ab, cx, cy, ac, bc, unused;
};
static_assert(sizeof(GeodesicFan) == 32);

// One fan per entry of the vertex -> triangle adjacency (CSR: vertex_count
// + 1 offsets, then triangle ids), in the same order. a and b follow c in
// the triangle's winding.
std::vector<GeodesicFan> geodesicFans(const Mesh& mesh, const std::vector<uint32_t>& adjacency);

// Mirror of the Push block in shaders/compute_common.glsl.
struct ComputePush {
  uint32_t vertex_count;
  uint32_t worklist_pass;
  uint32_t width;
  uint32_t height;
  float relative_jump;
  int32_t dilation;
  float depth_tolerance;
  float vote_delta;
  int32_t vote_levels;
  float alpha;
  uint32_t camera_count;
  uint32_t triangle_count;
  uint32_t parity;
  int32_t max_rings;
  float geodesic_scale;
  uint32_t temporal_stride;
};
static_assert(sizeof(ComputePush) == 64);
static_assert(HOLOFUSE_COMPUTE_PUSH_OFFSET + sizeof(ComputePush) <= 128,
              "lavapipe allows 128 bytes");

// Geodesic worklist counts (dispatch size and length): count p belongs to
// the list Jacobi pass p reads, which pass p - 1 appends to (the first
// pass runs densely and reads none); the last pass appends to count K.
inline uint32_t worklistPasses(const FieldParameters& parameters) {
  return static_cast<uint32_t>(std::max(parameters.geodesic_iterations, 0)) + 1;
}

class TextureFieldPasses {
 public:
  // layout: the shared pipeline layout (the one descriptor set of
  // config.h's bindings, push constants for compute at offset 0).
  TextureFieldPasses(VulkanContext& context, VkPipelineLayout layout);
  ~TextureFieldPasses();
  TextureFieldPasses(const TextureFieldPasses&) = delete;
  TextureFieldPasses& operator=(const TextureFieldPasses&) = delete;

  // Starts the GPU clock of a frame: call before the depth maps are drawn,
  // then depthMapsDone() after them, then record().
  void beginTiming(VkCommandBuffer cmd);
  void depthMapsDone(VkCommandBuffer cmd);
  // Stage 1: clears depth_maps ([camera][y][x] float bits) to
  // HOLOFUSE_NO_DEPTH and rasterises every triangle into every camera's
  // map; a barrier makes them readable to compute and fragment shaders.
  void recordDepthMaps(VkCommandBuffer cmd, VkDescriptorSet set, uint32_t triangle_count,
                       uint32_t camera_count, uint32_t width, uint32_t height, VkBuffer depth_maps);
  // Records stages 2 to 4 and the Holoportation field for the bound set,
  // then each triangle's merged best views, with a barrier between
  // dependent dispatches and one at the end that makes them visible to
  // the blend.
  // Buffers the passes reset themselves before use (transfer commands).
  struct ResetBuffers {
    VkBuffer visible_counts;   // cleared before stage 7 adds to it
    VkBuffer worklist;         // geodesic worklists and marks, cleared
    VkBuffer worklist_counts;  // indirect dispatch sizes, set to empty lists
    VkBuffer seams;            // zero where the mode computes no seams (holoportation)
  };
  void record(VkCommandBuffer cmd, VkDescriptorSet set, uint32_t vertex_count,
              uint32_t triangle_count, uint32_t camera_count, uint32_t width, uint32_t height,
              const FieldParameters& parameters, const ResetBuffers& reset);

  // Stages 8 to 10 of Montage4D for one rendered view (per frame, after the
  // per-mesh passes): target, temporal and normalised fields, then each
  // triangle's merged best views for the blend.
  void recordMontage(VkCommandBuffer cmd, VkDescriptorSet set, uint32_t vertex_count,
                     uint32_t triangle_count, uint32_t camera_count,
                     const FieldParameters& parameters, float geodesic_scale,
                     uint32_t temporal_stride);

  // Modes normal and fragment with more cameras than best views: each
  // vertex's candidate cameras for the rendered view (after the depth
  // maps; shaders/view_candidates.comp.glsl).
  void recordCandidates(VkCommandBuffer cmd, VkDescriptorSet set, uint32_t vertex_count,
                        uint32_t camera_count, uint32_t width, uint32_t height);

  // GPU milliseconds of each pass in the last recorded run (after the
  // submission finished), in pass order, named as in stageNames(); -1 for
  // a pass the run's mode does not have (holoportation: seams and
  // geodesics), whose stamps only bracket nothing.
  std::vector<double> lastTimesMs() const;
  static const std::vector<std::string>& stageNames();
  // Which half of the ping-pong buffers holds the final distances.
  static uint32_t finalDistanceHalf(const FieldParameters& p) {
    return static_cast<uint32_t>(p.geodesic_iterations) % 2;
  }

 private:
  VkPipeline create(const uint32_t* code, size_t bytes);
  // After a field pass: each triangle's corners' best views merged, for
  // the blend (shaders/triangle_views.comp.glsl), with the field pass's
  // push constants and bound set.
  void recordTriangleViews(VkCommandBuffer cmd, const ComputePush& push);
  void stamp(VkCommandBuffer cmd, uint32_t index);

  VulkanContext& ctx_;
  VkPipelineLayout layout_;
  VkPipeline depth_raster_ = VK_NULL_HANDLE, discontinuity_ = VK_NULL_HANDLE,
             visibility_ = VK_NULL_HANDLE, seams_ = VK_NULL_HANDLE,
             global_visibility_ = VK_NULL_HANDLE, geodesic_seed_ = VK_NULL_HANDLE,
             geodesic_distance_ = VK_NULL_HANDLE, montage_ = VK_NULL_HANDLE, vote_ = VK_NULL_HANDLE,
             field_ = VK_NULL_HANDLE, candidates_ = VK_NULL_HANDLE,
             triangle_views_ = VK_NULL_HANDLE;
  VkQueryPool queries_ = VK_NULL_HANDLE;
  double timestamp_period_ns_ = 1.0;
  bool recorded_ = false;
  bool field_stamp_pending_ =
      false;  // record() ran for montage4d: recordMontage writes the last stamp
  bool geodesics_recorded_ = false;  // the last record() ran the seams and geodesics
};

}  // namespace holofuse::render
