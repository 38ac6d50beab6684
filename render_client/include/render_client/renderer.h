// The render client's Vulkan pipeline: per-camera depth maps (recomputed
// only when the mesh or the cameras change), then the user's view with the
// pod images blended onto the mesh, read back as RGBA (alpha: coverage).
#pragma once

#include <algorithm>
#include <array>
#include <glm/glm.hpp>
#include <memory>
#include <vector>

#include "base/status.h"
#include "config/settings.h"
#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "gpu/vulkan_context.h"
#include "image/image.h"
#include "render_client/render_settings.h"
#include "render_client/texture_field_passes.h"
#include "texture/texture_layers.h"

namespace holofuse::render {

// What the texture-field passes computed, read back for tests, indexed
// [camera * vertex_count + vertex] (weights: [vertex * camera_count +
// camera]; best views: [vertex * best_views + rank]).
struct FieldSnapshot {
  uint32_t vertex_count = 0, camera_count = 0;
  std::vector<uint32_t> sights, trusted;
  std::vector<float> depth_maps;  // [camera][y][x] of the pod images: camera-space depth,
                                  // HOLOFUSE_NO_DEPTH where none
  // 1 where the vertex lies in the camera's dilated depth discontinuities;
  // computed only where it passes the depth test, 0 elsewhere.
  std::vector<uint32_t> discontinuities;
  uint32_t triangle_count = 0;
  std::vector<uint32_t> seams;           // [camera * triangle_count + triangle]: SeamRule bits
  std::vector<uint32_t> visible_counts;  // per camera: vertices seen and trusted
  std::vector<float>
      distances;  // [camera * vertex_count + vertex]: geodesic distance (3e38: unreached)
  float geodesic_scale = 0;  // distance that maps to gamma = 1
  std::vector<float> weights;
  // Each vertex's best views for the blend, by rank: the camera
  // (HOLOFUSE_NO_VIEW past the last) and its weight.
  uint32_t best_views = 0;
  std::vector<uint32_t> best_cameras;
  std::vector<float> best_weights;
  // Each triangle's corners' best views merged for the blend,
  // [triangle * triangle_view_slots + entry]: the camera (HOLOFUSE_NO_VIEW
  // past the last) and its weight at corners 0, 1 and 2.
  uint32_t triangle_view_slots = 0;
  std::vector<uint32_t> triangle_cameras;
  std::vector<glm::vec3> triangle_weights;
};

struct ViewImages {
  Camera camera;
  Image8 color;  // RGB
  Image8 mask;   // grey, 255 foreground
  // grey: distance to the silhouette's edge in pixels, 255 and beyond as
  // 255 (the pod's feather map); empty when none was sent (every pixel of
  // the mask weighs alike).
  Image8 feather;
};

// Column-major world-to-clip matrix of a pinhole camera for Vulkan: x and y
// map the image to [-1, 1] (y down, as in the image), w is the camera-space
// depth and z/w runs from 0 at near to 1 at far.
glm::mat4 worldToClip(const Camera& camera, double near_plane = 0.05, double far_plane = 100.0);

// Near and far planes that hold the box [lo, hi] as seen by camera, so any
// scene scale (millimetres to kilometres) keeps its depth precision.
std::pair<double, double> depthRange(const Camera& camera, const glm::dvec3& lo,
                                     const glm::dvec3& hi);

// What half-precision vertex storage keeps of a position or normal: each
// component rounded to the nearest half, and halves too small to be normal
// (below 2^-14) stored as 0, so that a GPU that flushes them reads the same.
// Halves hold magnitudes up to 65504 with 11 significant bits: about 0.5 mm
// at 1 m, 8 m at 10 km.
constexpr float kSmallestNormalHalf = 6.103515625e-05f;  // 2^-14
glm::vec3 halfPrecision(const glm::vec3& v);

// What the renderer refuses, as errors its caller checks first: meshes,
// images and settings that came from outside (the network, a file, a flag)
// are checked with these and skipped by name, never thrown. Renderer's
// setMesh, setViews and render throw std::invalid_argument on the same
// conditions: a caller that did not check broke their contract.
//
// A mesh half precision cannot hold (a coordinate past 65504) when
// half_precision is on.
Status checkMesh(const Mesh& mesh, bool half_precision);
// Views of one image size with colour, mask and (when sent) feather maps
// of that size, at most HOLOFUSE_MAX_CAMERAS of them.
Status checkViews(const std::vector<ViewImages>& views);
// Settings the mode can take for a mesh of that many vertices (montage4d's
// geodesic rings and its vertex limit).
Status checkRenderable(size_t mesh_vertices, const BlendSettings& settings);

class StylisePass;  // stylise_pass.h

class Renderer {
 public:
  Renderer(VulkanContext& context, uint32_t width, uint32_t height);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Uploads the mesh's vertices in the precision setHalfPrecisionVertices
  // chose (full by default).
  void setMesh(const Mesh& mesh);
  // From the next setMesh on, positions and normals are stored on the GPU
  // as halves (paper 000's memory saving: 12 bytes a vertex instead of 24);
  // every pass reads what a full-precision buffer of the rounded values
  // would hold.
  void setHalfPrecisionVertices(bool half) { half_vertices_ = half; }
  // Bytes allocated for the vertices on the GPU (room for the largest mesh
  // so far, with a margin).
  uint64_t vertexBufferBytes() const { return vertex_buffer_.size; }
  // All views must share one image size (the pods' calibration): see
  // checkViews.
  void setViews(const std::vector<ViewImages>& views);
  // Renders a sphere of a hull's size (32768 triangles) seen by four
  // views of the picture's size (at most 640x480) in settings' mode (but
  // layered, which has no camera images) and forgets it: the next setMesh
  // starts as the first one. Views of another size than the pods' are
  // made again by the first frame. What a first frame compiles (on lavapipe the
  // JIT of each pipeline and compute pass, hundreds of ms at its first
  // draw or dispatch) is then paid before the client takes frames, not by
  // the first frames it shows.
  void warmUp(const BlendSettings& settings);
  // Mode layered's input (checkLayeredViews; the mesh of setMesh, its
  // corner_uvs pointing into these layers, passes checkLayerCoordinates): uploaded once, rendered
  // from until the next call. Throws std::invalid_argument where the
  // layers are refused.
  void setLayers(const LayeredViews& layers);
  // Renders the user's view. Depth maps are refreshed first if stale.
  // Mode layered reads the layers alone (no depth map, no camera image);
  // it throws std::invalid_argument without layers or texture coordinates.
  Image8 render(const Camera& user_camera, const BlendSettings& settings);
  // render in two halves: beginRender records and submits, and the host
  // is free (to decode the next frame) until finishRender waits for the
  // picture. Anything else given to the renderer in between (a mesh,
  // views, the next beginRender) waits for the render first; the next
  // beginRender's picture replaces one not yet taken.
  void beginRender(const Camera& user_camera, const BlendSettings& settings);
  Image8 finishRender();
  // The render begun has finished on the device: finishRender will not wait.
  bool renderDone() const { return ctx_.submissionDone(); }

  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  uint64_t depthMapPasses() const { return depth_map_passes_; }
  // Cameras of the current views whose mask holds none of the subject:
  // they are left out of every GPU array (unless no camera sees it).
  size_t camerasWithoutSubject() const {
    return static_cast<size_t>(std::count(subject_seen_.begin(), subject_seen_.end(), false));
  }
  uint64_t fieldPasses() const { return field_passes_; }
  // GPU milliseconds of the texture-field passes of the last mesh
  // (TextureFieldPasses::stageNames() order); empty before the first.
  std::vector<double> fieldTimesMs() const { return field_passes_pipelines_->lastTimesMs(); }
  // The texture fields of the last render in a field mode.
  FieldSnapshot readFields() const;
  // The absolute part of the per-fragment depth tolerance: the current
  // mesh's mean edge length, about the depth a fragment of the surface a
  // depth-map pixel holds can lie behind the pixel's centre's.
  double fragmentDepthSlack() const { return mean_edge_; }

