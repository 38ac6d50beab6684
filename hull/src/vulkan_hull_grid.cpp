#include "hull/vulkan_hull_grid.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <glm/gtc/packing.hpp>
#include <unordered_map>
#include <vector>

#include "shaders/hull_classify_comp_spv.h"
#include "shaders/hull_march_comp_spv.h"
#include "shaders/hull_mark_comp_spv.h"
#include "shaders/hull_sample_comp_spv.h"
#include "shaders/hull_settle_comp_spv.h"

namespace holofuse::hull {
namespace {

constexpr uint32_t kGroup = 64;         // HULL_GROUP
constexpr int kPacked = 1024;           // points a side the packing holds
constexpr uint32_t kMaxGroups = 65535;  // a dispatch's groups along x, at least
constexpr uint32_t kBuffers = 10;       // bindings 0..9 of hull_common.glsl
constexpr uint32_t kCaseTable = 7, kCorners = 8, kCubes = 9;

// hull_common.glsl's HullCamera, std430.
struct GpuCamera {
  float rows[3][4];
  float intrinsics[4];
  float image[4];
  float lens[4];
  float lens_k3[4];
  uint32_t offsets[4];
};
static_assert(sizeof(GpuCamera) == 128);

struct Push {
  float origin[4];
  int32_t points[4];
  uint32_t list_in[4];
  uint32_t list_out[4];
  uint32_t march[4];
};

uint32_t groupsFor(uint64_t items) { return static_cast<uint32_t>((items + kGroup - 1) / kGroup); }

int ceilDiv(int a, int b) { return (a + b - 1) / b; }

}  // namespace

struct VulkanHullGrid::Passes {
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  VkPipeline classify = VK_NULL_HANDLE, settle = VK_NULL_HANDLE, mark = VK_NULL_HANDLE,
             sample = VK_NULL_HANDLE, march = VK_NULL_HANDLE;
  // cameras, distances, sums, lists, counts, values, marks, the case
  // table, corners, cubes: grown, never shrunk.
  std::array<gpu::Buffer, kBuffers> buffers{};
  uint32_t case_stride = 0;
  uint64_t corner_capacity = 1 << 16;
  // The last carve's layout: what surface() reads back and marchAgain()
  // dispatches.
  Push march_push{};
  glm::ivec3 points{0};
  uint32_t voxel_list = 0, voxel_offset = 0, corner_list = 0, cube_list = 0;
};

std::shared_ptr<VulkanHullGrid> VulkanHullGrid::open(const std::string& device_selector) {
  return std::shared_ptr<VulkanHullGrid>(
      new VulkanHullGrid(std::make_unique<gpu::VulkanContext>(device_selector)));
}

VulkanHullGrid::VulkanHullGrid(std::unique_ptr<gpu::VulkanContext> owned) : VulkanHullGrid(*owned) {
  owned_context_ = std::move(owned);
}

VulkanHullGrid::VulkanHullGrid(gpu::VulkanContext& context)
    : context_(context), passes_(std::make_unique<Passes>()) {
  VkDevice d = context_.device();
  std::array<VkDescriptorSetLayoutBinding, kBuffers> bindings{};
  for (uint32_t b = 0; b < kBuffers; ++b) {
    bindings[b].binding = b;
    bindings[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    bindings[b].descriptorCount = 1;
    bindings[b].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo set_info{};
  set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  set_info.bindingCount = kBuffers;
  set_info.pBindings = bindings.data();
  HOLOFUSE_VK_CHECK(vkCreateDescriptorSetLayout(d, &set_info, nullptr, &passes_->set_layout));
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push)};
  VkPipelineLayoutCreateInfo layout_info{};
  layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &passes_->set_layout;
  layout_info.pushConstantRangeCount = 1;
  layout_info.pPushConstantRanges = &range;
  HOLOFUSE_VK_CHECK(vkCreatePipelineLayout(d, &layout_info, nullptr, &passes_->layout));
  const gpu::DescriptorSet set = gpu::createDescriptorSet(
      d, passes_->set_layout, {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kBuffers}});
  passes_->pool = set.pool;
  passes_->set = set.set;
  auto create = [&](const uint32_t* code, size_t bytes) {
    return context_.createComputePipeline(code, bytes, passes_->layout);
  };
  passes_->classify = create(k_hull_classify_comp_spv, sizeof(k_hull_classify_comp_spv));
  passes_->settle = create(k_hull_settle_comp_spv, sizeof(k_hull_settle_comp_spv));
  passes_->mark = create(k_hull_mark_comp_spv, sizeof(k_hull_mark_comp_spv));
  passes_->sample = create(k_hull_sample_comp_spv, sizeof(k_hull_sample_comp_spv));
  passes_->march = create(k_hull_march_comp_spv, sizeof(k_hull_march_comp_spv));
  // geometry's case table: per configuration its corner count, then its
  // triangles' cube edges.
  const auto& table = marchingCubesCaseTable();
  size_t widest = 0;
  for (const auto& triangles : table) widest = std::max(widest, triangles.size());
  passes_->case_stride = static_cast<uint32_t>(widest + 1);
  gpu::Buffer& cases = passes_->buffers[kCaseTable];
  cases = context_.createBuffer(4 * table.size() * passes_->case_stride,
                                VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  uint32_t* words = static_cast<uint32_t*>(cases.mapped);
  for (size_t config = 0; config < table.size(); ++config) {
    uint32_t* row = words + config * passes_->case_stride;
    row[0] = static_cast<uint32_t>(table[config].size());
    for (size_t k = 0; k < table[config].size(); ++k)
      row[1 + k] = static_cast<uint32_t>(table[config][k]);
  }
}

VulkanHullGrid::~VulkanHullGrid() {
  context_.waitForSubmitted();
  VkDevice d = context_.device();
  for (VkPipeline p :
       {passes_->classify, passes_->settle, passes_->mark, passes_->sample, passes_->march})
    vkDestroyPipeline(d, p, nullptr);
  for (gpu::Buffer& b : passes_->buffers) context_.destroy(b);
  vkDestroyDescriptorPool(d, passes_->pool, nullptr);
  vkDestroyPipelineLayout(d, passes_->layout, nullptr);
  vkDestroyDescriptorSetLayout(d, passes_->set_layout, nullptr);
}

size_t VulkanHullGrid::cpuFallbacks() const { return cpu_fallbacks_; }

size_t VulkanHullGrid::remarches() const { return remarches_; }

namespace {

bool deviceHolds(const glm::ivec3& n) {
  const uint64_t points = static_cast<uint64_t>(n.x) * n.y * n.z;
  const uint64_t voxels =
      static_cast<uint64_t>(std::max(n.x - 1, 0)) * std::max(n.y - 1, 0) * std::max(n.z - 1, 0);
  return n.x < kPacked && n.y < kPacked && n.z < kPacked && voxels > 0 &&
         groupsFor(voxels) <= kMaxGroups && groupsFor(points) <= kMaxGroups;
}

}  // namespace

void VulkanHullGrid::growBuffers(const std::array<VkDeviceSize, kBuffers>& bytes) {
  bool grown = false;
  for (uint32_t b = 0; b < kBuffers; ++b) {
    gpu::Buffer& buffer = passes_->buffers[b];
    if (buffer.buffer != VK_NULL_HANDLE && buffer.size >= bytes[b]) continue;
    context_.destroy(buffer);
    // Room to grow: the region changes a little from frame to frame.
    buffer =
        context_.createBuffer(bytes[b] + bytes[b] / 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                                           VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                                           VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
    grown = true;
  }
  if (!grown) return;
  std::array<VkDescriptorBufferInfo, kBuffers> infos{};
  std::array<VkWriteDescriptorSet, kBuffers> writes{};
  for (uint32_t b = 0; b < kBuffers; ++b) {
    infos[b] = {passes_->buffers[b].buffer, 0, VK_WHOLE_SIZE};
    writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[b].dstSet = passes_->set;
    writes[b].dstBinding = b;
    writes[b].descriptorCount = 1;
    writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[b].pBufferInfo = &infos[b];
  }
  vkUpdateDescriptorSets(context_.device(), kBuffers, writes.data(), 0, nullptr);
}

// The cubes marched again into buffers with room (the carve's lists and
// grid are still on the device): every frame's surface comes from the
// device, so its bytes do not depend on which frame came first.
void VulkanHullGrid::marchAgain() {
  std::array<VkDeviceSize, kBuffers> bytes{};
  for (uint32_t b = 0; b < kBuffers; ++b) bytes[b] = passes_->buffers[b].size;
  bytes[kCorners] = 16 * passes_->corner_capacity;
  bytes[kCubes] = 16 * (passes_->corner_capacity / 3 + 1);
  growBuffers(bytes);
  auto* counts = static_cast<uint32_t*>(passes_->buffers[4].mapped);
  counts[4 * passes_->corner_list + 3] = 0;
  counts[4 * passes_->cube_list + 3] = 0;
  Push push = passes_->march_push;
  push.march[1] = static_cast<uint32_t>(passes_->corner_capacity);
  context_.submitAndWait([&](VkCommandBuffer cmd) {
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, passes_->layout, 0, 1,
                            &passes_->set, 0, nullptr);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, passes_->march);
    vkCmdPushConstants(cmd, passes_->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    vkCmdDispatchIndirect(cmd, passes_->buffers[4].buffer, VkDeviceSize{16} * push.list_in[0]);
    gpu::shaderWritesToHost(cmd);
  });
}

// The lock is held for the device's work only, never around oneTBB's:
// a thread waiting for a parallel loop runs other work meanwhile, such as
// another group's carve, which would then wait for the lock its own
// thread holds.
ScalarGrid VulkanHullGrid::fill(const HullGridInput& input, HullStats& stats) {
  if (!deviceHolds(input.points)) {
    ++cpu_fallbacks_;
    return fillHullGrid(input, stats);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  carve(input, stats, false);
  return readGrid(input);
}

ScalarGrid VulkanHullGrid::readGrid(const HullGridInput& input) const {
  ScalarGrid grid;
  grid.nx = input.points.x;
  grid.ny = input.points.y;
  grid.nz = input.points.z;
  grid.origin = input.origin;
  grid.spacing = input.spacing;
  grid.values.resize(static_cast<size_t>(grid.nx) * grid.ny * grid.nz);
  std::memcpy(grid.values.data(), passes_->buffers[5].mapped, 4 * grid.values.size());
  return grid;
}

Mesh VulkanHullGrid::surface(const HullGridInput& input, HullStats& stats) {
  if (!deviceHolds(input.points)) {
    ++cpu_fallbacks_;
    return surfaceOfGrid(fillHullGrid(input, stats));
  }
  ScalarGrid grid;  // the dense grid, for marching cubes on the host after the lock
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (input.levels > 0) {
      if (!carve(input, stats, true)) {
        ++remarches_;
        marchAgain();
      }
      return readSurface();
    }
    // The dense grid has no list of cubes to march.
    carve(input, stats, false);
    grid = readGrid(input);
  }
  return surfaceOfGrid(std::move(grid));
}

bool VulkanHullGrid::carve(const HullGridInput& input, HullStats& stats, bool surface) {
  const glm::ivec3 n = input.points;
  const uint64_t points = static_cast<uint64_t>(n.x) * n.y * n.z;
  const uint64_t voxels =
      static_cast<uint64_t>(std::max(n.x - 1, 0)) * std::max(n.y - 1, 0) * std::max(n.z - 1, 0);
  const std::vector<HullView>& views = *input.views;
  const int levels = std::max(input.levels, 0);
  // Lists: k = 0 the top cells (2^levels voxels a side), k = levels - l
  // those of 2^l, k = levels the voxels, then the settled cells (two words
  // each) and the points to sample.
  const uint32_t voxel_list = static_cast<uint32_t>(levels), settled_list = voxel_list + 1,
                 sampled_list = voxel_list + 2, corner_list = voxel_list + 3,
                 cube_list = voxel_list + 4;
  std::vector<uint32_t> offsets(sampled_list + 1, 0);
  uint64_t words = 0, settled_capacity = 0;
  for (int k = 0; k < levels; ++k) {
    const int size = 1 << (levels - k);
    const uint64_t cells = static_cast<uint64_t>(ceilDiv(n.x - 1, size)) * ceilDiv(n.y - 1, size) *
                           ceilDiv(n.z - 1, size);
    offsets[k] = static_cast<uint32_t>(words);
    words += cells;
    settled_capacity += cells;
  }
  offsets[voxel_list] = static_cast<uint32_t>(words);
  words += voxels;
  offsets[settled_list] = static_cast<uint32_t>(words);
  words += 2 * settled_capacity;
  offsets[sampled_list] = static_cast<uint32_t>(words);
  words += levels > 0 ? points : 0;

  std::vector<GpuCamera> cameras(views.size());
  uint64_t distance_words = 0, sum_words = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    const Camera& c = views[i].camera;
    GpuCamera& g = cameras[i];
    for (int r = 0; r < 3; ++r) {
      // glm is column-major: rotation[col][row].
      for (int col = 0; col < 3; ++col) g.rows[r][col] = static_cast<float>(c.rotation[col][r]);
      g.rows[r][3] = static_cast<float>(c.translation[r]);
    }
    const double lens[5] = {c.distortion.size() > 0 ? c.distortion[0] : 0,
                            c.distortion.size() > 1 ? c.distortion[1] : 0,
                            c.distortion.size() > 2 ? c.distortion[2] : 0,
                            c.distortion.size() > 3 ? c.distortion[3] : 0,
                            c.distortion.size() > 4 ? c.distortion[4] : 0};
    const float intrinsics[4] = {static_cast<float>(c.fx), static_cast<float>(c.fy),
                                 static_cast<float>(c.cx), static_cast<float>(c.cy)};
    std::memcpy(g.intrinsics, intrinsics, sizeof(intrinsics));
    g.image[0] = static_cast<float>(c.skew);
    g.image[1] = static_cast<float>(c.width);
    g.image[2] = static_cast<float>(c.height);
    g.image[3] = c.distortion.empty() ? 0.0f : 1.0f;
    for (int k = 0; k < 4; ++k) g.lens[k] = static_cast<float>(lens[k]);
    g.lens_k3[0] = static_cast<float>(lens[4]);
    g.offsets[0] = static_cast<uint32_t>(distance_words);
    g.offsets[1] = static_cast<uint32_t>(sum_words);
    distance_words += input.distances[i].size();
    if (levels > 0) sum_words += input.foreground_sums[i].size();
  }

