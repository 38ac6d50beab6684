#include "render_client/renderer.h"

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <glm/gtc/packing.hpp>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include "render_client/reference/texture_fields.h"
#include "render_client/temporal_carry.h"
#include "shaders/blend_frag_spv.h"
#include "shaders/blend_vert_spv.h"

namespace holofuse::render {
namespace {

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

constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
// Geodesic worklists are cleared by transfer commands every mesh.
constexpr VkBufferUsageFlags kWorklistUsage =
    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
// The vertices are read as a storage buffer by every stage (shaders/vertices.glsl).
constexpr VkBufferUsageFlags kVertexUsage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
constexpr VkBufferUsageFlags kIndexUsage =
    VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
constexpr uint32_t kImageMipLevels = 4;  // the vote searches at most this many

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
                          const uint32_t* vs, size_t vs_bytes, const uint32_t* fs,
                          size_t fs_bytes) {
  VkShaderModule vert = ctx.createShader(vs, vs_bytes);
  VkShaderModule frag = ctx.createShader(fs, fs_bytes);
  std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
  stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vert;
  stages[0].pName = "main";
  stages[1] = stages[0];
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = frag;
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
  depth.depthWriteEnable = VK_TRUE;
  depth.depthCompareOp = VK_COMPARE_OP_LESS;
  VkPipelineColorBlendAttachmentState blend_attachment{};
  blend_attachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
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
  info.stageCount = static_cast<uint32_t>(stages.size());
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
  vkDestroyShaderModule(ctx.device(), frag, nullptr);
  return pipeline;
}

void setViewport(VkCommandBuffer cmd, uint32_t w, uint32_t h) {
  VkViewport viewport{0.0f, 0.0f, static_cast<float>(w), static_cast<float>(h), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, {w, h}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

}  // namespace

glm::mat4 worldToClip(const Camera& c, double n, double f) {
  const double w = c.width, h = c.height;
  glm::dmat4 projection(0.0);  // glm: projection[column][row]
  projection[0][0] = 2 * c.fx / w;
  projection[1][0] = 2 * c.skew / w;
  projection[2][0] = 2 * c.cx / w - 1;
  projection[1][1] = 2 * c.fy / h;
  projection[2][1] = 2 * c.cy / h - 1;
  projection[2][2] = f / (f - n);
  projection[3][2] = -f * n / (f - n);
  projection[2][3] = 1;
  glm::dmat4 view(c.rotation);
  view[3] = glm::dvec4(c.translation, 1.0);
  return glm::mat4(projection * view);
}

std::pair<double, double> depthRange(const Camera& camera, const glm::dvec3& lo,
                                     const glm::dvec3& hi) {
  double z_min = std::numeric_limits<double>::max(), z_max = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const glm::dvec3 p((corner & 1) ? hi.x : lo.x, (corner & 2) ? hi.y : lo.y,
                       (corner & 4) ? hi.z : lo.z);
    const double z = camera.toCamera(p).z;
    if (!std::isfinite(z)) continue;
    z_min = std::min(z_min, z);
    z_max = std::max(z_max, z);
  }
  if (!(z_max > 0)) return {0.05, 100.0};  // the box is behind the camera: nothing to keep
  // A camera inside the box sees from just in front of its centre.
  const double far_plane = 2.0 * z_max;
  const double near_plane = std::max(z_min > 0 ? 0.5 * z_min : 1e-4 * z_max, 1e-6 * far_plane);
  return {near_plane, far_plane};
}

// Storage buffers the field passes clear with vkCmdFillBuffer (worklists,
// seams) also need to be transfer destinations.
Status checkMesh(const Mesh& mesh, bool half_precision) {
  if (!half_precision) return Status::ok();
  // A half holds magnitudes up to 65504: past that a position would become
  // infinite.
  constexpr float kHalfMax = 65504.0f;
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::vec3& p = mesh.positions[v];
    if (!(std::abs(p.x) <= kHalfMax && std::abs(p.y) <= kHalfMax && std::abs(p.z) <= kHalfMax)) {
      char text[160];
      std::snprintf(text, sizeof(text),
                    "vertex %zu at (%g, %g, %g) is outside half precision's range (|x| <= 65504)",
                    v, p.x, p.y, p.z);
      return Status(StatusCode::kMalformed, text);
    }
  }
  return Status::ok();
}

