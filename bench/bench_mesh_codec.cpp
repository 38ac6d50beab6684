// The mesh codecs on the same meshes: Draco (the default) against half
// floats through LZ4 (the open Holoportation stack's), each mesh the hull
// the server carves from the demo's rig (4 pods at 320x240) at 20 and
// 10 mm, with vertex keys (Draco's in half steps on the hull's lattice,
// the positions as places along the keys' edges) and without normals (the
// receiver recomputes them), as the server sends them: encode
// and decode ms (medians) and bytes, and the ratios. Ratios are measured in
// one run; the machine is noisy.
//   bench_mesh_codec [frames]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "bench_timing.h"
#include "capture_node/pod.h"
#include "codec/mesh_codec.h"
#include "fusion_server/fusion_worker.h"
#include "hull/visual_hull.h"
#include "scene/synthetic_scene.h"

using namespace holofuse;
using bench::Clock;
using bench::median;

namespace {

struct CodecCost {
  std::vector<double> encode_ms, decode_ms, bytes;
};

template <typename Encode, typename Decode>
bool measure(const std::vector<Mesh>& meshes, Encode encode, Decode decode, CodecCost& cost) {
  for (int round = 0; round < 2; ++round) {  // the first warms the caches
    for (const Mesh& mesh : meshes) {
      const auto t0 = Clock::now();
      auto bytes = encode(mesh);
      const auto t1 = Clock::now();
      if (!bytes.isOk()) return false;
      auto back = decode(bytes->data(), bytes->size());
      const auto t2 = Clock::now();
      if (!back.isOk() || back->triangleCount() != mesh.triangleCount()) return false;
      if (round == 0) continue;
      cost.encode_ms.push_back(bench::ms(t0, t1));
      cost.decode_ms.push_back(bench::ms(t1, t2));
      cost.bytes.push_back(static_cast<double>(bytes->size()));
    }
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::max(1, std::atoi(argv[1])) : 6;
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(4, 320, 240);
  std::vector<scene::CameraRenderer> renderers;
  std::vector<Image8> plates;
  for (const auto& camera : cameras) {
    renderers.emplace_back(scene, camera);
    plates.push_back(scene.backgroundPlate(camera));
  }
  std::printf("4 pods at 320x240, %d hulls of the synthetic subject per voxel size (medians)\n\n",
              frames);
  std::printf("%6s %-10s %9s %9s %9s %12s %10s\n", "voxel", "codec", "vertices", "encode ms",
              "decode ms", "KB", "ms / Draco");
  for (double voxel : {0.02, 0.01}) {
    std::vector<Mesh> meshes;
    hull::HullOptions options;
    options.voxel_size = voxel;
    // Draco's keys and places on the hull's lattice, as the server sends them.
    const DracoOptions spelling = fusion::dracoOnHullLattice({}, options);
    for (int f = 0; f < frames; ++f) {
      std::vector<hull::HullView> views;
      for (size_t i = 0; i < cameras.size(); ++i) {
        capture::PodCapture pod = capture::capturePodFrame(
            renderers[i], plates[i], 30 + static_cast<uint64_t>(f), static_cast<uint16_t>(i));
        views.push_back({cameras[i], pod.mask, pod.feather});
      }
      meshes.push_back(hull::carveVisualHull(views, options));
    }
    std::vector<double> vertices;
    for (const Mesh& m : meshes) vertices.push_back(static_cast<double>(m.vertexCount()));
    CodecCost draco, fp16;
    const bool ok = measure(
                        meshes, [&](const Mesh& m) { return encodeDraco(m, spelling); },
                        [](const uint8_t* d, size_t n) { return decodeDraco(d, n); }, draco) &&
                    measure(
                        meshes, [](const Mesh& m) { return encodeFp16Lz4(m, false); },
                        [](const uint8_t* d, size_t n) { return decodeFp16Lz4(d, n); }, fp16);
    if (!ok) {
      std::fprintf(stderr, "a codec failed on a hull mesh\n");
      return 1;
    }
    const double draco_ms = median(draco.encode_ms) + median(draco.decode_ms);
    for (const auto& [name, cost] : {std::pair<const char*, CodecCost*>{"draco", &draco},
                                     std::pair<const char*, CodecCost*>{"fp16-lz4", &fp16}}) {
      std::printf("%4.0f mm %-10s %9.0f %9.2f %9.2f %12.1f %10.2f\n", voxel * 1000, name,
                  median(vertices), median(cost->encode_ms), median(cost->decode_ms),
                  median(cost->bytes) / 1000.0,
                  (median(cost->encode_ms) + median(cost->decode_ms)) / draco_ms);
    }
    std::printf("%4.0f mm fp16-lz4 against draco: %.2fx the bytes, %.2fx the encode + decode ms\n",
                voxel * 1000, median(fp16.bytes) / median(draco.bytes),
                (median(fp16.encode_ms) + median(fp16.decode_ms)) / draco_ms);
  }
  return 0;
}
