// What layered transmission (Volino and Hilton 2016) sends against camera
// images: 4 pods of the synthetic scene at 320x240 (the demo's rig), the
// hull at the server's default voxel as a client decodes it, laid into the
// per-frame atlas in the paper's squares (Dong and Hollerer 2017) at three
// sizes and in charts at three densities, L = 1..4 layers built on the CPU
// reference and compressed as the server compresses them. Prints, per
// layout and L, the atlas's side, bytes per frame against the pods'
// masked, cropped images (colour, mask, feather as the bundle carries them
// today), the layout's bytes (its slots), the layout and build time
// against the hull's, and the share of squares that stayed in place from
// frame to frame. Ratios within one run; the machine is noisy.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "capture_node/pod.h"
#include "codec/image_codec.h"
#include "codec/mesh_codec.h"
#include "codec/pod_frame_codec.h"
#include "hull/visual_hull.h"
#include "scene/synthetic_scene.h"
#include "texture/texture_atlas.h"
#include "texture/texture_layers.h"

using namespace holofuse;
using bench::Clock;
using bench::median;

namespace {

struct Frame {
  std::vector<capture::PodCapture> pods;
  uint64_t image_bytes = 0;  // the pods' planes as encoded for the wire
};

size_t layerBytes(const Image8& layer) {
  // Colour as the server sends colour, the camera byte as a mask plane.
  Image8 colour(layer.width, layer.height, 3), camera(layer.width, layer.height, 1);
  for (size_t i = 0, n = size_t{layer.width} * layer.height; i < n; ++i) {
    for (int c = 0; c < 3; ++c) colour.pixels[3 * i + c] = layer.pixels[4 * i + c];
    camera.pixels[i] = layer.pixels[4 * i + 3];
  }
  std::vector<uint8_t> a, b;
  return encodePlane(colour, protocol::PlaneKind::kColor, protocol::Codec::kLz4PlanarDelta, a)
             .data.size() +
         encodePlane(camera, protocol::PlaneKind::kMask, protocol::Codec::kLz4, b).data.size();
}

}  // namespace

int main(int argc, char** argv) {
  const int frame_count = argc > 1 ? std::max(2, std::atoi(argv[1])) : 4;
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(4, 320, 240);
  std::vector<Frame> frames;
  for (int f = 0; f < frame_count; ++f) {
    Frame frame;
    for (const auto& camera : cameras) {
      capture::PodCapture pod =
          capture::capturePodFrame(scene, camera, scene.backgroundPlate(camera),
                                   30 + static_cast<uint64_t>(f), static_cast<uint16_t>(camera.id));
      PodPlanes planes;
      planes.color = &pod.view.color;
      planes.mask = &pod.mask;
      planes.feather = &pod.feather;
      std::vector<protocol::StageStamp> stamps;
      const auto wire = encodePodFrame(planes, stamps, camera.id, PodEncoding{});
      frame.image_bytes += wire.size();
      frame.pods.push_back(std::move(pod));
    }
    frames.push_back(std::move(frame));
  }
  hull::HullOptions hull_options;
  std::printf("4 pods at 320x240, %d frames of the synthetic subject, voxel %.0f mm\n\n",
              frame_count, hull_options.voxel_size * 1000);
  std::printf("%-16s %3s %6s %12s %9s %10s %10s %11s %8s %8s\n", "layout", "L", "side", "layers KB",
              "images KB", "ratio", "layout KB", "layers ms", "/ hull", "kept");
  std::vector<Mesh> hulls;
  std::vector<double> hull_ms;
  for (const Frame& frame : frames) {
    std::vector<hull::HullView> views;
    for (size_t i = 0; i < cameras.size(); ++i)
      views.push_back({cameras[i], frame.pods[i].mask, frame.pods[i].feather});
    const auto t0 = Clock::now();
    hulls.push_back(hull::carveVisualHull(views, hull_options));
    hull_ms.push_back(bench::ms(t0, Clock::now()));
  }
  double image_bytes = 0;
  for (const Frame& frame : frames) image_bytes += static_cast<double>(frame.image_bytes);
  image_bytes /= frame_count;
  // The paper's squares at three sizes, then charts of 4^3 voxels at three
  // densities (the server's default: 3 texels a voxel).
  struct Layout {
    std::string name;
    AtlasOptions options;
  };
  std::vector<Layout> layouts;
  for (const uint32_t texels : {512u, 1024u, 2048u}) {
    AtlasOptions options;
    options.texels = options.max_texels = texels;
    layouts.push_back({"squares " + std::to_string(texels), options});
  }
  for (const double density : {2.0, 3.0, 4.0}) {
    AtlasOptions options;
    options.chart_cells = 4;
    options.texels_per_cell = density;
    options.cell_size = hull_options.voxel_size;
    char name[32];
    std::snprintf(name, sizeof(name), "charts %.0f/voxel", density);
    layouts.push_back({name, options});
  }
  for (Layout& layout : layouts) {
    layout.options.lattice = hull::keyLattice(hull_options);
    for (int layers = 1; layers <= 4; ++layers) {
      TextureAtlas atlas(layout.options);
      std::vector<double> build_ms;
      double bytes = 0, layout_bytes = 0, kept = 0, texels = 0;
      bool refused = false;
      for (int f = 0; f < frame_count; ++f) {
        // As the client decodes it: charts are placed by its positions.
        const auto draco = encodeDraco(hulls[f]);
        Mesh mesh = decodeDraco(draco->data(), draco->size()).value();
        AtlasStats stats;
        const auto t0 = Clock::now();
        auto cells = atlas.layOut(mesh, &stats);
        if (!cells.isOk()) {
          std::printf("%-16s %3d %s\n", layout.name.c_str(), layers,
                      cells.status().toString().c_str());
          refused = true;
          break;
        }
        layout_bytes += static_cast<double>(encodeAtlasSlots(atlas.layout().slots).size());
        texels += stats.texels;
        if (f > 0) kept += stats.keptFraction() / (frame_count - 1);
        std::vector<LayerView> views;
        for (size_t i = 0; i < cameras.size(); ++i) {
          const capture::PodCapture& pod = frames[f].pods[i];
          views.push_back({&cameras[i], &pod.view.color, &pod.mask, &pod.feather});
        }
        LayerOptions options;
        options.layers = layers;
        auto built = buildTextureLayers(mesh, atlas.texels(), views, options);
        build_ms.push_back(bench::ms(t0, Clock::now()));
        for (const Image8& layer : built->layers) bytes += static_cast<double>(layerBytes(layer));
      }
      if (refused) break;
      bytes /= frame_count;
      layout_bytes /= frame_count;
      std::printf("%-16s %3d %6.0f %12.1f %9.1f %10.2f %10.1f %11.1f %8.1f %7.0f%%\n",
                  layout.name.c_str(), layers, texels / frame_count, bytes / 1024,
                  image_bytes / 1024, (bytes + layout_bytes) / image_bytes, layout_bytes / 1024,
                  median(build_ms), median(build_ms) / median(hull_ms), 100 * kept);
    }
  }
  std::printf(
      "\nratio: (layers + the atlas layout's bytes) / the images' bytes; layers ms: layout and "
      "build on the CPU reference\n");
  return 0;
}
