// `./holofuse dataset export`: one frame of a dataset fused into a visual
// hull and written as a textured mesh a person opens in Blender or
// MeshLab, the atlas (texture/texture_atlas.h) filled per texel from the
// most direct camera that sees the point (layer 1 of
// texture/texture_layers.h).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"

namespace holofuse::dataset {

struct ExportOptions {
  std::optional<uint64_t> frame_id;  // default: the first frame every camera holds
  uint32_t atlas_texels = 2048;      // grows up to 8192 when the hull needs it
  double voxel_size = 0.0;           // 0: the dataset's
};

struct ExportedMesh {
  uint64_t frame_id = 0;
  size_t vertices = 0, triangles = 0;
  uint32_t texels = 0;      // side of the atlas texture
  double seen_share = 0.0;  // of the triangles' texels, those some camera sees
  std::vector<std::string> files;
};

// Writes out_path as glTF binary (.glb) or OBJ (.obj, with .mtl and .png
// beside it); any other extension is refused by name.
StatusOr<ExportedMesh> exportTexturedFrame(const std::string& dir, const std::string& out_path,
                                           const ExportOptions& options = {});

}  // namespace holofuse::dataset
