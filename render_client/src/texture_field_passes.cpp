#include "render_client/texture_field_passes.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "render_client/reference/depth_map.h"
#include "shaders/config.h"
#include "shaders/depth_raster_comp_spv.h"
#include "shaders/discontinuity_comp_spv.h"
#include "shaders/geodesic_distance_comp_spv.h"
#include "shaders/geodesic_seed_comp_spv.h"
#include "shaders/global_visibility_comp_spv.h"
#include "shaders/holoportation_field_comp_spv.h"
#include "shaders/montage_field_comp_spv.h"
#include "shaders/seams_comp_spv.h"
#include "shaders/triangle_views_comp_spv.h"
#include "shaders/view_candidates_comp_spv.h"
#include "shaders/visibility_comp_spv.h"
#include "shaders/vote_comp_spv.h"

namespace holofuse::render {
namespace {

void computeBarrier(VkCommandBuffer cmd, VkPipelineStageFlags dst_stage, VkAccessFlags dst_access) {
  // Later passes, the vertex shader and host readback (tests) all read.
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  barrier.dstAccessMask = dst_access;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, dst_stage, 0, 1, &barrier, 0,
                       nullptr, 0, nullptr);
}

// After a pass whose results the blend reads (the vertex and fragment
// shaders), later passes read or overwrite, and the tests read back.
void barrierBeforeBlend(VkCommandBuffer cmd) {
  computeBarrier(cmd,
                 VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT |
                     VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                 VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT);
}

// Buffers cleared or filled by transfer commands, then used by compute.
void clearedBarrier(VkCommandBuffer cmd) {
  VkMemoryBarrier cleared{};
  cleared.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  cleared.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  // The geodesic counts are also indirect dispatch arguments.
  cleared.dstAccessMask =
      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                       0, 1, &cleared, 0, nullptr, 0, nullptr);
}

uint32_t groups(uint32_t n, uint32_t size) { return (n + size - 1) / size; }
constexpr uint32_t kStamps = 8;  // around the depth maps and the six timed passes

}  // namespace

std::vector<GeodesicFan> geodesicFans(const Mesh& mesh, const std::vector<uint32_t>& adjacency) {
  const size_t vertex_count = mesh.vertexCount();
  std::vector<GeodesicFan> fans(adjacency.size() - vertex_count - 1);
  for (uint32_t c = 0; c < vertex_count; ++c) {
    for (uint32_t k = adjacency[c]; k < adjacency[c + 1]; ++k) {
      const uint32_t t = adjacency[vertex_count + 1 + k];
      const uint32_t i0 = mesh.indices[3 * t], i1 = mesh.indices[3 * t + 1],
                     i2 = mesh.indices[3 * t + 2];
      GeodesicFan& f = fans[k];
      f.a = i0 == c ? i1 : (i1 == c ? i2 : i0);
      f.b = i0 == c ? i2 : (i1 == c ? i0 : i1);
      const glm::dvec3 pa(mesh.positions[f.a]), pb(mesh.positions[f.b]), pc(mesh.positions[c]);
      const double ab = glm::length(pa - pb), ac = glm::length(pa - pc), bc = glm::length(pb - pc);
      // The same construction as render::reference::unfoldedDistance.
      const double cx = ab > 0 ? (ac * ac - bc * bc + ab * ab) / (2 * ab) : 0.0;
      f.ab = static_cast<float>(ab);
      f.ac = static_cast<float>(ac);
      f.bc = static_cast<float>(bc);
      f.cx = static_cast<float>(cx);
      f.cy = static_cast<float>(std::sqrt(std::max(ac * ac - cx * cx, 0.0)));
      f.unused = 0.0f;
    }
  }
  return fans;
}

TextureFieldPasses::TextureFieldPasses(VulkanContext& context, VkPipelineLayout layout)
    : ctx_(context), layout_(layout) {
  depth_raster_ = create(k_depth_raster_comp_spv, sizeof(k_depth_raster_comp_spv));
  discontinuity_ = create(k_discontinuity_comp_spv, sizeof(k_discontinuity_comp_spv));
  visibility_ = create(k_visibility_comp_spv, sizeof(k_visibility_comp_spv));
  vote_ = create(k_vote_comp_spv, sizeof(k_vote_comp_spv));
  seams_ = create(k_seams_comp_spv, sizeof(k_seams_comp_spv));
  global_visibility_ = create(k_global_visibility_comp_spv, sizeof(k_global_visibility_comp_spv));
  geodesic_seed_ = create(k_geodesic_seed_comp_spv, sizeof(k_geodesic_seed_comp_spv));
  geodesic_distance_ = create(k_geodesic_distance_comp_spv, sizeof(k_geodesic_distance_comp_spv));
  montage_ = create(k_montage_field_comp_spv, sizeof(k_montage_field_comp_spv));
  field_ = create(k_holoportation_field_comp_spv, sizeof(k_holoportation_field_comp_spv));
  candidates_ = create(k_view_candidates_comp_spv, sizeof(k_view_candidates_comp_spv));
  triangle_views_ = create(k_triangle_views_comp_spv, sizeof(k_triangle_views_comp_spv));
  VkQueryPoolCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = kStamps;
  HOLOFUSE_VK_CHECK(vkCreateQueryPool(ctx_.device(), &info, nullptr, &queries_));
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(ctx_.physicalDevice(), &props);
  timestamp_period_ns_ = props.limits.timestampPeriod;
}