  // Every buffer large enough, and the descriptors pointing at them.
  const std::array<VkDeviceSize, kBuffers> bytes = {
      sizeof(GpuCamera) * std::max<size_t>(views.size(), 1),
      4 * std::max<uint64_t>(distance_words, 1),
      4 * std::max<uint64_t>(sum_words, 1),
      4 * std::max<uint64_t>(words, 1),
      16 * (cube_list + 1),
      4 * points,
      4 * points,
      passes_->buffers[kCaseTable].size,
      16 * passes_->corner_capacity,
      16 * (passes_->corner_capacity / 3 + 1)};
  growBuffers(bytes);
  auto mapped = [&](uint32_t b) { return passes_->buffers[b].mapped; };
  std::memcpy(mapped(0), cameras.data(), sizeof(GpuCamera) * cameras.size());
  for (size_t i = 0; i < views.size(); ++i) {
    std::memcpy(static_cast<float*>(mapped(1)) + cameras[i].offsets[0], input.distances[i].data(),
                4 * input.distances[i].size());
    if (levels > 0) {
      std::memcpy(static_cast<uint32_t*>(mapped(2)) + cameras[i].offsets[1],
                  input.foreground_sums[i].data(), 4 * input.foreground_sums[i].size());
    }
  }
  // The top cells, written here; every other list starts empty.
  uint32_t* counts = static_cast<uint32_t*>(mapped(4));
  for (uint32_t k = 0; k <= cube_list; ++k) {
    counts[4 * k] = 0;
    counts[4 * k + 1] = counts[4 * k + 2] = 1;
    counts[4 * k + 3] = 0;
  }
  // The settling pass runs one plane of each cell along y.
  counts[4 * settled_list + 1] = (1u << levels) + 1;
  uint32_t tops = 0;
  if (levels > 0) {
    const int top = 1 << levels;
    uint32_t* lists = static_cast<uint32_t*>(mapped(3));
    for (int z = 0; z < n.z - 1; z += top) {
      for (int y = 0; y < n.y - 1; y += top) {
        for (int x = 0; x < n.x - 1; x += top) {
          lists[offsets[0] + tops++] = static_cast<uint32_t>(x) | (static_cast<uint32_t>(y) << 10) |
                                       (static_cast<uint32_t>(z) << 20);
        }
      }
    }
    counts[3] = tops;
    counts[0] = groupsFor(tops);
  }

