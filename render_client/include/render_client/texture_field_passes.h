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

#include "common/mesh.h"
#include "render_client/vulkan_context.h"
#include "shaders/config.h"

namespace holofuse::render {

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

struct FieldParameters {
  float relative_jump = 0.03f;  // discontinuity: relative depth step
  int dilation_px = -1;         // discontinuity: eps; -1: paper 000's 4 px at 2048 wide, scaled
                                // (reference::scaledDilationPx)
  float relative_depth_tolerance = 0.015f;
  // The majority vote's delta; 0: no vote, every visible view trusted.
  // Paper 000's vote (delta = 0.15) rejects a view whose colour disagrees;
  // on a visual hull every view disagrees somewhat, the hull lying off the
  // surface, and the vote cost the temple 0.7-0.9 dB while gaining no
  // synthetic scene more than 0.1 (docs/blending.md).
  float vote_delta = 0.0f;
  int vote_levels = 3;
  float alpha = 2.0f;
  // The views each vertex keeps for the blend (1 to HOLOFUSE_MAX_BEST_VIEWS):
  // its largest field weights, renormalised where any is left out. The
  // blend's cost per fragment grows with this, not with the camera count.
  int best_views = 8;
  // Seams, the global visibility and the geodesic distance from the seams
  // (docs/design.md section 6, steps 5 to 7): run only when a mode needs them (montage4d); the
  // Holoportation baseline does not pay for them.
  bool geodesics = false;
  // montage4d: the field depends on the view, and recordMontage computes it
  // for every rendered view in place of the per-mesh field pass ("field").
  bool field_per_view = false;
  int geodesic_rings = 15;       // k
  int geodesic_iterations = 20;  // K
  // Metres from a seam at which gamma reaches 1, and beyond which no
  // distance is computed (0: k mean edge lengths, distance unbounded).
  // Paper 000's k = 15 triangles on its ~4 mm-edge captures is about 6 cm;
  // a fixed length keeps that reach on coarser meshes, where 15 rings would
  // span a whole limb and the fields would sum below 1 almost everywhere.
  float geodesic_radius = 0.06f;
  // Measurement only (bench_texture_fields): record the per-mesh passes up
  // to this stage of stageNames() and skip the rest (-1: all). Wall clock
  // differences between stops give each stage's cost where a CPU device's
  // timestamps cannot (it rasterises lazily). A stop before stage 6 ("field") skips
  // montage4d's per-view field as well.
  int last_stage = -1;
  // Measurement only: record the dispatches of stage repeated_stage (1 to
  // 6 of stageNames(); 6 in montage4d is its per-view field pass)
  // stage_repeats times over. Stages that cost a
  // fraction of a millisecond drown in a shared machine's noise once; the
  // extra time of many repeats, divided by their number, does not. The
  // global visibility counts come out multiplied: timing runs only.
  int repeated_stage = -1;
  int stage_repeats = 1;
  bool operator==(const FieldParameters&) const = default;
};

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

// The largest geodesic reach in rings (k) the packed ring field holds.
constexpr int kMaxGeodesicRings = 64;
static_assert(kMaxGeodesicRings < static_cast<int>(HOLOFUSE_NO_RING));

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
