// The server's layer stage (protocol 1.5): the fused mesh laid out in the
// frame's atlas (Dong and Hollerer 2017) and L texture layers filled from
// the group's decoded images (Volino and Hilton 2016, section 3.1), for the
// clients that asked for layers instead of camera images.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "common/mesh.h"
#include "common/texture_atlas.h"
#include "common/texture_layers.h"
#include "fusion_server/frame_sync.h"
#include "hull/visual_hull.h"
#include "protocol/messages.h"

namespace holofuse::fusion {

struct LayerSettings {
  int layers = 3;                    // L (paper 001: three are enough)
  uint32_t atlas_texels = 1024;      // side of the atlas
  uint32_t atlas_max_texels = 4096;  // it grows up to this when the mesh needs it
  // Charts (AtlasOptions::chart_cells): blocks of this many lattice cells a
  // side per chart, at texels_per_cell; 0: a square per pair of triangles
  // at atlas_texels (Dong and Hollerer 2017).
  uint32_t chart_cells = 4;
  double texels_per_cell = 3.0;
  bool operator==(const LayerSettings&) const = default;
};

// What one frame's layers took and hold.
struct LayerStats {
  AtlasStats atlas;
  uint64_t texels_covered = 0, texels_seen = 0;
};

class LayerStage {
 public:
  // The mesh (its vertex keys on the lattice of hull; with charts, the mesh
  // as the client decodes it, whose positions place the charts) laid out and its
  // layers built from views and encoded into bundle.layers, the encoded
  // bytes in storage; camera_ids names each view on the wire. Refused by
  // name, bundle untouched, when the mesh's keys are not the lattice's or
  // its triangles need more than the largest atlas. image_codec,
  // lz4_acceleration and lz4_hc_level: the colour planes'.
  Status build(const Mesh& mesh, const std::vector<LayerView>& views,
               const std::vector<uint32_t>& camera_ids, const hull::HullOptions& hull,
               const LayerSettings& settings, protocol::Codec image_codec, int lz4_acceleration,
               int lz4_hc_level, protocol::TextureBundle& bundle,
               std::deque<std::vector<uint8_t>>& storage, LayerStats* stats = nullptr);
  // The same from a group's decoded images, in camera-id order.
  Status build(const FrameGroup& group, const Mesh& mesh, const hull::HullOptions& hull,
               const LayerSettings& settings, protocol::Codec image_codec, int lz4_acceleration,
               int lz4_hc_level, protocol::TextureBundle& bundle,
               std::deque<std::vector<uint8_t>>& storage, LayerStats* stats = nullptr);

 private:
  std::optional<TextureAtlas> atlas_;
  glm::u64vec3 lattice_{0};
  LayerSettings settings_;  // the atlas's
};

}  // namespace holofuse::fusion
