#include "stylise_pass.h"

#include <array>

#include "shaders/stipple_comp_spv.h"

namespace holofuse::render {

StylisePass::StylisePass(gpu::VulkanContext& context, uint32_t width, uint32_t height)
    : ctx_(context) {
  VkDevice d = ctx_.device();
  output_ = ctx_.createImage(width, height, 1, VK_FORMAT_R8G8B8A8_UNORM,
                             VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                             VK_IMAGE_ASPECT_COLOR_BIT, false);
  std::array<VkDescriptorSetLayoutBinding, 2> bindings{};
  for (uint32_t b = 0; b < bindings.size(); ++b)
    bindings[b] = {b, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo set_info{};
  set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  set_info.bindingCount = static_cast<uint32_t>(bindings.size());
  set_info.pBindings = bindings.data();
  HOLOFUSE_VK_CHECK(vkCreateDescriptorSetLayout(d, &set_info, nullptr, &set_layout_));
  const gpu::DescriptorSet set =
      gpu::createDescriptorSet(d, set_layout_, {{VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2}});
  pool_ = set.pool;
  set_ = set.set;
  VkPipelineLayoutCreateInfo layout_info{};
  layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &set_layout_;
  HOLOFUSE_VK_CHECK(vkCreatePipelineLayout(d, &layout_info, nullptr, &layout_));
  stipple_ = ctx_.createComputePipeline(k_stipple_comp_spv, sizeof(k_stipple_comp_spv), layout_);
}

StylisePass::~StylisePass() {
  VkDevice d = ctx_.device();
  vkDestroyPipeline(d, stipple_, nullptr);
  vkDestroyPipelineLayout(d, layout_, nullptr);
  vkDestroyDescriptorPool(d, pool_, nullptr);
  vkDestroyDescriptorSetLayout(d, set_layout_, nullptr);
  ctx_.destroy(output_);
}

const gpu::Image& StylisePass::recordStipple(VkCommandBuffer cmd, const gpu::Image& colour) {
  if (bound_source_ != colour.view) {
    const VkDescriptorImageInfo source{VK_NULL_HANDLE, colour.view, VK_IMAGE_LAYOUT_GENERAL};
    const VkDescriptorImageInfo target{VK_NULL_HANDLE, output_.view, VK_IMAGE_LAYOUT_GENERAL};
    std::array<VkWriteDescriptorSet, 2> writes{};
    for (uint32_t b = 0; b < writes.size(); ++b) {
      writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
      writes[b].dstSet = set_;
      writes[b].dstBinding = b;
      writes[b].descriptorCount = 1;
      writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
      writes[b].pImageInfo = b == 0 ? &source : &target;
    }
    vkUpdateDescriptorSets(ctx_.device(), static_cast<uint32_t>(writes.size()), writes.data(), 0,
                           nullptr);
    bound_source_ = colour.view;
  }
  constexpr VkImageAspectFlags kColour = VK_IMAGE_ASPECT_COLOR_BIT;
  // The blend's picture, read by the pass; the last copy out of the
  // output done with before it is written again.
  gpu::transitionImage(cmd, colour, kColour, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                       VK_IMAGE_LAYOUT_GENERAL, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                       VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                       VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
  gpu::transitionImage(cmd, output_, kColour, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL,
                       VK_ACCESS_TRANSFER_READ_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                       VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, stipple_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set_, 0, nullptr);
  vkCmdDispatch(cmd, (output_.width + 7) / 8, (output_.height + 7) / 8, 1);
  gpu::transitionImage(cmd, output_, kColour, VK_IMAGE_LAYOUT_GENERAL,
                       VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_ACCESS_SHADER_WRITE_BIT,
                       VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                       VK_PIPELINE_STAGE_TRANSFER_BIT);
  return output_;
}

}  // namespace holofuse::render
