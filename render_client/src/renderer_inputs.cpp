// What the renderer takes from outside: the mesh (in full or half
// precision) and the pods' views, checked, uploaded, mip-mapped.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <glm/gtc/packing.hpp>
#include <limits>
#include <map>
#include <stdexcept>
#include <type_traits>

#include "render_client/reference/texture_fields.h"
#include "render_client/renderer.h"
#include "render_client/temporal_carry.h"
#include "renderer_gpu.h"

namespace holofuse::render {

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
  const int best = settings.fields.best_views;
  if (best < 1 || best > HOLOFUSE_MAX_BEST_VIEWS) {
    return Status(StatusCode::kMalformed, "best views per vertex " + std::to_string(best) +
                                              " is outside 1.." +
                                              std::to_string(HOLOFUSE_MAX_BEST_VIEWS));
  }
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
  ctx_.waitForSubmitted();  // a render in flight reads what this overwrites
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
  // An empty mesh has no index data to copy (memcpy from its null pointer
  // is undefined even for 0 bytes; UBSan, ./holofuse test --sanitize).
  if (!mesh.indices.empty())
    std::memcpy(index_buffer_.mapped, mesh.indices.data(), mesh.indices.size() * 4);
  index_count_ = static_cast<uint32_t>(mesh.indices.size());
  // Mode layered's atlas coordinates, one per corner, when the mesh has them.
  mesh_has_uvs_ = !mesh.indices.empty() && mesh.corner_uvs.size() == mesh.indices.size();
  if (mesh_has_uvs_) {
    const VkDeviceSize uv_bytes = mesh.corner_uvs.size() * sizeof(glm::vec2);
    if (corner_uvs_.size < uv_bytes) {
      vkDeviceWaitIdle(ctx_.device());
      ctx_.destroy(corner_uvs_);
      corner_uvs_ = ctx_.createBuffer(uv_bytes * 3 / 2, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
      if (images_.image != VK_NULL_HANDLE) writeDescriptors();
    }
    std::memcpy(corner_uvs_.mapped, mesh.corner_uvs.data(), uv_bytes);
  }
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
  candidates_stale_ = true;
}

void Renderer::setViews(const std::vector<ViewImages>& views) {
  ctx_.waitForSubmitted();  // a render in flight reads what this overwrites
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
  candidates_stale_ = true;
}

void Renderer::ensureLayerImage(uint32_t texels, uint32_t count) {
  if (layers_.width == texels && layers_.layers == count) return;
  vkDeviceWaitIdle(ctx_.device());
  ctx_.destroy(layers_);
  layers_ = ctx_.createImage(texels, texels, count, VK_FORMAT_R8G8B8A8_UNORM,
                             VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                             VK_IMAGE_ASPECT_COLOR_BIT, true, 1);
  writeDescriptors();
}

void Renderer::setLayers(const LayeredViews& layers) {
  ctx_.waitForSubmitted();  // a render in flight reads what this overwrites
  if (const Status usable = checkLayeredViews(layers); !usable.isOk())
    throw std::invalid_argument(usable.message());
  // The descriptor set is first written with the view resources: a client
  // that receives only layers gets a one-pixel stand-in for the images.
  if (images_.image == VK_NULL_HANDLE) {
    ensureViewResources(1, 1, 1);
    // Never uploaded, but bound: in the layout the descriptors name.
    ctx_.submitAndWait([&](VkCommandBuffer cmd) {
      for (const Image* image : {&images_, &feathers_}) {
        transitionImage(cmd, *image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, 0, VK_ACCESS_SHADER_READ_BIT,
                        VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT);
      }
    });
  }
  const uint32_t texels = layers.layers.front().width;
  const uint32_t count = static_cast<uint32_t>(layers.layers.size());
  ensureLayerImage(texels, count);
  const VkDeviceSize layer_bytes = VkDeviceSize{texels} * texels * 4;
  Buffer staging = ctx_.createBuffer(layer_bytes * count, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  for (uint32_t l = 0; l < count; ++l)
    std::memcpy(static_cast<uint8_t*>(staging.mapped) + l * layer_bytes,
                layers.layers[l].pixels.data(), layer_bytes);
  auto* centres = static_cast<glm::vec4*>(layer_cameras_.mapped);
  for (size_t i = 0; i < layers.camera_centers.size(); ++i)
    centres[i] = glm::vec4(glm::vec3(layers.camera_centers[i]), 1.0f);
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    transitionImage(cmd, layers_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                    VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, count};
    region.imageExtent = {texels, texels, 1};
    vkCmdCopyBufferToImage(cmd, staging.buffer, layers_.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           1, &region);
    transitionImage(cmd, layers_, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                    VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                    VK_PIPELINE_STAGE_ALL_COMMANDS_BIT);
  });
  ctx_.destroy(staging);
  layer_count_ = count;
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

namespace {

// A sphere of radius 0.5: the octahedron's faces split in four, `levels`
// times (8 * 4^levels triangles), closed and counter-clockwise from
// outside, its edges shared, as a carved hull's are.
Mesh warmUpSphere(int levels) {
  Mesh mesh;
  mesh.positions = {{0.5f, 0, 0},  {-0.5f, 0, 0}, {0, 0.5f, 0},
                    {0, -0.5f, 0}, {0, 0, 0.5f},  {0, 0, -0.5f}};
  for (const uint32_t x : {0u, 1u}) {
    for (const uint32_t y : {2u, 3u}) {
      for (const uint32_t z : {4u, 5u}) {
        // Counter-clockwise from outside: the x, y, z order flips with
        // each negative axis.
        const bool flip = ((x == 1u) != (y == 3u)) != (z == 5u);
        mesh.indices.insert(mesh.indices.end(), {x, flip ? z : y, flip ? y : z});
      }
    }
  }
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      auto [it, added] = midpoints.try_emplace(key, static_cast<uint32_t>(mesh.positions.size()));
      if (added)
        mesh.positions.push_back(0.5f * glm::normalize(mesh.positions[a] + mesh.positions[b]));
      return it->second;
    };
    std::vector<uint32_t> split;
    split.reserve(mesh.indices.size() * 4);
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      const uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
      const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      split.insert(split.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
    }
    mesh.indices = std::move(split);
  }
  for (const auto& p : mesh.positions) mesh.normals.push_back(glm::normalize(p));
  return mesh;
}

}  // namespace

