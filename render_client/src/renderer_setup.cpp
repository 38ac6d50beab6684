// The renderer's GPU objects: render passes, pipelines, per-view images,
// field buffers and descriptors, made once or when the views outgrow them.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <glm/gtc/packing.hpp>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "render_client/reference/texture_fields.h"
#include "render_client/renderer.h"
#include "render_client/temporal_carry.h"
#include "renderer_gpu.h"
#include "shaders/blend_frag_spv.h"
#include "shaders/blend_vert_spv.h"
#include "stylise_pass.h"

namespace holofuse::render {

VkRenderPass createPass(VkDevice device, VkFormat color_format, VkImageLayout color_final) {
  std::array<VkAttachmentDescription, 2> attachments{};
  attachments[0].format = color_format;
  attachments[0].samples = VK_SAMPLE_COUNT_1_BIT;
  attachments[0].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  attachments[0].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  attachments[0].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  attachments[0].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  attachments[0].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  attachments[0].finalLayout = color_final;
  attachments[1] = attachments[0];
  attachments[1].format = kDepthFormat;
  attachments[1].storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  attachments[1].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  VkAttachmentReference color_ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkAttachmentReference depth_ref{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass{};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = 1;
  subpass.pColorAttachments = &color_ref;
  subpass.pDepthStencilAttachment = &depth_ref;
  // Make earlier writes (uploads, previous passes) visible, and this pass's
  // colour visible to later sampling or copies.
  std::array<VkSubpassDependency, 2> deps{};
  deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
  deps[0].dstSubpass = 0;
  deps[0].srcStageMask = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
  deps[0].dstStageMask = VK_PIPELINE_STAGE_ALL_GRAPHICS_BIT;
  deps[0].srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
  deps[0].dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  deps[1].srcSubpass = 0;
  deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
  deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[1].dstStageMask = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
  deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  deps[1].dstAccessMask = VK_ACCESS_MEMORY_READ_BIT;
  VkRenderPassCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
  info.attachmentCount = static_cast<uint32_t>(attachments.size());
  info.pAttachments = attachments.data();
  info.subpassCount = 1;
  info.pSubpasses = &subpass;
  info.dependencyCount = static_cast<uint32_t>(deps.size());
  info.pDependencies = deps.data();
  VkRenderPass pass;
  HOLOFUSE_VK_CHECK(vkCreateRenderPass(device, &info, nullptr, &pass));
  return pass;
}

VkFramebuffer createFramebuffer(VkDevice device, VkRenderPass pass, VkImageView color,
                                VkImageView depth, uint32_t w, uint32_t h) {
  VkImageView views[2] = {color, depth};
  VkFramebufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
  info.renderPass = pass;
  info.attachmentCount = 2;
  info.pAttachments = views;
  info.width = w;
  info.height = h;
  info.layers = 1;
  VkFramebuffer fb;
  HOLOFUSE_VK_CHECK(vkCreateFramebuffer(device, &info, nullptr, &fb));
  return fb;
}

VkPipeline createPipeline(VulkanContext& ctx, VkRenderPass pass, VkPipelineLayout layout,
                          const uint32_t* vs, size_t vs_bytes, const uint32_t* fs, size_t fs_bytes,
                          int32_t fragment_mode, int32_t overlay) {
  // No fragment stage: the depth pre-pass, which writes the nearest depth
  // and no colour.
  const bool depth_only = fs == nullptr;
  VkShaderModule vert = ctx.createShader(vs, vs_bytes);
  VkShaderModule frag = depth_only ? VK_NULL_HANDLE : ctx.createShader(fs, fs_bytes);
  std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
  stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vert;
  stages[0].pName = "main";
  stages[1] = stages[0];
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = frag;
  const int32_t constants[2] = {fragment_mode, overlay};
  const VkSpecializationMapEntry entries[2] = {{0, 0, sizeof(int32_t)},
                                               {1, sizeof(int32_t), sizeof(int32_t)}};
  VkSpecializationInfo specialization{};
  specialization.mapEntryCount = 2;
  specialization.pMapEntries = entries;
  specialization.dataSize = sizeof(constants);
  specialization.pData = constants;
  stages[1].pSpecializationInfo = &specialization;
  // No vertex attributes: the vertex stage reads the vertices from the
  // storage buffer the compute passes share (shaders/vertices.glsl), in
  // full or half precision.
  VkPipelineVertexInputStateCreateInfo input{};
  input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
  VkPipelineInputAssemblyStateCreateInfo assembly{};
  assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport{};
  viewport.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster{};
  raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = VK_CULL_MODE_NONE;  // the hull may be open where it meets the valid region
  raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample{};
  multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo depth{};
  depth.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
  depth.depthTestEnable = VK_TRUE;
  // The blend shades only the fragment the pre-pass found nearest: with
  // no culling (the hull may be open) and no order among the triangles,
  // the blend otherwise shaded every layer the depth test let through
  // (bench_texture_fields on lavapipe: normal's view 20 ms, 5-7 ms with
  // either face culled).
  depth.depthWriteEnable = depth_only ? VK_TRUE : VK_FALSE;
  depth.depthCompareOp = depth_only ? VK_COMPARE_OP_LESS : VK_COMPARE_OP_EQUAL;
  VkPipelineColorBlendAttachmentState blend_attachment{};
  blend_attachment.colorWriteMask = depth_only
                                        ? 0
                                        : VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                              VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  VkPipelineColorBlendStateCreateInfo blend{};
  blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
  blend.attachmentCount = 1;
  blend.pAttachments = &blend_attachment;
  std::array<VkDynamicState, 2> dynamic_states = {VK_DYNAMIC_STATE_VIEWPORT,
                                                  VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{};
  dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
  dynamic.dynamicStateCount = static_cast<uint32_t>(dynamic_states.size());
  dynamic.pDynamicStates = dynamic_states.data();
  VkGraphicsPipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
  info.stageCount = depth_only ? 1 : static_cast<uint32_t>(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = &input;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = layout;
  info.renderPass = pass;
  VkPipeline pipeline;
  HOLOFUSE_VK_CHECK(
      vkCreateGraphicsPipelines(ctx.device(), VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
  vkDestroyShaderModule(ctx.device(), vert, nullptr);
  if (!depth_only) vkDestroyShaderModule(ctx.device(), frag, nullptr);
  return pipeline;
}

void setViewport(VkCommandBuffer cmd, uint32_t w, uint32_t h) {
  VkViewport viewport{0.0f, 0.0f, static_cast<float>(w), static_cast<float>(h), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, {w, h}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

VkBufferUsageFlags Renderer::usageOf(const Buffer& buffer) const {
  if (&buffer == &worklist_counts_) return kWorklistUsage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;
  const bool filled = &buffer == &worklist_ || &buffer == &seams_;
  return filled ? kWorklistUsage : VkBufferUsageFlags{VK_BUFFER_USAGE_STORAGE_BUFFER_BIT};
}

Renderer::Renderer(VulkanContext& context, uint32_t width, uint32_t height)
    : ctx_(context), width_(width), height_(height) {
  createPipelines();
  color_ = ctx_.createImage(width, height, 1, VK_FORMAT_R8G8B8A8_UNORM,
                            VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                                VK_IMAGE_USAGE_STORAGE_BIT,  // read by the stylisation passes
                            VK_IMAGE_ASPECT_COLOR_BIT, false);
  depth_ =
      ctx_.createImage(width, height, 1, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                       VK_IMAGE_ASPECT_DEPTH_BIT, false);
  output_framebuffer_ =
      createFramebuffer(ctx_.device(), blend_pass_, color_.view, depth_.view, width, height);
  readback_ = ctx_.createBuffer(VkDeviceSize{width} * height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  uniforms_ = ctx_.createBuffer(sizeof(BlendUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  camera_buffer_ = ctx_.createBuffer(sizeof(CameraGpu) * HOLOFUSE_MAX_CAMERAS,
                                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  // Every binding of the shared set must hold a buffer before the first
  // descriptor write: start small, grow with the mesh.
  vertex_buffer_ = ctx_.createBuffer(24, kVertexUsage);
  index_buffer_ = ctx_.createBuffer(4, kIndexUsage);
  for (Buffer* b :
       {&discontinuities_, &sights_, &trusted_, &weights_, &seams_, &adjacency_, &rings_,
        &distances_, &temporal_, &carry_, &fans_, &worklist_, &worklist_counts_, &sight_bits_,
        &best_views_, &candidates_, &triangle_views_}) {
    *b = ctx_.createBuffer(16, usageOf(*b));
  }
  visible_counts_ =
      ctx_.createBuffer(4 * HOLOFUSE_MAX_CAMERAS,
                        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  corner_uvs_ = ctx_.createBuffer(24, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  layer_cameras_ = ctx_.createBuffer(16 * kNoLayerCamera, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  // A layer to bind until the first layers arrive.
  layers_ = ctx_.createImage(1, 1, 1, VK_FORMAT_R8G8B8A8_UNORM,
                             VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                             VK_IMAGE_ASPECT_COLOR_BIT, true, 1);
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    transitionImage(cmd, layers_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, 0, VK_ACCESS_SHADER_READ_BIT,
                    VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT);
  });
}

Renderer::~Renderer() {
  VkDevice d = ctx_.device();
  vkDeviceWaitIdle(d);
  destroyViewResources();
  ctx_.destroy(vertex_buffer_);
  ctx_.destroy(index_buffer_);
  vkDestroyFramebuffer(d, output_framebuffer_, nullptr);
  ctx_.destroy(color_);
  ctx_.destroy(depth_);
  ctx_.destroy(readback_);
  ctx_.destroy(uniforms_);
  ctx_.destroy(camera_buffer_);
  ctx_.destroy(corner_uvs_);
  ctx_.destroy(layer_cameras_);
  ctx_.destroy(layers_);
  for (Buffer* b :
       {&discontinuities_, &sights_, &trusted_, &weights_, &seams_, &visible_counts_, &adjacency_,
        &rings_, &distances_, &temporal_, &carry_, &fans_, &worklist_, &worklist_counts_,
        &sight_bits_, &best_views_, &candidates_, &triangle_views_}) {
    ctx_.destroy(*b);
  }
  field_passes_pipelines_.reset();
  stylise_pass_.reset();
  for (VkPipeline pipeline : blend_pipelines_) vkDestroyPipeline(d, pipeline, nullptr);
  vkDestroyPipeline(d, depth_prepass_, nullptr);
  vkDestroyPipelineLayout(d, blend_layout_, nullptr);
  vkDestroyRenderPass(d, blend_pass_, nullptr);
  vkDestroyDescriptorPool(d, descriptor_pool_, nullptr);
  vkDestroyDescriptorSetLayout(d, set_layout_, nullptr);
  vkDestroySampler(d, linear_sampler_, nullptr);
}

VkPipeline Renderer::blendPipeline(BlendMode mode, Overlay overlay) {
  VkPipeline& pipeline =
      blend_pipelines_.at(kOverlayCount * static_cast<size_t>(mode) + static_cast<size_t>(overlay));
  if (pipeline == VK_NULL_HANDLE) {
    pipeline = createPipeline(ctx_, blend_pass_, blend_layout_, k_blend_vert_spv,
                              sizeof(k_blend_vert_spv), k_blend_frag_spv, sizeof(k_blend_frag_spv),
                              static_cast<int32_t>(mode), static_cast<int32_t>(overlay));
  }
  return pipeline;
}

void Renderer::createPipelines() {
  VkDevice d = ctx_.device();
  blend_pass_ = createPass(d, VK_FORMAT_R8G8B8A8_UNORM, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);

  // One set for the blend and every compute pass (bindings in config.h).
  std::array<VkDescriptorSetLayoutBinding, HOLOFUSE_BINDING_COUNT> bindings{};
  for (uint32_t b = 0; b < bindings.size(); ++b) {
    bindings[b] = {b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr};
  }
  bindings[HOLOFUSE_BINDING_BLEND].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  bindings[HOLOFUSE_BINDING_IMAGES].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  bindings[HOLOFUSE_BINDING_FEATHERS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  bindings[HOLOFUSE_BINDING_LAYERS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  VkDescriptorSetLayoutCreateInfo set_info{};
  set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  set_info.bindingCount = static_cast<uint32_t>(bindings.size());
  set_info.pBindings = bindings.data();
  HOLOFUSE_VK_CHECK(vkCreateDescriptorSetLayout(d, &set_info, nullptr, &set_layout_));

  std::array<VkPushConstantRange, 2> push = {
      VkPushConstantRange{VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(glm::mat4)},
      VkPushConstantRange{VK_SHADER_STAGE_COMPUTE_BIT, HOLOFUSE_COMPUTE_PUSH_OFFSET,
                          sizeof(ComputePush)}};
  VkPipelineLayoutCreateInfo layout_info{};
  layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout_info.pPushConstantRanges = push.data();
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &set_layout_;
  layout_info.pushConstantRangeCount = static_cast<uint32_t>(push.size());
  HOLOFUSE_VK_CHECK(vkCreatePipelineLayout(d, &layout_info, nullptr, &blend_layout_));
  field_passes_pipelines_ = std::make_unique<TextureFieldPasses>(ctx_, blend_layout_);
  depth_prepass_ = createPipeline(ctx_, blend_pass_, blend_layout_, k_blend_vert_spv,
                                  sizeof(k_blend_vert_spv), nullptr, 0, 0);

  const gpu::DescriptorSet set =
      gpu::createDescriptorSet(d, set_layout_,
                               {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 3},
                                {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, HOLOFUSE_BINDING_COUNT - 4}});
  descriptor_pool_ = set.pool;
  descriptor_set_ = set.set;

  VkSamplerCreateInfo sampler{};
  sampler.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  sampler.magFilter = VK_FILTER_LINEAR;
  sampler.minFilter = VK_FILTER_LINEAR;
  sampler.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sampler.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sampler.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sampler.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;  // levels are picked explicitly (textureLod)
  sampler.maxLod = VK_LOD_CLAMP_NONE;
  HOLOFUSE_VK_CHECK(vkCreateSampler(d, &sampler, nullptr, &linear_sampler_));
}

void Renderer::destroyViewResources() {
  ctx_.destroy(images_);
  ctx_.destroy(feathers_);
  ctx_.destroy(depth_maps_);
  ctx_.destroy(staging_);
}

void Renderer::ensureViewResources(uint32_t w, uint32_t h, uint32_t count) {
  if (images_.image != VK_NULL_HANDLE && images_.width == w && images_.height == h &&
      images_.layers == count)
    return;
  vkDeviceWaitIdle(ctx_.device());
  destroyViewResources();
  // Mips for the majority vote's coarse-to-fine search.
  uint32_t levels = 1;
  while (levels < kImageMipLevels && (std::min(w, h) >> levels) > 0) ++levels;
  images_ = ctx_.createImage(w, h, count, VK_FORMAT_R8G8B8A8_UNORM,
                             VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                 VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                             VK_IMAGE_ASPECT_COLOR_BIT, true, levels);
  feathers_ = ctx_.createImage(w, h, count, VK_FORMAT_R8_UNORM,
                               VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                               VK_IMAGE_ASPECT_COLOR_BIT, true, 1);
  depth_maps_ =
      ctx_.createBuffer(VkDeviceSize{w} * h * count * 4,
                        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  // RGBA of every layer, then every layer's feather map.
  staging_ = ctx_.createBuffer(VkDeviceSize{w} * h * 5 * count, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  writeDescriptors();
  // A frame drawn before any mesh reads maps of "no surface".
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    field_passes_pipelines_->recordDepthMaps(cmd, descriptor_set_, 0, count, w, h,
                                             depth_maps_.buffer);
  });
}

bool Renderer::ensureFieldBuffers(const FieldParameters& parameters) {
  // Everything per camera is sized by the cameras present, bit sets by
  // their words.
  const VkDeviceSize vertices = std::max(vertex_count_, 1u);
  const VkDeviceSize cameras = std::max(images_.layers, 1u);
  const VkDeviceSize words = cameraWords(images_.layers);
  const VkDeviceSize per_vertex = vertices * cameras * 4;
  const VkDeviceSize best_views = std::clamp(parameters.best_views, 1, HOLOFUSE_MAX_BEST_VIEWS);
  const VkDeviceSize best = vertices * best_views * 8;
  const VkDeviceSize triangles = std::max(triangle_count_, 1u);
  const VkDeviceSize triangle_best =
      triangles * std::max(triangleViewSlots(static_cast<int>(best_views), images_.layers), 1) * 16;
  bool changed = false;
  const VkDeviceSize rule_bits = triangles * HOLOFUSE_SEAM_SETS * words * 4;
  for (auto [buffer, size] : {std::pair{&discontinuities_, vertices * words * 4},
                              {&sight_bits_, vertices * HOLOFUSE_SIGHT_BIT_SETS * words * 4},
                              {&sights_, per_vertex},
                              {&trusted_, per_vertex},
                              {&weights_, per_vertex},
                              {&best_views_, best},
                              {&candidates_, best},
                              {&triangle_views_, triangle_best},
                              {&seams_, rule_bits},
                              {&rings_, 2 * per_vertex},
                              {&distances_, 2 * per_vertex},
                              {&adjacency_, VkDeviceSize{adjacency_data_.size() * 4 + 4}},
                              {&fans_, VkDeviceSize{fan_data_.size() * sizeof(GeodesicFan) + 32}},
                              {&worklist_, 2 * HOLOFUSE_WORKLIST_SLOTS * per_vertex},
                              {&worklist_counts_, VkDeviceSize{16} * worklistPasses(parameters)}}) {
    if (buffer->size >= size) continue;
    ctx_.destroy(*buffer);
    *buffer = ctx_.createBuffer(size * 3 / 2, usageOf(*buffer));
    changed = true;
  }
  if (changed) writeDescriptors();
  std::memcpy(adjacency_.mapped, adjacency_data_.data(), adjacency_data_.size() * 4);
  std::memcpy(fans_.mapped, fan_data_.data(), fan_data_.size() * sizeof(GeodesicFan));
  return changed;
}

void Renderer::writeDescriptors() {
  vkDeviceWaitIdle(ctx_.device());
  VkDescriptorBufferInfo ubo{uniforms_.buffer, 0, sizeof(BlendUniforms)};
  VkDescriptorImageInfo image_info{linear_sampler_, images_.view,
                                   VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo feather_info{linear_sampler_, feathers_.view,
                                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo layers_info{linear_sampler_, layers_.view,
                                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  // Storage buffers in binding order from HOLOFUSE_BINDING_VERTICES to
  // the sight bits.
  std::array<VkDescriptorBufferInfo, HOLOFUSE_BINDING_SIGHT_BITS + 1 - HOLOFUSE_BINDING_VERTICES>
      storage = {VkDescriptorBufferInfo{vertex_buffer_.buffer, 0, VK_WHOLE_SIZE},
                 {discontinuities_.buffer, 0, VK_WHOLE_SIZE},
                 {sights_.buffer, 0, VK_WHOLE_SIZE},
                 {trusted_.buffer, 0, VK_WHOLE_SIZE},
                 {weights_.buffer, 0, VK_WHOLE_SIZE},
                 {index_buffer_.buffer, 0, VK_WHOLE_SIZE},
                 {seams_.buffer, 0, VK_WHOLE_SIZE},
                 {visible_counts_.buffer, 0, VK_WHOLE_SIZE},
                 {adjacency_.buffer, 0, VK_WHOLE_SIZE},
                 {rings_.buffer, 0, VK_WHOLE_SIZE},
                 {distances_.buffer, 0, VK_WHOLE_SIZE},
                 {temporal_.buffer, 0, VK_WHOLE_SIZE},
                 {carry_.buffer, 0, VK_WHOLE_SIZE},
                 {fans_.buffer, 0, VK_WHOLE_SIZE},
                 {worklist_.buffer, 0, VK_WHOLE_SIZE},
                 {worklist_counts_.buffer, 0, VK_WHOLE_SIZE},
                 {sight_bits_.buffer, 0, VK_WHOLE_SIZE}};
  std::array<VkWriteDescriptorSet, HOLOFUSE_BINDING_COUNT> writes{};
  for (uint32_t b = 0; b < writes.size(); ++b) {
    writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[b].dstSet = descriptor_set_;
    writes[b].dstBinding = b;
    writes[b].descriptorCount = 1;
    if (b >= HOLOFUSE_BINDING_VERTICES && b <= HOLOFUSE_BINDING_SIGHT_BITS) {
      writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[b].pBufferInfo = &storage[b - HOLOFUSE_BINDING_VERTICES];
    }
  }
  writes[HOLOFUSE_BINDING_BLEND].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  writes[HOLOFUSE_BINDING_BLEND].pBufferInfo = &ubo;
  // The storage buffers outside the run above, by binding.
  const std::array<std::pair<uint32_t, VkDescriptorBufferInfo>, 7> others = {
      std::pair{HOLOFUSE_BINDING_DEPTHS,
                VkDescriptorBufferInfo{depth_maps_.buffer, 0, VK_WHOLE_SIZE}},
      {HOLOFUSE_BINDING_CAMERAS, {camera_buffer_.buffer, 0, VK_WHOLE_SIZE}},
      {HOLOFUSE_BINDING_BEST_VIEWS, {best_views_.buffer, 0, VK_WHOLE_SIZE}},
      {HOLOFUSE_BINDING_CANDIDATES, {candidates_.buffer, 0, VK_WHOLE_SIZE}},
      {HOLOFUSE_BINDING_TRIANGLE_VIEWS, {triangle_views_.buffer, 0, VK_WHOLE_SIZE}},
      {HOLOFUSE_BINDING_CORNER_UVS, {corner_uvs_.buffer, 0, VK_WHOLE_SIZE}},
      {HOLOFUSE_BINDING_LAYER_CAMERAS, {layer_cameras_.buffer, 0, VK_WHOLE_SIZE}}};
  for (const auto& [binding, info] : others) {
    writes[binding].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[binding].pBufferInfo = &info;
  }
  writes[HOLOFUSE_BINDING_IMAGES].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[HOLOFUSE_BINDING_IMAGES].pImageInfo = &image_info;
  writes[HOLOFUSE_BINDING_FEATHERS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[HOLOFUSE_BINDING_FEATHERS].pImageInfo = &feather_info;
  writes[HOLOFUSE_BINDING_LAYERS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[HOLOFUSE_BINDING_LAYERS].pImageInfo = &layers_info;
  vkUpdateDescriptorSets(ctx_.device(), static_cast<uint32_t>(writes.size()), writes.data(), 0,
                         nullptr);
}

}  // namespace holofuse::render