  Push push{};
  push.origin[0] = static_cast<float>(input.origin.x);
  push.origin[1] = static_cast<float>(input.origin.y);
  push.origin[2] = static_cast<float>(input.origin.z);
  push.origin[3] = static_cast<float>(input.spacing);
  push.points[0] = n.x;
  push.points[1] = n.y;
  push.points[2] = n.z;
  push.points[3] = static_cast<int32_t>(views.size());
  context_.submitAndWait([&](VkCommandBuffer cmd) {
    auto barrier = [&](VkPipelineStageFlags src, VkAccessFlags src_access) {
      VkMemoryBarrier b{};
      b.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
      b.srcAccessMask = src_access;
      b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                        VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
      vkCmdPipelineBarrier(
          cmd, src, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT, 0,
          1, &b, 0, nullptr, 0, nullptr);
    };
    auto run = [&](VkPipeline pipeline) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
      vkCmdPushConstants(cmd, passes_->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    };
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, passes_->layout, 0, 1,
                            &passes_->set, 0, nullptr);
    vkCmdFillBuffer(cmd, passes_->buffers[5].buffer, 0, 4 * points, 0);
    vkCmdFillBuffer(cmd, passes_->buffers[6].buffer, 0, 4 * points, 0);
    barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
    VkBuffer count_buffer = passes_->buffers[4].buffer;
    push.list_out[2] = settled_list;
    push.list_out[3] = offsets[settled_list];
    for (uint32_t k = 0; k < voxel_list; ++k) {
      push.list_in[0] = k;
      push.list_in[1] = offsets[k];
      push.list_in[2] = 1u << (levels - static_cast<int>(k));
      push.list_out[0] = k + 1;
      push.list_out[1] = offsets[k + 1];
      run(passes_->classify);
      if (k == 0) {
        vkCmdDispatch(cmd, groupsFor(tops), 1, 1);
      } else {
        vkCmdDispatchIndirect(cmd, count_buffer, VkDeviceSize{16} * k);
      }
      barrier(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT);
    }
    if (levels > 0) {
      run(passes_->settle);
      vkCmdDispatchIndirect(cmd, count_buffer, VkDeviceSize{16} * settled_list);
      // The marks append to the lists the settling pass read.
      barrier(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
      push.list_in[0] = voxel_list;
      push.list_in[1] = offsets[voxel_list];
      push.list_out[0] = sampled_list;
      push.list_out[1] = offsets[sampled_list];
      run(passes_->mark);
      vkCmdDispatchIndirect(cmd, count_buffer, VkDeviceSize{16} * voxel_list);
      barrier(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT);
    }
    push.list_in[3] = (levels > 0 ? 0u : 1u) | (surface ? 2u : 0u);  // dense: every point; closed
    push.list_out[0] = sampled_list;
    push.list_out[1] = offsets[sampled_list];
    run(passes_->sample);
    if (levels > 0) {
      vkCmdDispatchIndirect(cmd, count_buffer, VkDeviceSize{16} * sampled_list);
    } else {
      vkCmdDispatch(cmd, groupsFor(points), 1, 1);
    }
    if (surface && levels > 0) {
      barrier(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT);
      push.list_in[0] = voxel_list;
      push.list_in[1] = offsets[voxel_list];
      push.march[0] = corner_list;
      push.march[1] = static_cast<uint32_t>(passes_->corner_capacity);
      push.march[2] = cube_list;
      push.march[3] = passes_->case_stride;
      passes_->march_push = push;
      run(passes_->march);
      vkCmdDispatchIndirect(cmd, count_buffer, VkDeviceSize{16} * voxel_list);
    }
    gpu::shaderWritesToHost(cmd);
  });
  for (uint32_t k = 0; k < voxel_list; ++k) stats.cells_classified += counts[4 * k + 3];
  stats.points_sampled += levels > 0 ? counts[4 * sampled_list + 3] : points;
  passes_->corner_list = corner_list;
  passes_->cube_list = cube_list;
  const uint64_t corners = counts[4 * corner_list + 3];
  if (!surface || corners <= passes_->corner_capacity) return true;
  // More triangles than the corners' buffer held: marched again into a
  // buffer with room (marchAgain), which the next frames keep.
  passes_->corner_capacity = corners + corners / 4;
  return false;
}