void Renderer::warmUp(const BlendSettings& settings) {
  blendPipeline(settings.mode);
  if (settings.mode == BlendMode::kLayered) return;  // its pipeline alone: no camera images
  // Sized as a live frame is likely to be (a hull of tens of thousands of
  // triangles, four views of the picture's size): the buffers and images a
  // frame needs are made here, not by the first frames shown.
  // Capped: a large picture must not allocate gigabytes before a pod joins.
  const uint32_t view_width = std::min<uint32_t>(width_, 640);
  const uint32_t view_height = std::min<uint32_t>(height_, 480);
  const Mesh mesh = warmUpSphere(6);
  std::vector<ViewImages> views;
  for (int k = 0; k < 4; ++k) {
    const double angle = k * 1.5707963267948966;
    ViewImages view;
    view.camera =
        lookAtCamera(static_cast<uint32_t>(k), {2.0 * std::cos(angle), 0.5, 2.0 * std::sin(angle)},
                     {0, 0, 0}, {0, 1, 0}, view_width, view_height, 60.0);
    view.color = Image8(view_width, view_height, 3, 128);
    view.mask = Image8(view_width, view_height, 1, 255);
    views.push_back(std::move(view));
  }
  setMesh(mesh);
  setViews(views);
  for (int frame = 0; frame < 2; ++frame) render(views[0].camera, settings);  // the carry too
  setMesh(mesh);  // a second mesh: the carry's match of one mesh to the next
  render(views[1].camera, settings);
  vkDeviceWaitIdle(ctx_.device());
  previous_surface_ = Mesh{};
  current_surface_ = Mesh{};
}

}  // namespace holofuse::render
