// The stylisation passes over the final picture on the device (paper 000,
// section 6): a compute pass reads the blend's colour image and writes its
// own, which the picture is then copied from. CPU reference:
// render_client/reference/stylise.h.
#pragma once

#include <cstdint>

#include "gpu/vulkan_context.h"

namespace holofuse::render {

class StylisePass {
 public:
  // For pictures of width x height (the renderer's output size).
  StylisePass(gpu::VulkanContext& context, uint32_t width, uint32_t height);
  ~StylisePass();
  StylisePass(const StylisePass&) = delete;
  StylisePass& operator=(const StylisePass&) = delete;

  // Records the stippling of `colour` (left by the blend's render pass in
  // TRANSFER_SRC_OPTIMAL; it must have been made with STORAGE usage);
  // returns the stylised image, in TRANSFER_SRC_OPTIMAL for the copy out.
  const gpu::Image& recordStipple(VkCommandBuffer cmd, const gpu::Image& colour);

 private:
  gpu::VulkanContext& ctx_;
  gpu::Image output_;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline stipple_ = VK_NULL_HANDLE;
  VkImageView bound_source_ = VK_NULL_HANDLE;  // the colour view the set holds
};

}  // namespace holofuse::render