// "field" is the field pass and, after it, each triangle's merge of its
// corners' best views.
const std::vector<std::string>& TextureFieldPasses::stageNames() {
  static const std::vector<std::string> kNames = {"depth_maps",
                                                  "discontinuities",
                                                  "visibility",
                                                  "voting",
                                                  "seams_and_global_visibility",
                                                  "geodesics",
                                                  "field"};
  return kNames;
}

void TextureFieldPasses::recordCandidates(VkCommandBuffer cmd, VkDescriptorSet set,
                                          uint32_t vertex_count, uint32_t camera_count,
                                          uint32_t width, uint32_t height) {
  ComputePush push{};
  push.vertex_count = vertex_count;
  push.camera_count = camera_count;
  push.width = width;  // of the depth maps
  push.height = height;
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set, 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, candidates_);
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, HOLOFUSE_COMPUTE_PUSH_OFFSET,
                     sizeof(push), &push);
  if (vertex_count > 0) vkCmdDispatch(cmd, groups(vertex_count, HOLOFUSE_VERTEX_GROUP), 1, 1);
  barrierBeforeBlend(cmd);
}

void TextureFieldPasses::recordMontage(VkCommandBuffer cmd, VkDescriptorSet set,
                                       uint32_t vertex_count, uint32_t triangle_count,
                                       uint32_t camera_count, const FieldParameters& parameters,
                                       float geodesic_scale, uint32_t temporal_stride) {
  ComputePush push{};
  push.vertex_count = vertex_count;
  push.triangle_count = triangle_count;
  push.camera_count = camera_count;
  push.parity = finalDistanceHalf(parameters);  // the half holding the final distances
  push.max_rings = parameters.geodesic_rings;
  push.geodesic_scale = geodesic_scale;
  push.temporal_stride = temporal_stride;
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set, 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, montage_);
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, HOLOFUSE_COMPUTE_PUSH_OFFSET,
                     sizeof(push), &push);
  // Repeated for measurement as stage 6 (FieldParameters::repeated_stage):
  // the pass reads the previous half and writes the current one, so every
  // repeat writes the same values.
  const int repeats = parameters.repeated_stage == 6 ? std::max(1, parameters.stage_repeats) : 1;
  for (int r = 0; r < repeats; ++r) {
    if (vertex_count > 0) vkCmdDispatch(cmd, groups(vertex_count, HOLOFUSE_VERTEX_GROUP), 1, 1);
    barrierBeforeBlend(cmd);
  }
  recordTriangleViews(cmd, push);
  if (field_stamp_pending_)
    stamp(cmd, 7);  // this command buffer ran the per-mesh passes: the field is stage 6
  field_stamp_pending_ = false;
}

void TextureFieldPasses::recordTriangleViews(VkCommandBuffer cmd, const ComputePush& push) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, triangle_views_);
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, HOLOFUSE_COMPUTE_PUSH_OFFSET,
                     sizeof(push), &push);
  if (push.triangle_count > 0)
    vkCmdDispatch(cmd, groups(push.triangle_count, HOLOFUSE_VERTEX_GROUP), 1, 1);
  barrierBeforeBlend(cmd);
}

void TextureFieldPasses::beginTiming(VkCommandBuffer cmd) {
  vkCmdResetQueryPool(cmd, queries_, 0, kStamps);
  stamp(cmd, 0);
}

void TextureFieldPasses::depthMapsDone(VkCommandBuffer cmd) { stamp(cmd, 1); }