Mesh VulkanHullGrid::readSurface() const {
  const uint32_t* counts = static_cast<const uint32_t*>(passes_->buffers[4].mapped);
  const auto* cubes = static_cast<const glm::uvec4*>(passes_->buffers[kCubes].mapped);
  const auto* corners = static_cast<const glm::uvec4*>(passes_->buffers[kCorners].mapped);
  // The cubes in grid order, each its triangles in the case table's order,
  // and the vertices numbered as they are first reached: the numbering of
  // a scan of the whole grid (geometry's marchingCubes).
  std::vector<glm::uvec4> order(cubes, cubes + counts[4 * passes_->cube_list + 3]);
  std::sort(order.begin(), order.end(),
            [](const glm::uvec4& a, const glm::uvec4& b) { return a.x < b.x; });
  Mesh mesh;
  std::unordered_map<uint32_t, uint32_t> vertex_of_edge;
  vertex_of_edge.reserve(counts[4 * passes_->corner_list + 3] / 2);
  for (const glm::uvec4& cube : order) {
    for (uint32_t k = cube.y; k < cube.y + cube.z; ++k) {
      const glm::uvec4& corner = corners[k];
      const auto [it, added] =
          vertex_of_edge.emplace(corner.x, static_cast<uint32_t>(mesh.positions.size()));
      if (added) {
        mesh.positions.emplace_back(glm::uintBitsToFloat(corner.y), glm::uintBitsToFloat(corner.z),
                                    glm::uintBitsToFloat(corner.w));
        mesh.vertex_keys.push_back(corner.x);
      }
      mesh.indices.push_back(it->second);
    }
  }
  computeVertexNormals(mesh);
  return mesh;
}

HullSurface deviceSurface(std::shared_ptr<VulkanHullGrid> grid) {
  return [grid = std::move(grid)](const HullGridInput& input, HullStats& stats) {
    return grid->surface(input, stats);
  };
}

}  // namespace holofuse::hull