 private:
  void createPipelines();
  VkPipeline blendPipeline(BlendMode mode, Overlay overlay = Overlay::kNone);
  void ensureViewResources(uint32_t w, uint32_t h, uint32_t count);
  void destroyViewResources();
  void renderDepthMaps(VkCommandBuffer cmd);
  // Each camera's projection, centre, size and flags (enabled, sees none
  // of the subject) into the camera buffer.
  void writeCameras(const BlendSettings& settings);
  // Grows the field passes' buffers to the mesh, cameras and parameters;
  // true if any was made anew (its contents are gone).
  bool ensureFieldBuffers(const FieldParameters& parameters);
  void writeDescriptors();
  void generateMips(VkCommandBuffer cmd);
  void drawMesh(VkCommandBuffer cmd);
  void uploadMesh(const Mesh& mesh, bool half);  // setMesh's upload, in full or half precision
  glm::mat4 clipFor(const Camera& camera) const;

  // The fields of cameras_ as the passes left them (readFields expands
  // them to the views' indexing).
  FieldSnapshot readActiveFields() const;
  // Moves the latest temporal field's slots from cameras_ to the cameras
  // with these ids, in this order.
  void remapTemporal(const std::vector<uint32_t>& camera_ids);
  VkBufferUsageFlags usageOf(const Buffer& buffer) const;
  VulkanContext& ctx_;
  uint32_t width_, height_;
  // Mesh
  Buffer vertex_buffer_, index_buffer_;
  uint32_t index_count_ = 0;
  bool half_vertices_ = false, uploaded_half_ = false;  // asked for; what the vertex buffer holds
  glm::dvec3 bounds_min_{-1.0}, bounds_max_{1.0};       // of the current mesh
  // Pod views
  // The cameras that take part: those whose mask has foreground (all of
  // them when none has). A camera that sees none of the subject has every
  // vertex on its background, so it is left out of every array: no layer,
  // depth map, vote, seams or field (issue 4: skip what the scene does not
  // need). active_[j] is the views' index of cameras_[j].
  std::vector<Camera> cameras_;
  std::vector<uint32_t> active_;
  std::vector<Camera> view_cameras_;  // every view given to setViews
  std::vector<bool> subject_seen_;    // per view given to setViews: its mask has foreground
  Image images_;
  Image feathers_;     // one R8 layer per camera (config.h binding FEATHERS)
  Buffer depth_maps_;  // [camera][y][x] camera-space depth (config.h binding DEPTHS)
  Buffer staging_;
  bool depth_maps_stale_ = true;
  bool fields_stale_ = true;
  uint64_t depth_map_passes_ = 0;
  uint64_t field_passes_ = 0;
  uint32_t vertex_count_ = 0;
  // What the candidates were last picked for (they are picked again for a
  // new mesh or views, or when these change; mode fragment's every view).
  struct CandidateKey {
    bool fragment_ranking = false;
    int best_views = 0;
    float depth_tolerance = -1;
    std::vector<bool> camera_enabled;
    bool operator==(const CandidateKey&) const = default;
  };
  CandidateKey candidate_key_;
  bool candidates_stale_ = true;
  // The settings the fields were last computed with: they are recomputed
  // when a new mesh or new images arrive or these change.
  std::vector<bool> field_cameras_;
  FieldParameters field_parameters_;
  std::vector<uint32_t> adjacency_data_;  // CSR of the current mesh (config.h binding ADJACENCY)
  std::vector<GeodesicFan> fan_data_;     // in the same order (binding FANS)
  // Montage4D's temporal field: two halves (previous, current) of
  // temporal_stride_ floats, swapped every frame, and the map from this
  // mesh's vertices to the previous mesh's.
  Buffer temporal_, carry_;
  uint32_t temporal_stride_ = 0;
  uint32_t temporal_slots_ = 0;              // cameras per vertex in the temporal buffer's layout
  uint32_t temporal_half_ = 0;               // the half holding the previous frame's field
  Mesh previous_surface_, current_surface_;  // positions and keys only
  bool carry_pending_ = false;
  bool carry_is_identity_ = false;
  double mean_edge_ = 0;
  void prepareTemporal();
  // gamma = 1 at k mean edges from a seam.
  double geodesicScale(const FieldParameters& p) const {
    return p.geodesic_radius > 0 ? p.geodesic_radius : std::max(1, p.geodesic_rings) * mean_edge_;
  }
  // Texture-field buffers (config.h bindings 4 on).
  Buffer discontinuities_, sights_, trusted_, weights_, seams_, visible_counts_, adjacency_, rings_,
      distances_, fans_, worklist_, worklist_counts_, sight_bits_, best_views_, candidates_,
      triangle_views_;
  uint32_t triangle_count_ = 0;
  std::unique_ptr<TextureFieldPasses> field_passes_pipelines_;
  // The stylisation passes over the picture, made when first asked for.
  std::unique_ptr<StylisePass> stylise_pass_;
  // Mode layered: the corners' atlas coordinates (binding CORNER_UVS), the
  // layers (an RGBA array image, binding LAYERS) and their cameras'
  // centres (binding LAYER_CAMERAS).
  Buffer corner_uvs_, layer_cameras_;
  Image layers_;
  bool mesh_has_uvs_ = false;
  uint32_t layer_count_ = 0;  // 0: no layers set
  void ensureLayerImage(uint32_t texels, uint32_t count);
  // Output
  Image color_, depth_;
  VkFramebuffer output_framebuffer_ = VK_NULL_HANDLE;
  Buffer readback_, uniforms_;
  Buffer camera_buffer_;  // CameraGpu per camera (config.h binding CAMERAS)
  // Pipelines
  VkRenderPass blend_pass_ = VK_NULL_HANDLE;
  VkPipelineLayout blend_layout_ = VK_NULL_HANDLE;
  // Per mode and overlay, made when first used (blend.frag.glsl's
  // kBlendMode and kOverlay).
  std::array<VkPipeline, kOverlayCount * kBlendModeCount> blend_pipelines_{};
  VkPipeline depth_prepass_ = VK_NULL_HANDLE;  // the view's nearest depth, before the blend
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
  VkDescriptorSet descriptor_set_ = VK_NULL_HANDLE;
  VkSampler linear_sampler_ = VK_NULL_HANDLE;
};

}  // namespace holofuse::render
