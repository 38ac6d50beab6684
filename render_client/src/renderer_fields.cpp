// The texture fields read back (the tests' snapshots) and carried from
// mesh to mesh (temporal smoothing, Du et al. 2019 eq. 5).
#include <algorithm>
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
#include "render_client/renderer.h"
#include "render_client/temporal_carry.h"
#include "renderer_gpu.h"

namespace holofuse::render {

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
  out.weights.assign(s.weights.empty() ? 0 : views * vertices, 0.0f);
  for (uint32_t& camera : out.best_cameras) {
    if (camera != HOLOFUSE_NO_VIEW) camera = active_[camera];
  }
  for (uint32_t& camera : out.triangle_cameras) {
    if (camera < active_.size()) camera = active_[camera];
  }
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
      out.weights[v * views + i] = s.weights[v * active_.size() + j];
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
  const size_t words = cameraWords(s.camera_count);
  auto bit = [](const std::vector<uint32_t>& bits, size_t word, size_t i) {
    return (bits[word + i / 32] >> (i % 32)) & 1u;
  };
  std::vector<uint32_t> camera_bits;  // [vertex][word], bit i for camera i
  copy(discontinuities_, camera_bits, s.vertex_count * words);
  s.discontinuities.assign(per_vertex, 0);
  for (size_t i = 0; i < s.camera_count; ++i) {
    for (size_t v = 0; v < s.vertex_count; ++v)
      s.discontinuities[i * s.vertex_count + v] = bit(camera_bits, v * words, i);
  }
  copy(depth_maps_, s.depth_maps, size_t{images_.width} * images_.height * images_.layers);
  copy(weights_, s.weights, per_vertex);
  s.best_views =
      static_cast<uint32_t>(std::clamp(field_parameters_.best_views, 1, HOLOFUSE_MAX_BEST_VIEWS));
  std::vector<uint32_t> best;  // (camera, weight bits) pairs
  copy(best_views_, best, size_t{s.vertex_count} * s.best_views * 2);
  for (size_t k = 0; 2 * k + 1 < best.size(); ++k) {
    s.best_cameras.push_back(best[2 * k]);
    float w = 0;
    std::memcpy(&w, &best[2 * k + 1], 4);
    s.best_weights.push_back(w);
  }
  s.triangle_count = triangle_count_;
  s.triangle_view_slots =
      static_cast<uint32_t>(triangleViewSlots(static_cast<int>(s.best_views), cameras_.size()));
  std::vector<uint32_t> merged;  // (camera, weight bits at corners 0, 1, 2)
  copy(triangle_views_, merged, size_t{triangle_count_} * s.triangle_view_slots * 4);
  for (size_t e = 0; 4 * e + 3 < merged.size(); ++e) {
    s.triangle_cameras.push_back(merged[4 * e]);
    glm::vec3 w;
    std::memcpy(&w, &merged[4 * e + 1], 12);
    s.triangle_weights.push_back(w);
  }
  s.geodesic_scale = static_cast<float>(geodesicScale(field_parameters_));
  // Per triangle, a bit set per rule (config.h's seam sets): back to
  // [camera][triangle] SeamRule bits.
  std::vector<uint32_t> rule_bits;
  copy(seams_, rule_bits, size_t{triangle_count_} * HOLOFUSE_SEAM_SETS * words);
  s.seams.assign(size_t{triangle_count_} * s.camera_count, 0);
  for (size_t t = 0; t < triangle_count_ && !rule_bits.empty(); ++t) {
    const size_t at = t * HOLOFUSE_SEAM_SETS * words;
    for (size_t i = 0; i < s.camera_count; ++i) {
      s.seams[i * triangle_count_ + t] =
          bit(rule_bits, at + HOLOFUSE_SEAM_SET_OCCLUSION * words, i) * HOLOFUSE_SEAM_OCCLUSION |
          bit(rule_bits, at + HOLOFUSE_SEAM_SET_VOTE * words, i) * HOLOFUSE_SEAM_VOTE |
          bit(rule_bits, at + HOLOFUSE_SEAM_SET_FIELD_OF_VIEW * words, i) *
              HOLOFUSE_SEAM_FIELD_OF_VIEW;
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
  // visibility). The layout has one slot per camera, so a new camera count
  // lays the buffer out again.
  const size_t old_slots = std::max<uint32_t>(temporal_slots_, 1),
               new_slots = std::max<size_t>(camera_ids.size(), 1);
  const size_t vertices = temporal_stride_ / old_slots;
  const float* field =
      static_cast<const float*>(temporal_.mapped) + size_t{temporal_half_} * temporal_stride_;
  std::vector<float> moved(vertices * new_slots, 0.0f);
  for (size_t v = 0; v < vertices; ++v) {
    for (size_t j = 0; j < camera_ids.size(); ++j) {
      if (old_slot[j] >= 0) moved[v * new_slots + j] = field[v * old_slots + old_slot[j]];
    }
  }
  if (moved.size() > temporal_stride_) {
    vkDeviceWaitIdle(ctx_.device());
    ctx_.destroy(temporal_);
    temporal_stride_ = static_cast<uint32_t>(moved.size());
    temporal_ = ctx_.createBuffer(VkDeviceSize{temporal_stride_} * 2 * 4,
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    writeDescriptors();
  }
  float* latest = static_cast<float*>(temporal_.mapped) + size_t{temporal_half_} * temporal_stride_;
  std::fill_n(latest, temporal_stride_, 0.0f);
  std::copy(moved.begin(), moved.end(), latest);
  temporal_slots_ = static_cast<uint32_t>(new_slots);
}

void Renderer::prepareTemporal() {
  // Room for this mesh and the previous one in each half; growing keeps the
  // previous half's contents.
  // One slot per camera of cameras_ (remapTemporal keeps the layout so).
  const uint32_t slots = std::max<uint32_t>(static_cast<uint32_t>(cameras_.size()), 1);
  if (temporal_stride_ == 0) temporal_slots_ = slots;
  const uint32_t needed =
      std::max<uint32_t>(
          1, std::max<uint32_t>(vertex_count_,
                                static_cast<uint32_t>(previous_surface_.vertexCount()))) *
      slots;
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

}  // namespace holofuse::render
