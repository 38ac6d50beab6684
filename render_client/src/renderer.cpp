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
#include "renderer_gpu.h"
#include "stylise_pass.h"

namespace holofuse::render {

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

glm::mat4 Renderer::clipFor(const Camera& camera) const {
  const auto [near_plane, far_plane] = depthRange(camera, bounds_min_, bounds_max_);
  return worldToClip(camera, near_plane, far_plane);
}

void Renderer::drawMesh(VkCommandBuffer cmd) {
  // Not indexed: the vertex stage reads indices[corner] itself, so that
  // each corner knows its triangle (shaders/blend.vert.glsl).
  if (index_count_ == 0) return;
  vkCmdDraw(cmd, index_count_, 1, 0, 0);
}

void Renderer::renderDepthMaps(VkCommandBuffer cmd) {
  field_passes_pipelines_->recordDepthMaps(cmd, descriptor_set_, triangle_count_,
                                           static_cast<uint32_t>(cameras_.size()), images_.width,
                                           images_.height, depth_maps_.buffer);
  ++depth_map_passes_;
}

Image8 Renderer::render(const Camera& user_camera, const BlendSettings& settings) {
  beginRender(user_camera, settings);
  return finishRender();
}

namespace {

// The user camera's intrinsics scaled to an output of another size than
// its calibration's.
Camera scaledTo(const Camera& camera, uint32_t width, uint32_t height) {
  Camera scaled = camera;
  const double sx = static_cast<double>(width) / camera.width;
  const double sy = static_cast<double>(height) / camera.height;
  scaled.fx *= sx;
  scaled.cx *= sx;
  scaled.skew *= sx;
  scaled.fy *= sy;
  scaled.cy *= sy;
  scaled.width = width;
  scaled.height = height;
  return scaled;
}

}  // namespace

void Renderer::writeCameras(const BlendSettings& settings) {
  auto* gpu_cameras = static_cast<CameraGpu*>(camera_buffer_.mapped);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Camera& c = cameras_[i];
    CameraGpu& gpu = gpu_cameras[i];
    gpu.world_to_clip = clipFor(c);
    gpu.center = glm::vec4(glm::vec3(c.center()), 1.0f);
    gpu.size = glm::vec4(c.width, c.height, 1.0f / c.width, 1.0f / c.height);
    const uint32_t view = active_[i];  // camera_enabled is by the views' index
    const bool enabled = settings.camera_enabled.empty() ||
                         (view < settings.camera_enabled.size() && settings.camera_enabled[view]);
    // y: the camera sees none of the subject (an empty mask; only when no
    // camera does, else it is not among cameras_). Its depth map and
    // discontinuity test find no surface: every vertex is on its background.
    const bool empty = view < subject_seen_.size() && !subject_seen_[view];
    gpu.flags = glm::ivec4(enabled ? 1 : 0, empty ? 1 : 0, 0, 0);
  }
}

