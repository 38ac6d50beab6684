#include "fusion_server/layer_stage.h"

#include <algorithm>
#include <numeric>

#include "codec/image_codec.h"
#include "fusion_server/fusion_worker.h"

namespace holofuse::fusion {

namespace {

// The camera planes' LZ4, for clients before 1.11, at HC level 6: on the
// clean scene's layers it halves their bytes (47 to 23 KB a layer) for
// about 4 ms a layer; level 9 saves 6% more for 20 ms. Zstandard
// (kPlaneZstdLevel) takes 14 KB in 2 ms.
constexpr int kCameraPlaneHcLevel = 6;

}  // namespace

Status LayerStage::build(const FrameGroup& group, const Mesh& mesh, const hull::HullOptions& hull,
                         const LayerSettings& settings, LayerStats* stats) {
  // The whole images, in camera-id order: a layer texel's camera byte is
  // an index into this order (BundleLayers::camera_ids).
  const std::vector<hull::HullView> silhouettes = hullViewsOf(group);
  const std::vector<Image8> colours = colorsInFrame(group);
  std::vector<LayerView> views;
  std::vector<uint32_t> camera_ids;
  size_t k = 0;
  for (const auto& [camera_id, pod] : group.pods) {
    views.push_back({&silhouettes[k].camera, &colours[k], &silhouettes[k].mask,
                     silhouettes[k].feather.empty() ? nullptr : &silhouettes[k].feather});
    camera_ids.push_back(camera_id);
    ++k;
  }
  return build(mesh, views, camera_ids, hull, settings, stats);
}

Status LayerStage::build(const Mesh& mesh, const std::vector<LayerView>& views,
                         const std::vector<uint32_t>& camera_ids, const hull::HullOptions& hull,
                         const LayerSettings& settings, LayerStats* stats) {
  colours_.clear();
  cameras_.clear();
  camera_planes_.clear();
  if (camera_ids.size() != views.size())
    return Status(StatusCode::kMalformed, "texture layers: " + std::to_string(camera_ids.size()) +
                                              " camera ids for " + std::to_string(views.size()) +
                                              " views");
  // The lattice follows the hull's voxel (an error target changes it): a
  // new lattice names other patches, so the atlas starts afresh.
  const glm::u64vec3 lattice = hull::keyLattice(hull);
  if (!atlas_ || lattice != lattice_ || !settings.sameAtlas(settings_)) {
    AtlasOptions options;
    options.texels = settings.atlas_texels;
    options.max_texels = settings.atlas_max_texels;
    options.lattice = lattice;
    options.chart_cells = settings.chart_cells;
    options.texels_per_cell = settings.texels_per_cell;
    options.cell_size = hull.voxel_size;
    options.charts_face_surface_around = settings.charts_face_surface_around;
    atlas_.emplace(options);
    lattice_ = lattice;
  }
  // Streams of other settings start again (at a key frame).
  if (!(settings.video == settings_.video) || settings.video_crf_step != settings_.video_crf_step)
    streams_.clear();
  settings_ = settings;
  Mesh laid = mesh;
  AtlasStats atlas_stats;
  HOLOFUSE_RETURN_IF_ERROR(atlas_->layOut(laid, &atlas_stats).status());
  if (!atlas_->layout().keyed())
    return Status(StatusCode::kMalformed,
                  "texture layers: the mesh's vertex keys are not the hull's lattice");
  LayerOptions options;
  options.layers = settings.layers;
  options.min_score_share = settings.min_score_share;
  options.keep_share = settings.keep_share;
  HOLOFUSE_ASSIGN_OR_RETURN(const TextureLayers built,
                            buildTextureLayers(laid, atlas_->layout().texels, views, options));
  // RGB as the server sends colour; the camera byte as a plane of its own
  // (runs of one camera compress well, and it must arrive exact).
  for (const Image8& layer : built.layers) {
    Image8 colour(layer.width, layer.height, 3), camera(layer.width, layer.height, 1);
    for (size_t i = 0, n = size_t{layer.width} * layer.height; i < n; ++i) {
      for (int c = 0; c < 3; ++c) colour.pixels[3 * i + c] = layer.pixels[4 * i + c];
      camera.pixels[i] = layer.pixels[4 * i + 3];
    }
    colours_.push_back(std::move(colour));
    cameras_.push_back(std::move(camera));
  }
  covered_ = built.covered;
  camera_ids_ = camera_ids;
  if (stats != nullptr) {
    stats->atlas = atlas_stats;
    stats->texels_covered = built.texels_covered;
    stats->texels_seen = built.texels_seen;
  }
  return Status::ok();
}

protocol::BundleLayers LayerStage::layoutOnTheWire(
    std::deque<std::vector<uint8_t>>& storage) const {
  const AtlasLayout& layout = atlas_->layout();
  protocol::BundleLayers out;
  out.texels = layout.texels;
  out.squares_per_side = layout.squares_per_side;
  out.square_texels = layout.square_texels;
  for (int axis = 0; axis < 3; ++axis)
    out.lattice[axis] = static_cast<uint32_t>(layout.lattice[axis]);
  out.chart_cells = static_cast<uint8_t>(layout.chart_cells);
  out.texel_metres = layout.texel_metres;
  out.charts_face_surface_around = layout.charts_face_surface_around;
  out.square_count = static_cast<uint32_t>(layout.slots.size());
  storage.push_back(encodeAtlasSlots(layout.slots));
  out.slots = storage.back();
  out.camera_ids = camera_ids_;
  return out;
}

protocol::Plane LayerStage::cameraPlane(size_t layer, protocol::Codec codec,
                                        std::deque<std::vector<uint8_t>>& storage) const {
  const auto [at, coded] = camera_planes_.try_emplace({codec, layer});
  if (coded) {
    Image8 continued = cameras_[layer];
    continueCamerasAcrossGutters(continued, covered_);
    storage.emplace_back();
    at->second = encodePlane(continued, protocol::PlaneKind::kCamera, codec, storage.back(), 1,
                             kCameraPlaneHcLevel);
  }
  return at->second;
}

protocol::TextureBundle LayerStage::withLz4CameraPlanes(
    const protocol::TextureBundle& bundle, std::deque<std::vector<uint8_t>>& storage) const {
  protocol::TextureBundle older = bundle;
  if (older.layers) {
    for (size_t l = 0; l < older.layers->layers.size() && l < cameras_.size(); ++l) {
      for (protocol::Plane& plane : older.layers->layers[l])
        if (plane.kind == protocol::PlaneKind::kCamera)
          plane = cameraPlane(l, protocol::Codec::kLz4, storage);
    }
  }
  return older;
}

void LayerStage::encodeLz4(protocol::Codec image_codec, int lz4_acceleration, int lz4_hc_level,
                           protocol::TextureBundle& bundle,
                           std::deque<std::vector<uint8_t>>& storage) const {
  protocol::BundleLayers out = layoutOnTheWire(storage);
  for (size_t l = 0; l < colours_.size(); ++l) {
    std::vector<protocol::Plane> planes;
    storage.emplace_back();
    planes.push_back(encodePlane(colours_[l], protocol::PlaneKind::kColor, image_codec,
                                 storage.back(), lz4_acceleration, lz4_hc_level));
    planes.push_back(cameraPlane(l, protocol::Codec::kZstd, storage));
    out.layers.push_back(std::move(planes));
  }
  bundle.layers = std::move(out);
}

Status LayerStage::encodeVideo(bool key_frame, protocol::TextureBundle& bundle,
                               std::deque<std::vector<uint8_t>>& storage, LayerStats* stats) {
  if (!isVideoCodec(settings_.video.codec))
    return Status(StatusCode::kMalformed, "texture layers: video is off (--layer-video off)");
  protocol::BundleLayers out = layoutOnTheWire(storage);
  while (streams_.size() < colours_.size()) {
    LayerVideoOptions stream = settings_.video;  // the encoder caps the CRF at its codec's worst
    stream.crf += static_cast<int>(streams_.size()) * settings_.video_crf_step;
    streams_.push_back(std::make_unique<LayerVideoEncoder>(stream));
  }
  if (settings_.video.kbps > 0) {
    // The layers' target, split by the texels each layer holds (a deeper
    // layer holds a point only where its camera adds: most of it is fill,
    // which predicts for nearly nothing), each at least a twentieth. A
    // stream takes its new share at its next key frame.
    std::vector<uint64_t> held(cameras_.size(), 0);
    for (size_t l = 0; l < cameras_.size(); ++l)
      held[l] = static_cast<uint64_t>(
          std::count_if(cameras_[l].pixels.begin(), cameras_[l].pixels.end(),
                        [](uint8_t camera) { return camera != kNoLayerCamera; }));
    const uint64_t total = std::accumulate(held.begin(), held.end(), uint64_t{0});
    double shares = 0;
    for (uint64_t& h : held) {
      h = std::max<uint64_t>(h, total / 20 + 1);
      shares += static_cast<double>(h);
    }
    for (size_t l = 0; l < cameras_.size(); ++l)
      streams_[l]->setKbps(std::max(
          1, static_cast<int>(settings_.video.kbps * static_cast<double>(held[l]) / shares + 0.5)));
  }
  bool key = false;
  for (size_t l = 0; l < colours_.size(); ++l) {
    std::vector<protocol::Plane> planes;
    const uint64_t keys_before = streams_[l]->keyFrames();
    storage.emplace_back();
    // The texels no camera fills take the colours around them: no edge for
    // the coder at a chart's border (clean scene: 9% fewer bytes, SSIM
    // +0.01 from less ringing into the charts). A copy: the same layers
    // may also go out as LZ4, where flat grey is cheaper.
    Image8 filled = colours_[l];
    fillUncoveredTexels(filled, cameras_[l]);
    HOLOFUSE_ASSIGN_OR_RETURN(protocol::Plane colour,
                              streams_[l]->encode(filled, key_frame, storage.back()));
    key = key || streams_[l]->keyFrames() > keys_before;
    planes.push_back(colour);
    planes.push_back(cameraPlane(l, protocol::Codec::kZstd, storage));
    out.layers.push_back(std::move(planes));
  }
  bundle.layers = std::move(out);
  if (stats != nullptr) stats->video_key_frame = key;
  return Status::ok();
}

}  // namespace holofuse::fusion