Status checkViews(const std::vector<ViewImages>& views) {
  if (views.size() > HOLOFUSE_MAX_CAMERAS) {
    return Status(StatusCode::kMalformed, std::to_string(views.size()) + " cameras, more than " +
                                              std::to_string(HOLOFUSE_MAX_CAMERAS));
  }
  if (views.empty()) return Status::ok();
  const uint32_t w = views[0].camera.width, h = views[0].camera.height;
  for (const auto& view : views) {
    if (view.camera.width != w || view.camera.height != h || view.color.width != w ||
        view.color.height != h || view.mask.width != w || view.mask.height != h ||
        view.color.channels != 3 || view.mask.channels != 1) {
      return Status(StatusCode::kMalformed, "camera " + std::to_string(view.camera.id) +
                                                " images do not match " + std::to_string(w) + "x" +
                                                std::to_string(h));
    }
    const bool feather_sent = !view.feather.pixels.empty();
    if (feather_sent &&
        (view.feather.width != w || view.feather.height != h || view.feather.channels != 1)) {
      return Status(StatusCode::kMalformed, "camera " + std::to_string(view.camera.id) +
                                                " feather map is not " + std::to_string(w) + "x" +
                                                std::to_string(h) + " grey");
    }
  }
  return Status::ok();
}

