// What the renderer's files share (renderer.cpp, renderer_setup.cpp,
// renderer_inputs.cpp, renderer_fields.cpp): the uniform block's layout,
// buffer usages and the Vulkan objects every pass is made of.
#pragma once

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstddef>
#include <glm/glm.hpp>

#include "gpu/vulkan_context.h"
#include "protocol/messages.h"
#include "shaders/config.h"

namespace holofuse::render {

// Mirror of CameraGpu in shaders/cameras.glsl (one entry of the cameras'
// storage buffer; std430 and std140 lay it out alike).
struct CameraGpu {
  glm::mat4 world_to_clip;
  glm::vec4 center;
  glm::vec4 size;
  glm::ivec4 flags;
};
// std140 mirror of the Blend uniform block in shaders/cameras.glsl.
struct BlendUniforms {
  glm::ivec4 counts;
  glm::vec4 params;
  glm::vec4 hole_color;
  glm::vec4 user_eye;
  glm::vec4 temporal;  // x: lambda of this frame, y: half holding the previous field
  glm::vec4
      fragment_test;  // relative and absolute depth tolerance, feather width, 1 for the field modes
  glm::vec4 view_weight;  // x: beta; y, z, w: the overlay's camera slot, distance half, scale
  // x: best views per vertex, y: words of a per-camera bit set, z: 1 if the
  // per-fragment blends weigh candidates, w: entries per triangle of the
  // merged best views (triangleViewSlots)
  glm::ivec4 views;
  glm::vec4 relight;         // x: 1 to relight (eqs. 6 to 8)
  glm::mat4 world_to_view;   // the user camera's rotation, to view space (x right, y up)
  glm::vec4 light_probe[9];  // the probe's coefficients, rgb
};
static_assert(sizeof(CameraGpu) == 112);
static_assert(HOLOFUSE_MAX_CAMERAS == protocol::kMaxCameras, "one camera limit for the loop");
static_assert(offsetof(BlendUniforms, params) == 16);
static_assert(offsetof(BlendUniforms, fragment_test) == 80);
static_assert(offsetof(BlendUniforms, views) == 112);
static_assert(offsetof(BlendUniforms, relight) == 128);
static_assert(offsetof(BlendUniforms, world_to_view) == 144);
static_assert(sizeof(BlendUniforms) == 352);

// Words of a per-camera bit set (config.h): 32 cameras a word.
inline uint32_t cameraWords(size_t cameras) {
  return static_cast<uint32_t>(std::max<size_t>(cameras, 1) + 31) / 32;
}

// Entries per triangle of the merged best views (config.h's
// TRIANGLE_VIEWS): its corners keep at most 3 K cameras, and no more
// cameras than there are.
inline int triangleViewSlots(int best_views, size_t cameras) {
  return static_cast<int>(std::min<size_t>(3 * static_cast<size_t>(best_views), cameras));
}

inline constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
// Geodesic worklists are cleared by transfer commands every mesh.
inline constexpr VkBufferUsageFlags kWorklistUsage =
    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
// The vertices are read as a storage buffer by every stage (shaders/vertices.glsl).
inline constexpr VkBufferUsageFlags kVertexUsage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
inline constexpr VkBufferUsageFlags kIndexUsage =
    VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
inline constexpr uint32_t kImageMipLevels = 4;  // the vote searches at most this many

VkRenderPass createPass(VkDevice device, VkFormat color_format, VkImageLayout color_final);

VkFramebuffer createFramebuffer(VkDevice device, VkRenderPass pass, VkImageView color,
                                VkImageView depth, uint32_t w, uint32_t h);

// fragment_mode and overlay: the fragment stage's constants 0 and 1
// (blend.frag.glsl's kBlendMode and kOverlay). fs null: the depth
// pre-pass (nearest depth, no colour); else the blend, which shades only
// where its depth equals the pre-pass's.
VkPipeline createPipeline(VulkanContext& ctx, VkRenderPass pass, VkPipelineLayout layout,
                          const uint32_t* vs, size_t vs_bytes, const uint32_t* fs, size_t fs_bytes,
                          int32_t fragment_mode, int32_t overlay = 0);

void setViewport(VkCommandBuffer cmd, uint32_t w, uint32_t h);

}  // namespace holofuse::render
