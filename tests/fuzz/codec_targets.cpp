// Fuzz targets of the payloads inside frames, as each receiver decodes
// them: the server's PodFrame (planes checked against the sender's
// calibration, then LZ4), the client's TextureBundle (LZ4, then each image
// back in its whole frame) and the client's Draco mesh. What they accept
// must be what the stages after them rely on.
#include <cmath>

#include "codec/mesh_codec.h"
#include "fusion_server/pod_decoder.h"
#include "fuzz_frames.h"
#include "fuzz_rig.h"
#include "fuzz_target.h"
#include "render_client/client.h"

namespace holofuse::fuzz {
namespace {

bool sameSize(const Image8& a, const Image8& b) {
  return a.width == b.width && a.height == b.height;
}

bool whole(const Image8& image) {
  return image.pixels.size() == static_cast<size_t>(image.width) * image.height * image.channels;
}

}  // namespace

// A PodFrame payload from pod 0, whose calibration is the rig's camera 0.
HOLOFUSE_FUZZ_TARGET(server_pod_frame) {
  static const Camera camera = fuzzRig().at(0);
  fusion::PodDecodeJob job;
  job.pod = 0;
  job.camera = camera;
  job.frame = frameAround(protocol::MessageType::kPodFrame, protocol::kVersionMinor, {data, size});
  const fusion::DecodedPodFrame decoded = fusion::decodePodFrame(std::move(job));
  if (!decoded.status.isOk()) return 0;
  ++accepted()["server_pod_frame"];
  const fusion::PodImages& images = decoded.images;
  require(images.color.channels == 3 && images.mask.channels == 1 && images.feather.channels == 1,
          "a decoded pod frame has an RGB colour, a grey mask and a grey feather map");
  require(whole(images.color) && whole(images.mask) && whole(images.feather),
          "every decoded plane holds width x height x channels bytes");
  require(sameSize(images.color, images.mask) && sameSize(images.color, images.feather),
          "a pod frame's planes are one rectangle");
  require(cropFits(images.offset_x, images.offset_y, images.color.width, images.color.height,
                   camera.width, camera.height),
          "the rectangle lies inside the calibrated image");
  return 0;
}

// A TextureBundle (first byte: the minor) for a client that holds the
// rig's calibrations.
HOLOFUSE_FUZZ_TARGET(client_texture_bundle) {
  if (size == 0) return 0;
  static const std::map<uint32_t, Camera> rig = fuzzRig();
  protocol::TextureBundle bundle;
  // The bundle's planes point into the frame, which must outlive them.
  const protocol::Frame frame =
      frameAround(protocol::MessageType::kTextureBundle, minorOf(data[0]), {data + 1, size - 1});
  if (!protocol::decodeFrame(frame, bundle).isOk()) return 0;
  if (bundle.layers) {
    // Mode layered's side of the bundle (protocol 1.5; its video, 1.6,
    // through fresh streams: each input stands alone).
    render::LayerStreams streams;
    auto layers = render::layersOfBundle(*bundle.layers, rig, &streams);
    if (layers.isOk()) {
      ++accepted()["client_texture_bundle_layers"];
      require(checkLayeredViews(layers->views).isOk(), "accepted layers pass the renderer's check");
      require(layers->views.camera_centers.size() == bundle.layers->camera_ids.size(),
              "a centre for every layer camera");
      require(layers->layout.slots.size() == bundle.layers->square_count,
              "a slot for every square the bundle states");
    }
  }
  auto views = render::viewsOfBundle(bundle, rig);
  if (!views.isOk()) return 0;
  ++accepted()["client_texture_bundle"];
  for (const render::ViewImages& view : *views) {
    require(view.color.width == view.camera.width && view.color.height == view.camera.height &&
                view.color.channels == 3 && whole(view.color),
            "a bundle's colour comes back as its camera's whole RGB image");
    require(sameSize(view.mask, view.color) && view.mask.channels == 1 && whole(view.mask),
            "its mask is one grey plane of the same size");
    require(view.feather.pixels.empty() ||
                (sameSize(view.feather, view.color) && view.feather.channels == 1),
            "a feather map, where one came, is one grey plane of the same size");
  }
  return 0;
}

// What a client may take from a mesh decoder: whole triangles, indices
// that name vertices, a finite position and normal for every vertex.
void requireRenderable(const Mesh& mesh) {
  require(mesh.indices.size() % 3 == 0, "three indices a triangle");
  for (uint32_t index : mesh.indices)
    require(index < mesh.vertexCount(), "every index names a vertex");
  require(mesh.normals.size() == mesh.positions.size(), "a normal for every vertex");
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const glm::vec3& p = mesh.positions[i];
    const glm::vec3& n = mesh.normals[i];
    require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z), "finite positions");
    require(std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z), "finite normals");
  }
  require(mesh.corner_uvs.empty() || mesh.corner_uvs.size() == mesh.indices.size(),
          "texture coordinates, where there are some, for every corner");
}

// Draco bytes as a MeshFrame carries them to the client.
HOLOFUSE_FUZZ_TARGET(draco_mesh) {
  auto mesh = decodeDraco(data, size);
  if (!mesh.isOk()) return 0;
  ++accepted()["draco_mesh"];
  requireRenderable(*mesh);
  return 0;
}

// Half floats through LZ4 (protocol 1.7's mesh codec 2), as a client gets them.
HOLOFUSE_FUZZ_TARGET(fp16_lz4_mesh) {
  auto mesh = decodeFp16Lz4(data, size);
  if (!mesh.isOk()) return 0;
  ++accepted()["fp16_lz4_mesh"];
  requireRenderable(*mesh);
  return 0;
}

}  // namespace holofuse::fuzz
