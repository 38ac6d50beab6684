#include "dataset/textured_export.h"

#include <filesystem>

#include "dataset/dataset.h"
#include "dataset/inspection.h"
#include "hull/visual_hull.h"
#include "texture/texture_atlas.h"
#include "texture/texture_layers.h"
#include "texture/textured_mesh_files.h"

namespace holofuse::dataset {

StatusOr<ExportedMesh> exportTexturedFrame(const std::string& dir, const std::string& out_path,
                                           const ExportOptions& options) {
  const std::string extension = std::filesystem::path(out_path).extension().string();
  if (extension != ".glb" && extension != ".obj") {
    return Status(
        StatusCode::kMalformed,
        out_path + ": the extension names the format, .glb or .obj; not '" + extension + "'");
  }
  auto dataset = Dataset::open(dir);
  if (!dataset.isOk()) return dataset.status();
  uint64_t frame_id = 0;
  if (options.frame_id) {
    frame_id = *options.frame_id;
  } else {
    auto first = firstWholeFrame(*dataset, dir);
    if (!first.isOk()) return first.status();
    frame_id = *first;
  }
  auto frame = readFrameViews(*dataset, dir, frame_id);
  if (!frame.isOk()) return frame.status();

  hull::HullOptions hull_options = hullOptionsFor(*dataset, hull::HullOptions{}.voxel_size);
  if (options.voxel_size > 0) hull_options.voxel_size = options.voxel_size;
  std::vector<hull::HullView> hull_views;
  std::vector<LayerView> layer_views;
  for (size_t i = 0; i < frame->cameras.size(); ++i) {
    const PodImagesFull& images = frame->images[i];
    hull_views.push_back({frame->cameras[i], images.mask, images.feather});
    layer_views.push_back({&frame->cameras[i], &images.color, &images.mask,
                           images.feather.empty() ? nullptr : &images.feather});
  }
  Mesh mesh = hull::carveVisualHull(hull_views, hull_options);
  if (mesh.triangleCount() == 0) {
    return Status(StatusCode::kMalformed, dir + ": frame " + std::to_string(frame_id) +
                                              ": the cameras' silhouettes carve no hull");
  }
  AtlasOptions atlas_options;
  atlas_options.texels = options.atlas_texels;
  atlas_options.max_texels = std::max<uint32_t>(options.atlas_texels, 8192);
  atlas_options.headroom = 1.0;  // one frame: no growth to leave room for
  atlas_options.lattice = hull::keyLattice(hull_options);
  TextureAtlas atlas(atlas_options);
  auto cells = atlas.layOut(mesh);
  if (!cells.isOk()) return cells.status();
  LayerOptions layer_options;
  layer_options.layers = 1;
  auto layers = buildTextureLayers(mesh, atlas.texels(), layer_views, layer_options);
  if (!layers.isOk()) return layers.status();

  ExportedMesh out;
  out.frame_id = frame_id;
  out.vertices = mesh.vertexCount();
  out.triangles = mesh.triangleCount();
  out.texels = atlas.texels();
  out.seen_share = layers->texels_covered
                       ? static_cast<double>(layers->texels_seen) / layers->texels_covered
                       : 0.0;
  if (extension == ".glb") {
    HOLOFUSE_RETURN_IF_ERROR(writeTexturedGlb(out_path, mesh, layers->layers[0]));
    out.files = {out_path};
  } else {
    auto files = writeTexturedObj(out_path, mesh, layers->layers[0]);
    if (!files.isOk()) return files.status();
    out.files = *files;
  }
  return out;
}

}  // namespace holofuse::dataset