void Renderer::beginRender(const Camera& user_camera, const BlendSettings& settings) {
  ctx_.waitForSubmitted();  // the uniforms below are the previous render's until it ends
  BlendUniforms u{};
  // z: cameras left out of the arrays for their empty masks; each adds its
  // gamma of 1 (it sees no vertex) to montage4d's sum, as in the reference.
  u.counts =
      glm::ivec4(static_cast<int>(cameras_.size()), static_cast<int>(settings.mode),
                 static_cast<int>(subject_seen_.size() - active_.size()), uploaded_half_ ? 1 : 0);
  const bool layered = settings.mode == BlendMode::kLayered;
  if (layered && (layer_count_ == 0 || (index_count_ > 0 && !mesh_has_uvs_)))
    throw std::invalid_argument(layer_count_ == 0
                                    ? "mode layered without texture layers (setLayers)"
                                    : "mode layered with a mesh without texture coordinates");
  u.params = glm::vec4(settings.alpha, settings.depth_tolerance, static_cast<float>(layer_count_),
                       static_cast<float>(vertex_count_));
  u.hole_color = glm::vec4(settings.hole_color, 1.0f);
  u.user_eye = glm::vec4(glm::vec3(user_camera.center()), 1.0f);
  u.fragment_test =
      glm::vec4(settings.fields.relative_depth_tolerance, static_cast<float>(fragmentDepthSlack()),
                std::max(settings.feather_width_px, 0.0f), settings.fragment_test ? 1.0f : 0.0f);
  u.view_weight = glm::vec4(std::max(settings.beta, 0.0f), -1.0f, 0.0f, 0.0f);
  if (settings.relight) {
    // Eq. 6: the normal into view space; the camera's own axes (x right,
    // y down, z forward) turned to the probe's (y up, z towards the eye).
    const glm::mat3 flip(1, 0, 0, 0, -1, 0, 0, 0, -1);
    u.relight = glm::vec4(1, 0, 0, 0);
    u.world_to_view = glm::mat4(flip * glm::mat3(user_camera.rotation));
    for (size_t k = 0; k < settings.light_probe.size(); ++k)
      u.light_probe[k] = glm::vec4(settings.light_probe[k], 0.0f);
  }
  const int best_views = std::clamp(settings.fields.best_views, 1, HOLOFUSE_MAX_BEST_VIEWS);
  // Modes normal and fragment weigh each pod per fragment: past K cameras,
  // each vertex's K candidates (recordCandidates), so that a fragment's
  // cost follows K.
  const bool candidates = cameras_.size() > static_cast<size_t>(best_views);
  u.views = glm::ivec4(best_views, static_cast<int>(cameraWords(cameras_.size())),
                       candidates ? 1 : 0, triangleViewSlots(best_views, cameras_.size()));
  writeCameras(settings);
  // Mode layered reads no camera image: no depth map, field or ranking.
  const bool have_views = !cameras_.empty() && !layered;
  if (const Status usable = checkRenderable(vertex_count_, settings); have_views && !usable.isOk())
    throw std::invalid_argument(usable.message());
  const bool montage = have_views && settings.mode == BlendMode::kMontage4D;
  // The seams, distance and visibility overlays show what the field passes
  // compute, in any mode: they run for the overlay's sake, the seams and
  // geodesics too where the mode itself has none.
  const bool overlay_geodesics =
      settings.overlay == Overlay::kSeams || settings.overlay == Overlay::kGeodesics;
  const bool overlay_fields =
      have_views && (overlay_geodesics || settings.overlay == Overlay::kVisibility);
  const bool want_fields =
      have_views && (settings.mode == BlendMode::kHoloportation || montage || overlay_fields);
  FieldParameters parameters = settings.fields;
  parameters.alpha = settings.alpha;
  if (overlay_fields) {
    parameters.geodesics = parameters.geodesics || overlay_geodesics;
    int slot = -1;  // the overlay's pod among the arrays' cameras
    for (size_t k = 0; k < cameras_.size(); ++k) {
      if (cameras_[k].id == settings.overlay_pod) slot = static_cast<int>(k);
    }
    u.view_weight.y = static_cast<float>(slot);
    u.view_weight.z = static_cast<float>(TextureFieldPasses::finalDistanceHalf(parameters));
    u.view_weight.w = static_cast<float>(geodesicScale(parameters));
  }
  if (montage) {
    parameters.geodesics = true;
    parameters.field_per_view = true;
    u.temporal = glm::vec4(
        static_cast<float>(reference::temporalLambda(settings.lambda, settings.frame_interval_s)),
        static_cast<float>(temporal_half_), 0.0f, 0.0f);
  }
  std::memcpy(uniforms_.mapped, &u, sizeof(u));
  const bool settings_changed =
      settings.camera_enabled != field_cameras_ || !(parameters == field_parameters_);
  bool run_fields = want_fields && (fields_stale_ || depth_maps_stale_ || settings_changed);
  // The normal ranking (every mode but fragment) does not depend on the
  // view: once per mesh, views and settings; mode fragment's per view.
  const CandidateKey key{settings.mode == BlendMode::kFragment, best_views,
                         settings.depth_tolerance, settings.camera_enabled};
  bool run_candidates = candidates && (settings.mode == BlendMode::kFragment || candidates_stale_ ||
                                       depth_maps_stale_ || !(key == candidate_key_));
  // The fields and the candidates share the buffers' sizes: one made anew
  // for either has lost what the other computed (a field mode after mode
  // normal with more best views, on the same mesh, read never-written
  // lists). Both are computed again: now what this mode reads, later the
  // rest.
  if ((run_fields || run_candidates) && ensureFieldBuffers(parameters)) {
    fields_stale_ = candidates_stale_ = true;
    run_fields = want_fields;
    run_candidates = candidates;
  }
  if (run_candidates) {
    candidate_key_ = key;
    candidates_stale_ = false;
  }
  // Made (on first use) before recording: a failure leaves nothing half recorded.
  const VkPipeline blend_pipeline = blendPipeline(settings.mode, settings.overlay);
  const bool stipple = settings.stylisation == Stylisation::kStipple;
  if (stipple && !stylise_pass_)
    stylise_pass_ = std::make_unique<StylisePass>(ctx_, width_, height_);
  // The frame in two parts: what follows the mesh, then the view.
  auto recordPerMesh = [&](VkCommandBuffer cmd) {
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
    if (run_candidates) {
      field_passes_pipelines_->recordCandidates(cmd, descriptor_set_, vertex_count_,
                                                static_cast<uint32_t>(cameras_.size()),
                                                images_.width, images_.height);
    }
  };
  auto recordView = [&](VkCommandBuffer cmd) {
    // (A measurement stop before stage 6, the field, skips the per-view field too.)
    if (montage && (parameters.last_stage < 0 || parameters.last_stage >= 6)) {
      field_passes_pipelines_->recordMontage(cmd, descriptor_set_, vertex_count_, triangle_count_,
                                             static_cast<uint32_t>(cameras_.size()), parameters,
                                             static_cast<float>(geodesicScale(parameters)),
                                             temporal_stride_);
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
    if (have_views || layered) {
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, blend_layout_, 0, 1,
                              &descriptor_set_, 0, nullptr);
      setViewport(cmd, width_, height_);
      const glm::mat4 m = clipFor(scaledTo(user_camera, width_, height_));
      vkCmdPushConstants(cmd, blend_layout_, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(m), &m);
      // The nearest depth first, then the blend where it is met: each
      // pixel is blended once (the vertex stage's gl_Position is
      // invariant, so both draws rasterise the same depths).
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, depth_prepass_);
      drawMesh(cmd);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, blend_pipeline);
      drawMesh(cmd);
    }
    vkCmdEndRenderPass(cmd);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {width_, height_, 1};
    // The picture, stylised (paper 000, section 6) when asked.
    const gpu::Image& picture = stipple ? stylise_pass_->recordStipple(cmd, color_) : color_;
    vkCmdCopyImageToBuffer(cmd, picture.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           readback_.buffer, 1, &region);
    transferWritesToHost(cmd);
  };
  if (montage) {
    // Montage4D's temporal carry (the previous mesh's vertex for each of
    // this one's, on the host) is read first by the per-view field: the
    // host finds it while the device runs the per-mesh passes, which do
    // not read it. In one submission after the carry it cost every new
    // mesh its time (0.9 ms here; 1.7 ms of an H200's 4.2 ms).
    ctx_.submit(recordPerMesh);
    prepareTemporal();
    ctx_.submitBehind(recordView);
  } else {
    ctx_.submit([&](VkCommandBuffer cmd) {
      recordPerMesh(cmd);
      recordView(cmd);
    });
  }
  if (have_views) depth_maps_stale_ = false;
  if (montage) temporal_half_ ^= 1u;  // this frame's field is the next one's previous
  if (run_fields) {
    fields_stale_ = false;
    field_cameras_ = settings.camera_enabled;
    field_parameters_ = parameters;
  }
}

Image8 Renderer::finishRender() {
  ctx_.waitForSubmitted();
  Image8 out(width_, height_, 4);
  std::memcpy(out.pixels.data(), readback_.mapped, out.pixels.size());
  return out;
}

}  // namespace holofuse::render