void TextureFieldPasses::recordDepthMaps(VkCommandBuffer cmd, VkDescriptorSet set,
                                         uint32_t triangle_count, uint32_t camera_count,
                                         uint32_t width, uint32_t height, VkBuffer depth_maps) {
  const float far_depth = HOLOFUSE_NO_DEPTH;
  uint32_t far_bits;
  std::memcpy(&far_bits, &far_depth, 4);
  vkCmdFillBuffer(cmd, depth_maps, 0, VK_WHOLE_SIZE, far_bits);
  clearedBarrier(cmd);
  ComputePush push{};
  push.width = width;
  push.height = height;
  push.camera_count = camera_count;
  push.triangle_count = triangle_count;
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set, 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, depth_raster_);
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, HOLOFUSE_COMPUTE_PUSH_OFFSET,
                     sizeof(push), &push);
  if (triangle_count > 0 && camera_count > 0) {
    vkCmdDispatch(cmd, groups(triangle_count, HOLOFUSE_VERTEX_GROUP), camera_count, 1);
  }
  // The compute passes and the blend's fragment shader read the maps.
  computeBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
                 VK_ACCESS_SHADER_READ_BIT);
}

void TextureFieldPasses::stamp(VkCommandBuffer cmd, uint32_t index) {
  vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, index);
}

std::vector<double> TextureFieldPasses::lastTimesMs() const {
  if (!recorded_) return {};
  uint64_t ticks[kStamps] = {};
  if (vkGetQueryPoolResults(ctx_.device(), queries_, 0, kStamps, sizeof(ticks), ticks,
                            sizeof(uint64_t), VK_QUERY_RESULT_64_BIT) != VK_SUCCESS) {
    return {};
  }
  std::vector<double> ms;
  for (uint32_t k = 1; k < kStamps; ++k) {
    const std::string& stage = stageNames()[k - 1];
    const bool absent =
        !geodesics_recorded_ && (stage == "seams_and_global_visibility" || stage == "geodesics");
    ms.push_back(
        absent ? -1.0 : static_cast<double>(ticks[k] - ticks[k - 1]) * timestamp_period_ns_ / 1e6);
  }
  return ms;
}

TextureFieldPasses::~TextureFieldPasses() {
  for (VkPipeline p :
       {depth_raster_, discontinuity_, visibility_, vote_, seams_, global_visibility_,
        geodesic_seed_, geodesic_distance_, montage_, field_, candidates_, triangle_views_}) {
    vkDestroyPipeline(ctx_.device(), p, nullptr);
  }
  vkDestroyQueryPool(ctx_.device(), queries_, nullptr);
}

VkPipeline TextureFieldPasses::create(const uint32_t* code, size_t bytes) {
  return ctx_.createComputePipeline(code, bytes, layout_);
}

