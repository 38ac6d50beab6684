// What the renderer's files share (renderer.cpp, renderer_setup.cpp,
// renderer_inputs.cpp, renderer_fields.cpp): the uniform block's layout,
// buffer usages and the Vulkan objects every pass is made of.
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <glm/glm.hpp>

#include "render_client/vulkan_context.h"
#include "shaders/config.h"

namespace holofuse::render {

// std140 mirror of the Blend uniform block in shaders/cameras.glsl.
struct CameraGpu {
  glm::mat4 world_to_clip;
  glm::vec4 center;
  glm::vec4 size;
  glm::ivec4 flags;
};
struct BlendUniforms {
  CameraGpu cameras[HOLOFUSE_MAX_CAMERAS];
  glm::ivec4 counts;
  glm::vec4 params;
  glm::vec4 hole_color;
  glm::vec4 user_eye;
  glm::vec4 temporal;  // x: lambda of this frame, y: half holding the previous field
  glm::vec4
      fragment_test;  // relative and absolute depth tolerance, feather width, 1 for the field modes
  glm::vec4 view_weight;  // x: beta
};
static_assert(sizeof(CameraGpu) == 112);
static_assert(offsetof(BlendUniforms, counts) == 112 * HOLOFUSE_MAX_CAMERAS);
static_assert(offsetof(BlendUniforms, params) == 112 * HOLOFUSE_MAX_CAMERAS + 16);
static_assert(offsetof(BlendUniforms, fragment_test) == 112 * HOLOFUSE_MAX_CAMERAS + 80);
static_assert(sizeof(BlendUniforms) == 112 * HOLOFUSE_MAX_CAMERAS + 112);

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

VkPipeline createPipeline(VulkanContext& ctx, VkRenderPass pass, VkPipelineLayout layout,
                          const uint32_t* vs, size_t vs_bytes, const uint32_t* fs, size_t fs_bytes);

void setViewport(VkCommandBuffer cmd, uint32_t w, uint32_t h);

}  // namespace holofuse::render
