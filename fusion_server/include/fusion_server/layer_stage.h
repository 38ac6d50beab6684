// The server's layer stage (protocol 1.5): the fused mesh laid out in the
// frame's atlas (Dong and Hollerer 2017) and L texture layers filled from
// the group's decoded images (Volino and Hilton 2016, section 3.1), for the
// clients that asked for layers instead of camera images.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "codec/layer_video.h"
#include "fusion_server/frame_sync.h"
#include "geometry/mesh.h"
#include "hull/visual_hull.h"
#include "protocol/messages.h"
#include "texture/texture_atlas.h"
#include "texture/texture_layers.h"

namespace holofuse::fusion {

struct LayerSettings {
  // L. Paper 001 finds three enough. With the deeper layers held only where
  // their camera scores at least a quarter of the best (min_score_share),
  // the third is where many cameras see the surface about as well, and
  // there it is what the blend needs: eval, clean and many-cameras, h264
  // layers, --frames 8 --held-out 4 (PSNR and SSIM against normal's, share
  // of normal's bytes): 2 layers at a share of 0.5 and CRF 11 -0.07 dB,
  // +0.003, 19.7% and -0.27 dB, +0.0008, 9.2%; 3 layers at 0.25 and CRF
  // 14 -0.03 dB, +0.0018, 20.8% and -0.12 dB, +0.0006, 9.8%; at CRF 16
  // -0.04 dB, +0.0007, 18.8% and -0.19 dB, -0.0049, 8.8%.
  int layers = 3;
  uint32_t atlas_texels = 1024;      // side of the atlas
  uint32_t atlas_max_texels = 4096;  // it grows up to this when the mesh needs it
  // Charts (AtlasOptions::chart_cells): blocks of this many lattice cells a
  // side per chart, at texels_per_cell; 0: a square per pair of triangles
  // at atlas_texels (Dong and Hollerer 2017). Larger charts hold more of
  // the surface across frames and waste fewer texels on gutters, until a
  // block holds surfaces that face one way and fold onto each other. Eval,
  // h264 layers, --frames 8 --held-out 4 (KB a frame, SSIM; clean, then
  // many-cameras): 4 cells 134.5, 0.6946 and 127.1, 0.8106; 6 128.1,
  // 0.6954 and 120.4, 0.8115; 7 119.6, 0.6953 and 113.0, 0.8118; 8 125.1,
  // 0.6954 and 118.1, 0.8127; 10 122.3, 0.6934 and 115.8, 0.8122; 12
  // 123.0, 0.6880 and 115.3, 0.8061. At 4 texels a cell 7 is a 32-texel
  // square with its gutters: two 16-texel video blocks a side.
  uint32_t chart_cells = 7;
  double texels_per_cell = 4.0;   // see layers
  double min_score_share = 0.25;  // LayerOptions::min_score_share; see layers
  double keep_share = 0.5;        // LayerOptions::keep_share
  // The layers' colour as video, for the clients that decode it (protocol
  // 1.6); video.codec kLz4 (or any image codec, the default): never as
  // video, LZ4 as the images. Layer l at constant quality takes video.crf
  // + l * video_crf_step (at most the codec's worst): a deeper layer holds
  // a second view, which the blend weighs less than the first, so its
  // bits buy less. Eval, clean and many-cameras, 8 frames, h264 layers
  // (KB a frame, SSIM): CRF 12 every layer 169.9, 0.6948 and 157.0,
  // 0.8118; 11 then 17 157.8, 0.6948 and 143.2, 0.8099; 12 then 16 155.4,
  // 0.6945 and 141.8, 0.8103; 10 then 18 160.8, 0.6950 and 145.4, 0.8093.
  // The third layer's bytes are paid for with CRF 14 (see layers).
  LayerVideoOptions video{.codec = protocol::Codec::kLz4, .crf = 14};
  int video_crf_step = 6;
  // AtlasOptions::charts_face_surface_around: not a setting of its own,
  // but false while a layered client before protocol 1.12 is connected.
  bool charts_face_surface_around = true;
  bool operator==(const LayerSettings&) const = default;
  bool sameAtlas(const LayerSettings& other) const {
    return layers == other.layers && atlas_texels == other.atlas_texels &&
           atlas_max_texels == other.atlas_max_texels && chart_cells == other.chart_cells &&
           texels_per_cell == other.texels_per_cell && min_score_share == other.min_score_share &&
           keep_share == other.keep_share &&
           charts_face_surface_around == other.charts_face_surface_around;
  }
};

// What one frame's layers took and hold.
struct LayerStats {
  AtlasStats atlas;
  uint64_t texels_covered = 0, texels_seen = 0;
  bool video_key_frame = false;  // the video's frame was a key frame
};

class LayerStage {
 public:
  // The mesh (its vertex keys on the lattice of hull; with charts, the mesh
  // as the client decodes it, whose positions place the charts) laid out
  // and its layers built from views, kept for encodeLz4 and encodeVideo;
  // camera_ids names each view on the wire. Refused by name, nothing kept,
  // when the mesh's keys are not the lattice's or its triangles need more
  // than the largest atlas.
  Status build(const Mesh& mesh, const std::vector<LayerView>& views,
               const std::vector<uint32_t>& camera_ids, const hull::HullOptions& hull,
               const LayerSettings& settings, LayerStats* stats = nullptr);
  // The same from a group's decoded images, in camera-id order.
  Status build(const FrameGroup& group, const Mesh& mesh, const hull::HullOptions& hull,
               const LayerSettings& settings, LayerStats* stats = nullptr);