void TextureFieldPasses::record(VkCommandBuffer cmd, VkDescriptorSet set, uint32_t vertex_count,
                                uint32_t triangle_count, uint32_t camera_count, uint32_t width,
                                uint32_t height, const FieldParameters& parameters,
                                const ResetBuffers& reset) {
  ComputePush push{};
  push.vertex_count = vertex_count;
  push.width = width;
  push.height = height;
  push.relative_jump = parameters.relative_jump;
  push.dilation = parameters.dilation_px < 0 ? reference::scaledDilationPx(static_cast<int>(width))
                                             : parameters.dilation_px;
  push.depth_tolerance = parameters.relative_depth_tolerance;
  push.vote_delta = parameters.vote_delta;
  push.vote_levels = parameters.vote_levels;
  push.alpha = parameters.alpha;
  push.camera_count = camera_count;
  push.triangle_count = triangle_count;
  vkCmdFillBuffer(cmd, reset.visible_counts, 0, VK_WHOLE_SIZE, 0);
  geodesics_recorded_ = parameters.geodesics;
  if (!parameters.geodesics) vkCmdFillBuffer(cmd, reset.seams, 0, VK_WHOLE_SIZE, 0);
  // Empty lists and clear marks. A pass whose list is empty dispatches no
  // group: once the distances settle, the remaining of the K passes cost
  // only their barriers.
  auto clearWorklists = [&] {
    std::vector<uint32_t> empty(4 * worklistPasses(parameters), 1);  // x, y, z groups, length
    for (size_t k = 0; k < empty.size(); k += 4) empty[k] = empty[k + 3] = 0;
    constexpr size_t kMaxUpdateWords = 65536 / 4;  // vkCmdUpdateBuffer's limit
    for (size_t at = 0; at < empty.size(); at += kMaxUpdateWords) {
      const size_t words = std::min(kMaxUpdateWords, empty.size() - at);
      vkCmdUpdateBuffer(cmd, reset.worklist_counts, at * 4, words * 4, empty.data() + at);
    }
    vkCmdFillBuffer(cmd, reset.worklist, 0, VK_WHOLE_SIZE, 0);
  };
  if (parameters.geodesics) clearWorklists();
  clearedBarrier(cmd);
  // A stop for measurement: the stamps of the skipped stages read zero.
  auto stopsAfter = [&](int stage) {
    if (parameters.last_stage != stage) return false;
    for (uint32_t index = static_cast<uint32_t>(stage) + 2; index < kStamps; ++index)
      stamp(cmd, index);
    recorded_ = true;
    return true;
  };
  if (stopsAfter(0)) return;
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set, 0, nullptr);
  auto dispatchLinear = [&](VkPipeline pipeline, uint32_t items, bool barrier) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, HOLOFUSE_COMPUTE_PUSH_OFFSET,
                       sizeof(push), &push);
    if (items > 0) vkCmdDispatch(cmd, groups(items, HOLOFUSE_VERTEX_GROUP), 1, 1);
    if (barrier)
      computeBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
  };
  // How many times stage s is recorded (FieldParameters::repeated_stage).
  auto repeats = [&](int stage) {
    return parameters.repeated_stage == stage ? std::max(1, parameters.stage_repeats) : 1;
  };
  // Every per-vertex pass covers all cameras in one dispatch, so each
  // stage costs one barrier.
  for (int r = 0; r < repeats(1); ++r) dispatchLinear(discontinuity_, vertex_count, true);
  stamp(cmd, 2);
  if (stopsAfter(1)) return;
  for (int r = 0; r < repeats(2); ++r) dispatchLinear(visibility_, vertex_count, true);
  stamp(cmd, 3);
  if (stopsAfter(2)) return;
  for (int r = 0; r < repeats(3); ++r) dispatchLinear(vote_, vertex_count, true);
  stamp(cmd, 4);
  if (stopsAfter(3)) return;
  // Seams and the global visibility feed only the geodesics and montage4d's
  // g^i: the Holoportation baseline does not pay for them (paper 000
  // Table 3: N/A).
  for (int r = 0; r < (parameters.geodesics ? repeats(4) : 0); ++r) {
    // Seams and visibility counts read the same inputs: no barrier between.
    // (Counting inside the seams or vote pass measured no faster on
    // lavapipe: the work is the gathers, not the extra dispatch.)
    dispatchLinear(seams_, triangle_count, false);
    dispatchLinear(global_visibility_, vertex_count, true);
  }
  stamp(cmd, 5);
  if (stopsAfter(4)) return;
  if (parameters.geodesics) {
    // Stage 6: seed from the seams (per vertex, every camera), then K
    // Jacobi passes of rings and distances together over all cameras (y)
    // and vertices (x).
    push.max_rings = parameters.geodesic_rings;
    push.geodesic_scale =
        parameters.geodesic_radius > 0 ? parameters.geodesic_radius : HOLOFUSE_FAR;
    push.parity = 0;
    for (int r = 0; r < repeats(5); ++r) {
      if (r > 0) {  // a repeat for measurement starts from clean lists, as a new mesh does
        computeBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
        clearWorklists();
        clearedBarrier(cmd);
      }
      dispatchLinear(geodesic_seed_, camera_count > 0 ? vertex_count : 0, false);
      // The Jacobi passes write the halves the seeds wrote, too.
      computeBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                     VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
      // The first pass runs over every entry; each later one only the
      // entries its predecessor queued, the dispatch size coming from the
      // GPU (indirect, no round trip to the host; zero groups once the
      // distances settle).
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, geodesic_distance_);
      for (int pass = 0; pass < parameters.geodesic_iterations; ++pass) {
        push.parity = static_cast<uint32_t>(pass) % 2;
        push.worklist_pass = static_cast<uint32_t>(pass);
        vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, HOLOFUSE_COMPUTE_PUSH_OFFSET,
                           sizeof(push), &push);
        if (pass == 0) {  // every entry (see the shader): vertices along x, cameras along y
          if (vertex_count > 0 && camera_count > 0) {
            vkCmdDispatch(cmd, groups(vertex_count, HOLOFUSE_VERTEX_GROUP), camera_count, 1);
          }
        } else {
          vkCmdDispatchIndirect(cmd, reset.worklist_counts, VkDeviceSize{16} * push.worklist_pass);
        }
        computeBarrier(cmd,
                       VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                       VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                           VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
      }
    }
  }
  stamp(cmd, 6);
  if (stopsAfter(5)) return;
  recorded_ = true;
  if (parameters.field_per_view) {  // recordMontage computes it and closes this run's timing
    field_stamp_pending_ = true;
    return;
  }
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, field_);
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, HOLOFUSE_COMPUTE_PUSH_OFFSET,
                     sizeof(push), &push);
  for (int r = 0; r < repeats(6); ++r) {
    if (vertex_count > 0) vkCmdDispatch(cmd, groups(vertex_count, HOLOFUSE_VERTEX_GROUP), 1, 1);
    barrierBeforeBlend(cmd);
  }
  recordTriangleViews(cmd, push);
  stamp(cmd, 7);
}

}  // namespace holofuse::render