Status checkRenderable(size_t mesh_vertices, const BlendSettings& settings) {
  if (settings.mode != BlendMode::kMontage4D) return Status::ok();
  // The geodesic passes pack an entry's ring and nearest seam vertex in
  // one word (shaders/config.h).
  const int rings = settings.fields.geodesic_rings;
  if (rings < 0 || rings > kMaxGeodesicRings) {
    return Status(StatusCode::kMalformed, "geodesic rings k = " + std::to_string(rings) +
                                              " is outside 0.." +
                                              std::to_string(kMaxGeodesicRings));
  }
  if (mesh_vertices > HOLOFUSE_MAX_FIELD_VERTICES) {
    return Status(StatusCode::kMalformed, "a mesh of " + std::to_string(mesh_vertices) +
                                              " vertices is over montage4d's " +
                                              std::to_string(HOLOFUSE_MAX_FIELD_VERTICES));
  }
  return Status::ok();
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
                            VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                            VK_IMAGE_ASPECT_COLOR_BIT, false);
  depth_ =
      ctx_.createImage(width, height, 1, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                       VK_IMAGE_ASPECT_DEPTH_BIT, false);
  output_framebuffer_ =
      createFramebuffer(ctx_.device(), blend_pass_, color_.view, depth_.view, width, height);
  readback_ = ctx_.createBuffer(VkDeviceSize{width} * height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  uniforms_ = ctx_.createBuffer(sizeof(BlendUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  // Every binding of the shared set must hold a buffer before the first
  // descriptor write: start small, grow with the mesh.
  vertex_buffer_ = ctx_.createBuffer(24, kVertexUsage);
  index_buffer_ = ctx_.createBuffer(4, kIndexUsage);
  for (Buffer* b :
       {&discontinuities_, &sights_, &trusted_, &weights_, &seams_, &adjacency_, &rings_,
        &distances_, &temporal_, &carry_, &fans_, &worklist_, &worklist_counts_, &sight_bits_}) {
    *b = ctx_.createBuffer(16, usageOf(*b));
  }
  visible_counts_ =
      ctx_.createBuffer(4 * HOLOFUSE_MAX_CAMERAS,
                        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT);
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
  for (Buffer* b : {&discontinuities_, &sights_, &trusted_, &weights_, &seams_, &visible_counts_,
                    &adjacency_, &rings_, &distances_, &temporal_, &carry_, &fans_, &worklist_,
                    &worklist_counts_, &sight_bits_}) {
    ctx_.destroy(*b);
  }
  field_passes_pipelines_.reset();
  vkDestroyPipeline(d, blend_pipeline_, nullptr);
  vkDestroyPipelineLayout(d, blend_layout_, nullptr);
  vkDestroyRenderPass(d, blend_pass_, nullptr);
  vkDestroyDescriptorPool(d, descriptor_pool_, nullptr);
  vkDestroyDescriptorSetLayout(d, set_layout_, nullptr);
  vkDestroySampler(d, linear_sampler_, nullptr);
}

void Renderer::createPipelines() {
  VkDevice d = ctx_.device();
  blend_pass_ = createPass(d, VK_FORMAT_R8G8B8A8_UNORM, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);

  // One set for the blend and every compute pass (bindings in config.h).
  std::array<VkDescriptorSetLayoutBinding, HOLOFUSE_BINDING_COUNT> bindings{};
  for (uint32_t b = 0; b < bindings.size(); ++b) {
    bindings[b] = {b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr};
  }
  bindings[HOLOFUSE_BINDING_CAMERAS].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  bindings[HOLOFUSE_BINDING_IMAGES].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  bindings[HOLOFUSE_BINDING_FEATHERS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
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

  blend_pipeline_ =
      createPipeline(ctx_, blend_pass_, blend_layout_, k_blend_vert_spv, sizeof(k_blend_vert_spv),
                     k_blend_frag_spv, sizeof(k_blend_frag_spv));

  std::array<VkDescriptorPoolSize, 3> sizes = {
      VkDescriptorPoolSize{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
      VkDescriptorPoolSize{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2},
      VkDescriptorPoolSize{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, HOLOFUSE_BINDING_COUNT - 3}};
  VkDescriptorPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  pool_info.maxSets = 1;
  pool_info.poolSizeCount = static_cast<uint32_t>(sizes.size());
  pool_info.pPoolSizes = sizes.data();
  HOLOFUSE_VK_CHECK(vkCreateDescriptorPool(d, &pool_info, nullptr, &descriptor_pool_));
  VkDescriptorSetAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  alloc.descriptorPool = descriptor_pool_;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &set_layout_;
  HOLOFUSE_VK_CHECK(vkAllocateDescriptorSets(d, &alloc, &descriptor_set_));

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

glm::vec3 halfPrecision(const glm::vec3& v) {
  auto round = [](float x) {
    const float h = glm::unpackHalf2x16(glm::packHalf2x16(glm::vec2(x, 0.0f))).x;
    return std::abs(h) < kSmallestNormalHalf ? 0.0f : h;
  };
  return glm::vec3(round(v.x), round(v.y), round(v.z));
}

void Renderer::setMesh(const Mesh& mesh) {
  if (!half_vertices_) return uploadMesh(mesh, false);
  // Refused before anything changes, so the previous mesh stays.
  if (const Status usable = checkMesh(mesh, true); !usable.isOk())
    throw std::invalid_argument(usable.message());
  // Everything the CPU derives from the mesh (unfolded triangles, bounds,
  // the temporal carry) comes from the rounded values too, so that the
  // passes see one mesh: the one half precision stores.
  Mesh rounded = mesh;
  for (auto& p : rounded.positions) p = halfPrecision(p);
  for (auto& n : rounded.normals) n = halfPrecision(n);
  uploadMesh(rounded, true);
}

void Renderer::uploadMesh(const Mesh& mesh, bool half) {
  const VkDeviceSize vertex_bytes =
      std::max<VkDeviceSize>(mesh.positions.size() * (half ? 12 : 24), 24);
  const VkDeviceSize index_bytes = std::max<VkDeviceSize>(mesh.indices.size() * 4, 4);
  if (vertex_buffer_.size < vertex_bytes) {
    vkDeviceWaitIdle(ctx_.device());
    ctx_.destroy(vertex_buffer_);
    vertex_buffer_ = ctx_.createBuffer(vertex_bytes * 3 / 2, kVertexUsage);
    if (images_.image != VK_NULL_HANDLE) writeDescriptors();
  }
  if (index_buffer_.size < index_bytes) {
    vkDeviceWaitIdle(ctx_.device());
    ctx_.destroy(index_buffer_);
    index_buffer_ = ctx_.createBuffer(index_bytes * 3 / 2, kIndexUsage);
    if (images_.image != VK_NULL_HANDLE) writeDescriptors();
  }
  // Full precision: position and normal as six floats. Half: the same six
  // values as halves, two to a word (shaders/vertices.glsl unpacks them).
  // The flag follows the buffer's contents, once they are written.
  uploaded_half_ = half;
  auto* words = static_cast<uint32_t*>(vertex_buffer_.mapped);
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const glm::vec3 n = i < mesh.normals.size() ? mesh.normals[i] : glm::vec3(0.0f);
    const float values[6] = {
        mesh.positions[i].x, mesh.positions[i].y, mesh.positions[i].z, n.x, n.y, n.z};
    if (uploaded_half_) {
      for (size_t k = 0; k < 3; ++k)
        words[i * 3 + k] = glm::packHalf2x16(glm::vec2(values[2 * k], values[2 * k + 1]));
    } else {
      std::memcpy(words + i * 6, values, sizeof(values));
    }
  }
  std::memcpy(index_buffer_.mapped, mesh.indices.data(), mesh.indices.size() * 4);
  index_count_ = static_cast<uint32_t>(mesh.indices.size());
  const Bounds bounds = meshBounds(mesh);
  bounds_min_ = glm::dvec3(bounds.min);
  bounds_max_ = glm::dvec3(bounds.max);
  vertex_count_ = static_cast<uint32_t>(mesh.positions.size());
  triangle_count_ = static_cast<uint32_t>(mesh.indices.size() / 3);
  // Montage4D carries its temporal field from the previous surface.
  previous_surface_ = std::move(current_surface_);
  current_surface_ = Mesh{};
  current_surface_.positions = mesh.positions;
  current_surface_.vertex_keys = mesh.vertex_keys;
  carry_pending_ = true;
  mean_edge_ = meanEdgeLength(mesh);
  // Vertex -> triangles in CSR form: vertex_count + 1 offsets, then the
  // triangle ids, for the passes that gather over a vertex's triangles.
  adjacency_data_.assign(vertex_count_ + 1 + mesh.indices.size(), 0);
  for (uint32_t index : mesh.indices) ++adjacency_data_[index + 1];
  for (uint32_t v = 0; v < vertex_count_; ++v) adjacency_data_[v + 1] += adjacency_data_[v];
  std::vector<uint32_t> fill(adjacency_data_.begin(), adjacency_data_.begin() + vertex_count_);
  for (uint32_t t = 0; t < triangle_count_; ++t) {
    for (int k = 0; k < 3; ++k)
      adjacency_data_[vertex_count_ + 1 + fill[mesh.indices[3 * t + k]]++] = t;
  }
  fan_data_ = geodesicFans(mesh, adjacency_data_);
  depth_maps_stale_ = true;
  fields_stale_ = true;
}

void Renderer::setViews(const std::vector<ViewImages>& views) {
  if (views.empty()) {
    cameras_.clear();
    active_.clear();
    subject_seen_.clear();
    view_cameras_.clear();
    return;
  }
  if (const Status usable = checkViews(views); !usable.isOk())
    throw std::invalid_argument(usable.message());
  const uint32_t w = views[0].camera.width, h = views[0].camera.height;
  subject_seen_.clear();
  view_cameras_.clear();
  for (const auto& view : views) {
    view_cameras_.push_back(view.camera);
    subject_seen_.push_back(std::any_of(view.mask.pixels.begin(), view.mask.pixels.end(),
                                        [](uint8_t m) { return m != 0; }));
  }
  const bool any_seen =
      std::find(subject_seen_.begin(), subject_seen_.end(), true) != subject_seen_.end();
  std::vector<uint32_t> active;
  for (uint32_t i = 0; i < views.size(); ++i) {
    if (subject_seen_[i] || !any_seen) active.push_back(i);
  }
  std::vector<uint32_t> ids;
  for (uint32_t i : active) ids.push_back(views[i].camera.id);
  remapTemporal(ids);
  active_ = std::move(active);
  ensureViewResources(w, h, static_cast<uint32_t>(active_.size()));
  cameras_.clear();
  auto* dst = static_cast<uint8_t*>(staging_.mapped);
  const size_t pixels = static_cast<size_t>(w) * h;
  for (size_t layer = 0; layer < active_.size(); ++layer) {
    const ViewImages& view = views[active_[layer]];
    cameras_.push_back(view.camera);
    const uint8_t* rgb = view.color.pixels.data();
    const uint8_t* mask = view.mask.pixels.data();
    uint8_t* out = dst + layer * pixels * 4;
    for (size_t p = 0; p < pixels; ++p) {
      out[p * 4 + 0] = rgb[p * 3 + 0];
      out[p * 4 + 1] = rgb[p * 3 + 1];
      out[p * 4 + 2] = rgb[p * 3 + 2];
      out[p * 4 + 3] = mask[p];
    }
    // Without a feather map (a server of protocol 1.1 sends none) the
    // silhouette is one plateau: every pixel of the mask as far from the
    // edge as a map holds, so the feather weight is the same everywhere.
    uint8_t* feather = dst + active_.size() * pixels * 4 + layer * pixels;
    if (view.feather.pixels.empty()) {
      for (size_t p = 0; p < pixels; ++p) feather[p] = mask[p] != 0 ? 255 : 0;
    } else {
      std::memcpy(feather, view.feather.pixels.data(), pixels);
    }
  }
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    transitionImage(cmd, images_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                    VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0,
                               static_cast<uint32_t>(active_.size())};
    region.imageExtent = {w, h, 1};
    vkCmdCopyBufferToImage(cmd, staging_.buffer, images_.image,
                           VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    generateMips(cmd);
    transitionImage(cmd, feathers_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                    VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    region.bufferOffset = VkDeviceSize{pixels} * 4 * active_.size();
    vkCmdCopyBufferToImage(cmd, staging_.buffer, feathers_.image,
                           VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    transitionImage(cmd, feathers_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                    VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                    VK_PIPELINE_STAGE_ALL_COMMANDS_BIT);
  });
  // Depth maps depend on the camera poses as well as the mesh.
  depth_maps_stale_ = true;
  fields_stale_ = true;
}

void Renderer::generateMips(VkCommandBuffer cmd) {
  // Each level is the 2x2 box average of the one below: a linear blit of
  // exactly half the size samples the middle of every 2x2 block.
  int32_t w = static_cast<int32_t>(images_.width), h = static_cast<int32_t>(images_.height);
  for (uint32_t level = 1; level < images_.mip_levels; ++level) {
    transitionImage(cmd, images_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                    VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                    VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                    VK_PIPELINE_STAGE_TRANSFER_BIT, level - 1, 1);
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, images_.layers};
    blit.srcOffsets[1] = {w, h, 1};
    w = std::max(1, w / 2);
    h = std::max(1, h / 2);
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, images_.layers};
    blit.dstOffsets[1] = {w, h, 1};
    vkCmdBlitImage(cmd, images_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, images_.image,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
    transitionImage(cmd, images_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_READ_BIT,
                    VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                    VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, level - 1, 1);
  }
  transitionImage(cmd, images_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                  VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, images_.mip_levels - 1, 1);
}

void Renderer::ensureFieldBuffers(const FieldParameters& parameters) {
  const VkDeviceSize per_vertex =
      VkDeviceSize{std::max(vertex_count_, 1u)} * std::max(images_.layers, 1u) * 4;
  const VkDeviceSize weights = VkDeviceSize{std::max(vertex_count_, 1u)} * HOLOFUSE_MAX_CAMERAS * 4;
  bool changed = false;
  const VkDeviceSize one_per_vertex = VkDeviceSize{std::max(vertex_count_, 1u)} * 4;
  const VkDeviceSize rule_bits =
      VkDeviceSize{std::max(triangle_count_, 1u)} * 8;  // seams: a uvec2 per triangle
  for (auto [buffer, size] : {std::pair{&discontinuities_, one_per_vertex},
                              {&sight_bits_, 2 * one_per_vertex},
                              {&sights_, per_vertex},
                              {&trusted_, per_vertex},
                              {&weights_, weights},
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
}

void Renderer::writeDescriptors() {
  vkDeviceWaitIdle(ctx_.device());
  VkDescriptorBufferInfo ubo{uniforms_.buffer, 0, sizeof(BlendUniforms)};
  VkDescriptorImageInfo image_info{linear_sampler_, images_.view,
                                   VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo feather_info{linear_sampler_, feathers_.view,
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
  writes[HOLOFUSE_BINDING_CAMERAS].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  writes[HOLOFUSE_BINDING_CAMERAS].pBufferInfo = &ubo;
  VkDescriptorBufferInfo depth_maps{depth_maps_.buffer, 0, VK_WHOLE_SIZE};
  writes[HOLOFUSE_BINDING_DEPTHS].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  writes[HOLOFUSE_BINDING_DEPTHS].pBufferInfo = &depth_maps;
  writes[HOLOFUSE_BINDING_IMAGES].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[HOLOFUSE_BINDING_IMAGES].pImageInfo = &image_info;
  writes[HOLOFUSE_BINDING_FEATHERS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[HOLOFUSE_BINDING_FEATHERS].pImageInfo = &feather_info;
  vkUpdateDescriptorSets(ctx_.device(), static_cast<uint32_t>(writes.size()), writes.data(), 0,
                         nullptr);
}

FieldSnapshot Renderer::readFields() const {
  FieldSnapshot s = readActiveFields();
  if (active_.size() == subject_seen_.size()) return s;
  // Back to the views' indexing: a camera left out for its empty mask sees
  // every vertex on its background (or behind it, or outside its image),
  // trusts none, has no seams, no distances, no weight.
  const size_t views = subject_seen_.size(), vertices = s.vertex_count,
               triangles = s.triangle_count;
  const size_t pixels = size_t{images_.width} * images_.height;
  FieldSnapshot out = s;
  out.camera_count = static_cast<uint32_t>(views);
  out.sights.assign(views * vertices, 0);
  out.trusted.assign(views * vertices, 0);
  out.discontinuities.assign(views * vertices, 0);
  out.depth_maps.assign(views * pixels, HOLOFUSE_NO_DEPTH);
  out.seams.assign(views * triangles, 0);
  out.visible_counts.assign(views, 0);
  out.distances.assign(s.distances.empty() ? 0 : views * vertices, HOLOFUSE_FAR);
  out.weights.assign(s.weights.size(), 0.0f);
  std::vector<bool> left_out(views, true);
  for (size_t j = 0; j < active_.size(); ++j) {
    const size_t i = active_[j];
    left_out[i] = false;
    std::copy_n(s.sights.begin() + j * vertices, vertices, out.sights.begin() + i * vertices);
    std::copy_n(s.trusted.begin() + j * vertices, vertices, out.trusted.begin() + i * vertices);
    std::copy_n(s.discontinuities.begin() + j * vertices, vertices,
                out.discontinuities.begin() + i * vertices);
    if (s.depth_maps.size() >= (j + 1) * pixels) {
      std::copy_n(s.depth_maps.begin() + j * pixels, pixels, out.depth_maps.begin() + i * pixels);
    }
    std::copy_n(s.seams.begin() + j * triangles, triangles, out.seams.begin() + i * triangles);
    out.visible_counts[i] = s.visible_counts[j];
    if (!s.distances.empty())
      std::copy_n(s.distances.begin() + j * vertices, vertices,
                  out.distances.begin() + i * vertices);
    for (size_t v = 0; v < vertices && !s.weights.empty(); ++v) {
      out.weights[v * HOLOFUSE_MAX_CAMERAS + i] = s.weights[v * HOLOFUSE_MAX_CAMERAS + j];
    }
  }
  for (size_t i = 0; i < views; ++i) {
    if (!left_out[i]) continue;
    for (size_t v = 0; v < vertices; ++v) {
      const glm::dvec3 p(current_surface_.positions[v]);
      const auto pixel = view_cameras_[i].project(p);
      const bool inside = pixel && pixel->x >= 0 && pixel->y >= 0 &&
                          pixel->x < view_cameras_[i].width && pixel->y < view_cameras_[i].height;
      out.sights[i * vertices + v] = !pixel   ? HOLOFUSE_SIGHT_BEHIND
                                     : inside ? HOLOFUSE_SIGHT_BACKGROUND
                                              : HOLOFUSE_SIGHT_OUTSIDE_IMAGE;
    }
  }
  return out;
}

void Renderer::remapTemporal(const std::vector<uint32_t>& camera_ids) {
  // The slots' cameras until now: cameras_ still holds them.
  std::vector<int> old_slot(camera_ids.size(), -1);
  bool same = camera_ids.size() == cameras_.size();
  for (size_t j = 0; j < camera_ids.size(); ++j) {
    for (size_t k = 0; k < cameras_.size(); ++k) {
      if (cameras_[k].id == camera_ids[j]) old_slot[j] = static_cast<int>(k);
    }
    same = same && old_slot[j] == static_cast<int>(j);
  }
  if (temporal_stride_ == 0 || same) return;
  // The latest field (the half a render reads as the previous one) follows
  // each camera, by its id, to its new slot: a camera that left the arrays
  // or a pod missing from a bundle moves the others. A camera that joins
  // starts from 0, as one that comes back into view does (eq. 5 gated by
  // visibility).
  auto* field = static_cast<float*>(temporal_.mapped) + size_t{temporal_half_} * temporal_stride_;
  float slots[HOLOFUSE_MAX_CAMERAS];
  for (size_t v = 0; v < temporal_stride_ / HOLOFUSE_MAX_CAMERAS; ++v) {
    float* vertex = field + v * HOLOFUSE_MAX_CAMERAS;
    std::copy_n(vertex, HOLOFUSE_MAX_CAMERAS, slots);
    std::fill_n(vertex, HOLOFUSE_MAX_CAMERAS, 0.0f);
    for (size_t j = 0; j < camera_ids.size(); ++j) {
      if (old_slot[j] >= 0) vertex[j] = slots[old_slot[j]];
    }
  }
}

FieldSnapshot Renderer::readActiveFields() const {
  FieldSnapshot s;
  s.vertex_count = vertex_count_;
  s.camera_count = static_cast<uint32_t>(cameras_.size());
  const size_t per_vertex = size_t{s.vertex_count} * s.camera_count;
  auto copy = [](const Buffer& b, auto& out, size_t n) {
    using T = typename std::remove_reference_t<decltype(out)>::value_type;
    out.resize(n);
    if (n * sizeof(T) <= b.size) std::memcpy(out.data(), b.mapped, n * sizeof(T));
  };
  copy(sights_, s.sights, per_vertex);
  copy(trusted_, s.trusted, per_vertex);
  std::vector<uint32_t> camera_bits;  // per vertex, bit i for camera i
  copy(discontinuities_, camera_bits, s.vertex_count);
  s.discontinuities.assign(per_vertex, 0);
  for (size_t i = 0; i < s.camera_count; ++i) {
    for (size_t v = 0; v < camera_bits.size(); ++v)
      s.discontinuities[i * s.vertex_count + v] = (camera_bits[v] >> i) & 1u;
  }
  copy(depth_maps_, s.depth_maps, size_t{images_.width} * images_.height * images_.layers);
  copy(weights_, s.weights, size_t{s.vertex_count} * HOLOFUSE_MAX_CAMERAS);
  s.triangle_count = triangle_count_;
  s.geodesic_scale = static_cast<float>(geodesicScale(field_parameters_));
  // Per triangle, a bit per camera for each rule (compute_common.glsl):
  // back to [camera][triangle] SeamRule bits.
  std::vector<uint32_t> rule_bits;
  copy(seams_, rule_bits, size_t{triangle_count_} * 2);
  s.seams.assign(size_t{triangle_count_} * s.camera_count, 0);
  for (size_t t = 0; 2 * t + 1 < rule_bits.size(); ++t) {
    const uint32_t occlusion = rule_bits[2 * t] & 0xffffu, vote = rule_bits[2 * t] >> 16,
                   field_of_view = rule_bits[2 * t + 1];
    for (size_t i = 0; i < s.camera_count; ++i) {
      s.seams[i * triangle_count_ + t] = ((occlusion >> i) & 1u) * HOLOFUSE_SEAM_OCCLUSION |
                                         ((vote >> i) & 1u) * HOLOFUSE_SEAM_VOTE |
                                         ((field_of_view >> i) & 1u) * HOLOFUSE_SEAM_FIELD_OF_VIEW;
    }
  }
  copy(visible_counts_, s.visible_counts, s.camera_count);
  std::vector<float> both;
  copy(distances_, both, 2 * per_vertex);
  const size_t half = TextureFieldPasses::finalDistanceHalf(field_parameters_);
  if (both.size() == 2 * per_vertex)
    s.distances.assign(both.begin() + half * per_vertex, both.begin() + (half + 1) * per_vertex);
  return s;
}

void Renderer::prepareTemporal() {
  // Room for this mesh and the previous one in each half; growing keeps the
  // previous half's contents.
  const uint32_t needed =
      std::max<uint32_t>(
          1, std::max<uint32_t>(vertex_count_,
                                static_cast<uint32_t>(previous_surface_.vertexCount()))) *
      HOLOFUSE_MAX_CAMERAS;
  if (needed > temporal_stride_) {
    const uint32_t stride = needed * 3 / 2;
    Buffer grown =
        ctx_.createBuffer(VkDeviceSize{stride} * 2 * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    if (temporal_stride_ > 0) {
      std::memcpy(static_cast<float*>(grown.mapped) + temporal_half_ * stride,
                  static_cast<const float*>(temporal_.mapped) + temporal_half_ * temporal_stride_,
                  temporal_stride_ * 4);
    }
    vkDeviceWaitIdle(ctx_.device());
    ctx_.destroy(temporal_);
    temporal_ = grown;
    temporal_stride_ = stride;
    writeDescriptors();
  }
  if (carry_.size < VkDeviceSize{std::max(vertex_count_, 1u)} * 4) {
    vkDeviceWaitIdle(ctx_.device());
    ctx_.destroy(carry_);
    carry_ = ctx_.createBuffer(VkDeviceSize{std::max(vertex_count_, 1u)} * 4 * 3 / 2,
                               VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    writeDescriptors();
    carry_is_identity_ = false;
    carry_pending_ = true;
  }
  auto* carry = static_cast<int32_t*>(carry_.mapped);
  if (carry_pending_) {
    // A new mesh: follow vertices by key, else by the nearest previous
    // vertex within two mean edges, else start fresh.
    const CarryMap map = carryAcross(previous_surface_, current_surface_, 2.0 * mean_edge_);
    std::memcpy(carry, map.previous.data(), map.previous.size() * 4);
    carry_pending_ = false;
    carry_is_identity_ = false;
  } else if (!carry_is_identity_) {
    for (uint32_t v = 0; v < vertex_count_; ++v) carry[v] = static_cast<int32_t>(v);
    carry_is_identity_ = true;
  }
}

glm::mat4 Renderer::clipFor(const Camera& camera) const {
  const auto [near_plane, far_plane] = depthRange(camera, bounds_min_, bounds_max_);
  return worldToClip(camera, near_plane, far_plane);
}

void Renderer::drawMesh(VkCommandBuffer cmd) {
  if (index_count_ == 0) return;
  vkCmdBindIndexBuffer(cmd, index_buffer_.buffer, 0, VK_INDEX_TYPE_UINT32);
  vkCmdDrawIndexed(cmd, index_count_, 1, 0, 0, 0);
}

void Renderer::renderDepthMaps(VkCommandBuffer cmd) {
  field_passes_pipelines_->recordDepthMaps(cmd, descriptor_set_, triangle_count_,
                                           static_cast<uint32_t>(cameras_.size()), images_.width,
                                           images_.height, depth_maps_.buffer);
  ++depth_map_passes_;
}

Image8 Renderer::render(const Camera& user_camera, const BlendSettings& settings) {
  BlendUniforms u{};
  // z: cameras left out of the arrays for their empty masks; each adds its
  // gamma of 1 (it sees no vertex) to montage4d's sum, as in the reference.
  u.counts =
      glm::ivec4(static_cast<int>(cameras_.size()), static_cast<int>(settings.mode),
                 static_cast<int>(subject_seen_.size() - active_.size()), uploaded_half_ ? 1 : 0);
  u.params = glm::vec4(settings.alpha, settings.depth_tolerance, 0, 0);
  u.hole_color = glm::vec4(settings.hole_color, 1.0f);
  u.user_eye = glm::vec4(glm::vec3(user_camera.center()), 1.0f);
  u.fragment_test =
      glm::vec4(settings.fields.relative_depth_tolerance, static_cast<float>(fragmentDepthSlack()),
                std::max(settings.feather_width_px, 0.0f), settings.fragment_test ? 1.0f : 0.0f);
  u.view_weight = glm::vec4(std::max(settings.beta, 0.0f), 0.0f, 0.0f, 0.0f);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Camera& c = cameras_[i];
    u.cameras[i].world_to_clip = clipFor(c);
    u.cameras[i].center = glm::vec4(glm::vec3(c.center()), 1.0f);
    u.cameras[i].size = glm::vec4(c.width, c.height, 1.0f / c.width, 1.0f / c.height);
    const uint32_t view = active_[i];  // camera_enabled is by the views' index
    const bool enabled = settings.camera_enabled.empty() ||
                         (view < settings.camera_enabled.size() && settings.camera_enabled[view]);
    // y: the camera sees none of the subject (an empty mask; only when no
    // camera does, else it is not among cameras_). Its depth map and
    // discontinuity test find no surface: every vertex is on its background.
    const bool empty = view < subject_seen_.size() && !subject_seen_[view];
    u.cameras[i].flags = glm::ivec4(enabled ? 1 : 0, empty ? 1 : 0, 0, 0);
  }
  const bool have_views = !cameras_.empty();
  if (const Status usable = checkRenderable(vertex_count_, settings); have_views && !usable.isOk())
    throw std::invalid_argument(usable.message());
  const bool montage = have_views && settings.mode == BlendMode::kMontage4D;
  const bool want_fields = have_views && (settings.mode == BlendMode::kHoloportation || montage);
  FieldParameters parameters = settings.fields;
  parameters.alpha = settings.alpha;
  if (montage) {
    parameters.geodesics = true;
    parameters.field_per_view = true;
    prepareTemporal();
    u.temporal = glm::vec4(
        static_cast<float>(reference::temporalLambda(settings.lambda, settings.frame_interval_s)),
        static_cast<float>(temporal_half_), 0.0f, 0.0f);
  }
  std::memcpy(uniforms_.mapped, &u, sizeof(u));
  const bool settings_changed =
      settings.camera_enabled != field_cameras_ || !(parameters == field_parameters_);
  const bool run_fields = want_fields && (fields_stale_ || depth_maps_stale_ || settings_changed);
  if (run_fields) ensureFieldBuffers(parameters);
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    if (run_fields) field_passes_pipelines_->beginTiming(cmd);
    if (have_views && depth_maps_stale_) renderDepthMaps(cmd);
    if (run_fields) {
      field_passes_pipelines_->depthMapsDone(cmd);
      field_passes_pipelines_->record(
          cmd, descriptor_set_, vertex_count_, triangle_count_,
          static_cast<uint32_t>(cameras_.size()), images_.width, images_.height, parameters,
          {visible_counts_.buffer, worklist_.buffer, worklist_counts_.buffer, seams_.buffer});
      ++field_passes_;
    }
    // (A measurement stop before stage 6, the field, skips the per-view field too.)
    if (montage && (parameters.last_stage < 0 || parameters.last_stage >= 6)) {
      field_passes_pipelines_->recordMontage(
          cmd, descriptor_set_, vertex_count_, static_cast<uint32_t>(cameras_.size()), parameters,
          static_cast<float>(geodesicScale(parameters)), temporal_stride_);
    }
    std::array<VkClearValue, 2> clears{};
    clears[0].color = {{0.0f, 0.0f, 0.0f, 0.0f}};
    clears[1].depthStencil = {1.0f, 0};
    VkRenderPassBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
    begin.renderPass = blend_pass_;
    begin.framebuffer = output_framebuffer_;
    begin.renderArea = {{0, 0}, {width_, height_}};
    begin.clearValueCount = static_cast<uint32_t>(clears.size());
    begin.pClearValues = clears.data();
    vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
    if (have_views) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, blend_pipeline_);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, blend_layout_, 0, 1,
                              &descriptor_set_, 0, nullptr);
      setViewport(cmd, width_, height_);
      // The output may differ in size from the user camera's calibration:
      // scale the intrinsics to the output.
      Camera scaled = user_camera;
      const double sx = static_cast<double>(width_) / user_camera.width;
      const double sy = static_cast<double>(height_) / user_camera.height;
      scaled.fx *= sx;
      scaled.cx *= sx;
      scaled.skew *= sx;
      scaled.fy *= sy;
      scaled.cy *= sy;
      scaled.width = width_;
      scaled.height = height_;
      const glm::mat4 m = clipFor(scaled);
      vkCmdPushConstants(cmd, blend_layout_, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(m), &m);
      drawMesh(cmd);
    }
    vkCmdEndRenderPass(cmd);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {width_, height_, 1};
    vkCmdCopyImageToBuffer(cmd, color_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           readback_.buffer, 1, &region);
    VkMemoryBarrier to_host{};
    to_host.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    to_host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                         &to_host, 0, nullptr, 0, nullptr);
  });
  if (have_views) depth_maps_stale_ = false;
  if (montage) temporal_half_ ^= 1u;  // this frame's field is the next one's previous
  if (run_fields) {
    fields_stale_ = false;
    field_cameras_ = settings.camera_enabled;
    field_parameters_ = parameters;
  }
  Image8 out(width_, height_, 4);
  std::memcpy(out.pixels.data(), readback_.mapped, out.pixels.size());
  return out;
}

}  // namespace holofuse::render