  // The built layers into bundle.layers, the encoded bytes in storage:
  // colour planes in image_codec (lz4_acceleration, lz4_hc_level as the
  // images'), the camera planes Zstandard (protocol 1.11). The camera
  // planes are coded once a build and shared by the bundles after it, so
  // every encode between two builds takes the same storage.
  void encodeLz4(protocol::Codec image_codec, int lz4_acceleration, int lz4_hc_level,
                 protocol::TextureBundle& bundle, std::deque<std::vector<uint8_t>>& storage) const;
  // The same with each layer's colour as the next frame of that layer's
  // video stream (settings.video), a key frame in every stream when
  // key_frame (a receiver joined or missed a frame).
  Status encodeVideo(bool key_frame, protocol::TextureBundle& bundle,
                     std::deque<std::vector<uint8_t>>& storage, LayerStats* stats = nullptr);
  // A bundle of encodeLz4 or encodeVideo as a client before 1.11 decodes
  // it: the same colour planes, the camera planes LZ4.
  protocol::TextureBundle withLz4CameraPlanes(const protocol::TextureBundle& bundle,
                                              std::deque<std::vector<uint8_t>>& storage) const;

 private:
  protocol::BundleLayers layoutOnTheWire(std::deque<std::vector<uint8_t>>& storage) const;
  // Layer l's camera plane in codec, coded once a build whichever bundles
  // (LZ4 or video colour, either minor's spelling) carry it.
  protocol::Plane cameraPlane(size_t layer, protocol::Codec codec,
                              std::deque<std::vector<uint8_t>>& storage) const;
  std::optional<TextureAtlas> atlas_;
  glm::u64vec3 lattice_{0};
  LayerSettings settings_;  // of the atlas and the video streams
  std::vector<uint32_t> camera_ids_;
  // The last build's layers, colour and camera apart (RGB, GRAY8).
  std::vector<Image8> colours_, cameras_;
  std::vector<uint8_t> covered_;  // TextureLayers::covered
  // cameraPlane's, by codec and layer; their bytes lie in the storage of
  // the frame that coded them.
  mutable std::map<std::pair<protocol::Codec, size_t>, protocol::Plane> camera_planes_;
  std::vector<std::unique_ptr<LayerVideoEncoder>> streams_;  // one per layer index
};

}  // namespace holofuse::fusion
