#include "fusion_server/fusion_worker.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <deque>
#include <opencv2/core.hpp>

#include "codec/image_codec.h"
#include "protocol/clock.h"
#include "protocol/clock_sync.h"

namespace holofuse::fusion {

using protocol::kSourceServer;
using protocol::monotonicNs;
using protocol::Stage;

StatusOr<PodImages> podImagesOf(const protocol::PodFrame& pod, uint64_t wire_bytes,
                                const Camera& camera, uint64_t now_ns,
                                std::optional<int64_t> pod_clock_offset_ns,
                                uint64_t clock_uncertainty_ns) {
  PodImages images;
  images.camera_id = pod.camera_id;
  images.bytes = wire_bytes;
  // Sent when the pod finished its frame: a synthetic pod's encoding, a
  // replay pod's read of the recording. The send stage is the server's to
  // stamp: one a pod put in its frame is not kept.
  uint64_t pod_sent = pod.capture_time_ns;
  for (const auto& s : pod.stamps) {
    if (s.stage == static_cast<uint16_t>(protocol::Stage::kPodEncode) ||
        s.stage == static_cast<uint16_t>(protocol::Stage::kReplayRead)) {
      pod_sent = s.end_ns;
    }
  }
  images.pod_sent_ns = pod_sent;
  images.arrival_ns = now_ns;
  if (pod_clock_offset_ns) {
    images.capture_time_ns = protocol::shiftedNs(pod.capture_time_ns, *pod_clock_offset_ns);
    for (const auto& s : pod.stamps) {
      if (s.stage == static_cast<uint16_t>(protocol::Stage::kSend)) continue;
      images.stamps.push_back({s.stage, s.source,
                               protocol::shiftedNs(s.start_ns, *pod_clock_offset_ns),
                               protocol::shiftedNs(s.end_ns, *pod_clock_offset_ns)});
    }
    images.sent_ns = protocol::shiftedNs(pod_sent, *pod_clock_offset_ns);
    const bool within_uncertainty =
        images.sent_ns > now_ns && images.sent_ns - now_ns <= clock_uncertainty_ns;
    images.stamps.push_back({static_cast<uint16_t>(protocol::Stage::kSend),
                             static_cast<uint16_t>(pod.camera_id),
                             within_uncertainty ? now_ns : images.sent_ns, now_ns});
  } else {
    images.capture_time_ns = now_ns;
    images.sent_ns = now_ns;
  }
  images.camera = camera;  // the calibration these images belong to
  for (const auto& plane : pod.planes) {
    // Checked against the calibration before anything is decompressed: the
    // planes are the image, or a rectangle of it at the frame's offset.
    if (!cropFits(pod.offset_x, pod.offset_y, plane.width, plane.height, camera.width,
                  camera.height) ||
        (pod.planes.front().width != plane.width || pod.planes.front().height != plane.height)) {
      return Status(StatusCode::kMalformed,
                    "plane " + std::to_string(static_cast<int>(plane.kind)) + " is " +
                        std::to_string(plane.width) + "x" + std::to_string(plane.height) + " at (" +
                        std::to_string(pod.offset_x) + ", " + std::to_string(pod.offset_y) +
                        "), calibration says " + std::to_string(camera.width) + "x" +
                        std::to_string(camera.height));
    }
    auto image = decodePlane(plane);
    if (!image.isOk()) return image.status();
    switch (plane.kind) {
      case protocol::PlaneKind::kColor:
        images.color = std::move(*image);
        break;
      case protocol::PlaneKind::kMask:
        images.mask = std::move(*image);
        break;
      case protocol::PlaneKind::kFeather:
        images.feather = std::move(*image);
        break;
      case protocol::PlaneKind::kDepth:   // not used by the hull yet
      case protocol::PlaneKind::kCamera:  // a texture layer's: not a pod's
        break;
    }
  }
  if (images.color.channels != 3 || images.mask.channels != 1 || images.feather.channels != 1) {
    return Status(StatusCode::kMalformed,
                  "PodFrame needs an RGB colour, a grey mask and a grey feather plane");
  }
  images.offset_x = pod.offset_x;
  images.offset_y = pod.offset_y;
  images.stamps.push_back({static_cast<uint16_t>(protocol::Stage::kServerDecode),
                           static_cast<uint16_t>(pod.camera_id), now_ns, monotonicNs()});
  return images;
}

std::vector<hull::HullView> hullViewsOf(const FrameGroup& group) {
  std::vector<hull::HullView> views;
  for (const auto& [camera_id, pod] : group.pods) {
    // The hull samples whole silhouettes: a rectangle goes back into its
    // frame, in the calibration stored with the images (a newer one may
    // have other sizes).
    const bool whole = pod.offset_x == 0 && pod.offset_y == 0 &&
                       pod.mask.width == pod.camera.width && pod.mask.height == pod.camera.height;
    views.push_back(whole ? hull::HullView{pod.camera, pod.mask, pod.feather}
                          : hull::HullView{pod.camera,
                                           placeInFrame(pod.mask, pod.offset_x, pod.offset_y,
                                                        pod.camera.width, pod.camera.height),
                                           placeInFrame(pod.feather, pod.offset_x, pod.offset_y,
                                                        pod.camera.width, pod.camera.height)});
  }
  return views;
}

std::vector<Image8> colorsInFrame(const FrameGroup& group) {
  std::vector<Image8> colors;
  colors.reserve(group.pods.size());
  for (const auto& [camera_id, pod] : group.pods) {
    colors.push_back(pod.offset_x == 0 && pod.offset_y == 0 &&
                             pod.color.width == pod.camera.width &&
                             pod.color.height == pod.camera.height
                         ? pod.color
                         : placeInFrame(pod.color, pod.offset_x, pod.offset_y, pod.camera.width,
                                        pod.camera.height));
  }
  return colors;
}

FusedMesh carveHull(const std::vector<hull::HullView>& views, const hull::HullOptions& hull,
                    hull::HullStats* stats) {
  FusedMesh fused;
  fused.carve_start_ns = monotonicNs();
  fused.carved = hull::carveVisualHull(views, hull, stats);
  fused.carve_end_ns = monotonicNs();
  return fused;
}

bool refines(const PhotoRefineOptions& refine) { return refine.depth_voxels > 0; }

void refineFused(FusedMesh& fused, const std::vector<hull::HullView>& views,
                 const std::vector<Image8>& colors, const PhotoRefineOptions& refine,
                 double voxel_size) {
  if (!refines(refine)) return;
  fused.refine_start_ns = monotonicNs();
  PhotoRefineOptions at_voxel = refine;
  at_voxel.voxel_size = voxel_size;  // this frame's, under an error target
  fused.refined = refineByPhotoConsistency(fused.carved, views, colors, at_voxel);
  fused.refine_end_ns = monotonicNs();
}

// All of fuseGroup but the layers: the mesh carved (and refined) and
// encoded with the images. error: measured where the settings follow an
// error target.
EncodedGroup carveAndEncode(const GroupJob& job, const FusionSettings& settings,
                            hull::SilhouetteError& error) {
  const std::vector<hull::HullView> views = hullViewsOf(job.group);
  FusedMesh fused = carveHull(views, settings.hull);
  if (refines(settings.refine)) {
    refineFused(fused, views, colorsInFrame(job.group), settings.refine, settings.hull.voxel_size);
  }
  EncodedGroup encoded = encodeFused(job, settings, fused.mesh(), fused.carve_start_ns,
                                     fused.carve_end_ns, fused.refine_end_ns);
  // Measured after the encodes (not part of the hull's time): it only
  // steers the next frame's voxel, which is the carved hull's.
  if (settings.hull_error_target > 0) error = hull::silhouetteError(fused.carved, views);
  return encoded;
}

FusedOutput fuseGroup(const GroupJob& job, const FusionSettings& settings,
                      const LayerRequest& layers) {
  hull::SilhouetteError error;
  FusedOutput out = finishFused(job, settings, carveAndEncode(job, settings, error), layers);
  out.silhouette_error = error;
  return out;
}

namespace {

// The pods' images of a group, compressed for the clients: the current
// bundle and 1.1's, which has no feather maps.
void encodeImages(const FrameGroup& group, const FusionSettings& settings,
                  std::deque<std::vector<uint8_t>>& storage, protocol::TextureBundle& bundle,
                  protocol::TextureBundle& bundle_v1_1) {
  for (const auto& [camera_id, pod] : group.pods) {
    protocol::BundleImage image;
    image.camera_id = camera_id;
    image.offset_x = pod.offset_x;  // clients get the rectangle too
    image.offset_y = pod.offset_y;
    storage.emplace_back();
    image.planes.push_back(encodePlane(pod.color, protocol::PlaneKind::kColor, settings.image_codec,
                                       storage.back(), settings.lz4_acceleration,
                                       settings.lz4_hc_level));
    storage.emplace_back();
    image.planes.push_back(encodePlane(pod.mask, protocol::PlaneKind::kMask, protocol::Codec::kLz4,
                                       storage.back(), settings.lz4_acceleration,
                                       settings.lz4_hc_level));
    // Since 1.2 the pod's feather map goes on too, cropped as its image
    // (paper 004 weighs each pod by it at every fragment).
    bundle_v1_1.images.push_back(image);
    storage.emplace_back();
    image.planes.push_back(encodePlane(pod.feather, protocol::PlaneKind::kFeather,
                                       protocol::Codec::kLz4, storage.back(),
                                       settings.lz4_acceleration, settings.lz4_hc_level));
    bundle.images.push_back(std::move(image));
  }
}

// Texture layers in place of the images, for the clients that asked: laid
// out and filled in their own stage after the images' (images_end_ns), the
// video coded in its own. Why they were not built goes in out.layers_note.
void buildLayerBundles(const FrameGroup& group, const FusionSettings& settings,
                       const StatusOr<std::vector<uint8_t>>& encoded, const LayerRequest& layers,
                       uint64_t images_end_ns, std::deque<std::vector<uint8_t>>& storage,
                       FusedOutput& out, std::optional<protocol::TextureBundle>& layered,
                       std::optional<protocol::TextureBundle>& layer_video) {
  // Charts are placed by positions: the mesh as every client decodes it.
  StatusOr<Mesh> received = encoded.isOk()
                                ? decodeMesh(settings.mesh_codec, encoded->data(), encoded->size())
                                : StatusOr<Mesh>(encoded.status());
  Status built = !received.isOk() ? received.status()
                                  : layers.stage->build(group, *received, settings.hull,
                                                        settings.layers, &out.layer_stats);
  const uint64_t t4 = monotonicNs();
  if (built.isOk() && layers.lz4) {
    layered.emplace();
    layered->frame_id = group.frame_id;
    layers.stage->encodeLz4(settings.image_codec, settings.lz4_acceleration, settings.lz4_hc_level,
                            *layered, storage);
  }
  const uint64_t t5 = monotonicNs();
  if (built.isOk() && layers.video) {
    layer_video.emplace();
    layer_video->frame_id = group.frame_id;
    built =
        layers.stage->encodeVideo(layers.video_key_frame, *layer_video, storage, &out.layer_stats);
    if (built.isOk()) {
      const uint64_t t6 = monotonicNs();
      layer_video->stamps = {
          {static_cast<uint16_t>(Stage::kLayers), kSourceServer, images_end_ns, t4},
          {static_cast<uint16_t>(Stage::kLayerVideo), kSourceServer, t5, t6},
          {static_cast<uint16_t>(Stage::kFanout), kSourceServer, t6, 0}};
    } else {
      layer_video.reset();
    }
  }
  if (layered) {
    layered->stamps = {{static_cast<uint16_t>(Stage::kLayers), kSourceServer, images_end_ns, t5},
                       {static_cast<uint16_t>(Stage::kFanout), kSourceServer, t5, 0}};
  }
  if (!built.isOk()) out.layers_note = built.message();
}

// The frame's Stats: who was present, what came late or was dropped, and
// which cameras it went without.
protocol::Stats statsOf(const GroupJob& job, const FusionSettings& settings, uint64_t present,
                        uint64_t pod_bytes) {
  const FrameGroup& group = job.group;
  protocol::Stats stats;
  stats.frame_id = group.frame_id;
  stats.cameras_expected = settings.pods_expected;
  stats.cameras_present = present;
  stats.cameras_present_count = static_cast<uint32_t>(group.pods.size());
  stats.late_frames = job.late_frames;
  stats.dropped_groups = job.dropped_groups;
  stats.pod_bytes = pod_bytes;
  if (!group.complete) {
    std::string missing;
    for (uint32_t i = 0; i < settings.pods_expected; ++i) {
      if (!group.pods.count(i)) missing += (missing.empty() ? "" : ",") + std::to_string(i);
    }
    // A group that went out because its pods left (end of a replay) may
    // still hold every camera.
    if (!missing.empty())
      stats.note = "proceeded without camera(s) " + missing + " after the sync deadline";
  }
  return stats;
}

}  // namespace

DracoOptions dracoOnHullLattice(DracoOptions draco, const hull::HullOptions& hull) {
  const glm::u64vec3 lattice = hull::keyLattice(hull);
  draco.key_lattice = {lattice.x, lattice.y};
  draco.edge_origin = {hull.volume_min.x, hull.volume_min.y, hull.volume_min.z};
  draco.edge_spacing = hull.voxel_size;
  return draco;
}

EncodedGroup encodeFused(const GroupJob& job, const FusionSettings& settings, const Mesh& mesh,
                         uint64_t hull_start_ns, uint64_t hull_end_ns, uint64_t refine_end_ns) {
  const FrameGroup& group = job.group;
  EncodedGroup encoded;
  std::vector<protocol::StageStamp> stamps;
  uint64_t capture_time = UINT64_MAX;
  for (const auto& [camera_id, pod] : group.pods) {
    stamps.insert(stamps.end(), pod.stamps.begin(), pod.stamps.end());
    capture_time = std::min(capture_time, pod.capture_time_ns);
    encoded.pod_bytes += pod.bytes;
    if (camera_id < 64) encoded.present |= uint64_t{1} << camera_id;
  }
  stamps.push_back({static_cast<uint16_t>(Stage::kSyncWait), kSourceServer, group.first_arrival_ns,
                    group.emitted_ns});
  stamps.push_back(
      {static_cast<uint16_t>(Stage::kHull), kSourceServer, hull_start_ns, hull_end_ns});
  const uint64_t mesh_ready_ns = refine_end_ns != 0 ? refine_end_ns : hull_end_ns;
  if (refine_end_ns != 0)
    stamps.push_back(
        {static_cast<uint16_t>(Stage::kRefine), kSourceServer, hull_end_ns, refine_end_ns});
  DracoOptions draco = dracoOnHullLattice(settings.draco, settings.hull);
  if (job.coordinates_for_older) draco.edge_spacing = 0;
  encoded.mesh = encodeMesh(settings.mesh_codec, mesh, draco);
  // Clients before 1.7 decode Draco only, and before 1.11 its keys as halves.
  encoded.draco_apart =
      job.draco_for_older ||
      (settings.mesh_codec == protocol::MeshCodec::kDraco && job.key_halves_for_older);
  if (encoded.draco_apart) encoded.draco = encodeDraco(mesh, settings.draco);
  const uint64_t t2 = monotonicNs();
  stamps.push_back({static_cast<uint16_t>(Stage::kMeshEncode), kSourceServer, mesh_ready_ns, t2});

  encoded.bundle.frame_id = encoded.bundle_v1_1.frame_id = group.frame_id;
  encoded.storage = std::make_shared<std::deque<std::vector<uint8_t>>>();
  encodeImages(group, settings, *encoded.storage, encoded.bundle, encoded.bundle_v1_1);
  const uint64_t t3 = monotonicNs();
  encoded.images_end_ns = t3;
  encoded.bundle.stamps = {{static_cast<uint16_t>(Stage::kImageEncode), kSourceServer, t2, t3},
                           {static_cast<uint16_t>(Stage::kFanout), kSourceServer, t3, 0}};
  encoded.bundle_v1_1.stamps = encoded.bundle.stamps;
  stamps.push_back({static_cast<uint16_t>(Stage::kFanout), kSourceServer, t3, 0});

  protocol::MeshFrame& mesh_frame = encoded.mesh_frame;
  mesh_frame.frame_id = group.frame_id;
  mesh_frame.capture_time_ns = capture_time == UINT64_MAX ? group.first_arrival_ns : capture_time;
  const Bounds bounds = meshBounds(mesh);
  for (int k = 0; k < 3; ++k) {
    mesh_frame.bounds_min[k] = bounds.min[k];
    mesh_frame.bounds_max[k] = bounds.max[k];
  }
  mesh_frame.vertex_count = static_cast<uint32_t>(mesh.vertexCount());
  mesh_frame.triangle_count = static_cast<uint32_t>(mesh.triangleCount());
  mesh_frame.stamps = std::move(stamps);
  return encoded;
}

FusedOutput finishFused(const GroupJob& job, const FusionSettings& settings, EncodedGroup encoded,
                        const LayerRequest& layers) {
  const FrameGroup& group = job.group;
  FusedOutput out;
  out.frame_id = group.frame_id;
  out.voxel_size = settings.hull.voxel_size;
  std::optional<protocol::TextureBundle> layered, layer_video;
  if (layers.wanted()) {
    buildLayerBundles(group, settings, encoded.mesh, layers, encoded.images_end_ns,
                      *encoded.storage, out, layered, layer_video);
  }
  std::optional<protocol::TextureBundle> layered_v1_10, layer_video_v1_10;
  if (layers.lz4_camera_planes) {
    if (layered) layered_v1_10 = layers.stage->withLz4CameraPlanes(*layered, *encoded.storage);
    if (layer_video)
      layer_video_v1_10 = layers.stage->withLz4CameraPlanes(*layer_video, *encoded.storage);
  }
  protocol::Stats stats = statsOf(job, settings, encoded.present, encoded.pod_bytes);
  if (!encoded.mesh.isOk())
    stats.note += (stats.note.empty() ? "" : "; ") + encoded.mesh.status().message();
  else if (!encoded.draco.isOk())
    stats.note += (stats.note.empty() ? "" : "; ") + encoded.draco.status().message();
  if (!out.layers_note.empty()) stats.note += (stats.note.empty() ? "" : "; ") + out.layers_note;

  auto share = [](protocol::OutgoingFrame frame) {
    return std::make_shared<const protocol::OutgoingFrame>(std::move(frame));
  };
  const auto& storage = encoded.storage;
  // One sequence number for both spellings of the bundle, as for the Stats.
  const uint64_t bundle_sequence = protocol::nextSequence();
  out.texture_bundle = share(protocol::encodeOutgoing(encoded.bundle, bundle_sequence, storage));
  out.texture_bundle_v1_1 =
      share(protocol::encodeOutgoing(encoded.bundle_v1_1, bundle_sequence, storage, 1));
  if (layered)
    out.texture_bundle_layers = share(protocol::encodeOutgoing(*layered, bundle_sequence, storage));
  if (layer_video)
    out.texture_bundle_layer_video =
        share(protocol::encodeOutgoing(*layer_video, bundle_sequence, storage));
  if (layered_v1_10)
    out.texture_bundle_layers_v1_10 =
        share(protocol::encodeOutgoing(*layered_v1_10, bundle_sequence, storage, 10));
  if (layer_video_v1_10)
    out.texture_bundle_layer_video_v1_10 =
        share(protocol::encodeOutgoing(*layer_video_v1_10, bundle_sequence, storage, 10));
  out.texture_bundle_v1_2 =
      encoded.bundle.images.size() > protocol::kMaxCamerasBefore13
          ? share(protocol::encodeOutgoing(encoded.bundle, bundle_sequence, storage, 2))
          : out.texture_bundle;
  // The mesh bytes are borrowed by the frame, as the images are; one
  // sequence number for both spellings.
  const uint64_t mesh_sequence = protocol::nextSequence();
  auto frameOf = [&](StatusOr<std::vector<uint8_t>>& bytes, protocol::MeshCodec codec) {
    auto kept =
        bytes.isOk() ? std::make_shared<const std::vector<uint8_t>>(std::move(*bytes)) : nullptr;
    protocol::MeshFrame spelt = encoded.mesh_frame;
    spelt.codec = codec;
    if (kept) spelt.mesh = *kept;
    return share(protocol::encodeOutgoing(spelt, mesh_sequence, kept));
  };
  out.mesh_frame = frameOf(encoded.mesh, settings.mesh_codec);
  if (encoded.draco_apart)
    out.mesh_frame_draco = frameOf(encoded.draco, protocol::MeshCodec::kDraco);
  out.mesh_frame_v1_10 =
      settings.mesh_codec == protocol::MeshCodec::kDraco ? out.mesh_frame_draco : out.mesh_frame;
  // One sequence number for both: it is one frame, spelt per minor.
  const uint64_t stats_sequence = protocol::nextSequence();
  stats.pod_arrivals = job.pod_arrivals;
  out.stats = share(protocol::encodeOutgoing(stats, stats_sequence));
  out.stats_v1_7 = share(protocol::encodeOutgoing(stats, stats_sequence, nullptr, 7));
  out.stats_v1_2 = share(protocol::encodeOutgoing(stats, stats_sequence, nullptr, 2));
  out.stats_v1_0 = share(protocol::encodeOutgoing(stats, stats_sequence, nullptr, 0));
  out.triangles = encoded.mesh_frame.triangle_count;
  return out;
}

FusedOutput packageFused(const GroupJob& job, const FusionSettings& settings, const Mesh& mesh,
                         uint64_t hull_start_ns, uint64_t hull_end_ns, uint64_t refine_end_ns,
                         const LayerRequest& layers) {
  return finishFused(job, settings,
                     encodeFused(job, settings, mesh, hull_start_ns, hull_end_ns, refine_end_ns),
                     layers);
}

int fusionThreads(const FusionSettings& settings) {
  if (settings.threads > 0) return settings.threads;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

FusionWorker::FusionWorker(FusionSettings settings, int wake_fd, bool lossless)
    : settings_(std::move(settings)), wake_fd_(wake_fd), lossless_(lossless) {
  if (settings_.hull_error_target > 0) {
    voxel_.emplace(settings_.hull_error_target, settings_.hull.voxel_size,
                   settings_.hull.voxel_size);
  }
  const int threads = fusionThreads(settings_);
  // OpenCV's own loops (the hull's distance transforms) run in OpenCV's
  // TBB arena, sized to every core and outside ours: with one fusion
  // thread they still took a second core (8 pods at 640x480: 70 ms of CPU
  // per 62 ms frame), and with N they competed with the N. Run serially,
  // inside the hull's loop over the views, they are bounded by the
  // fusion's threads like the rest of its work.
  cv::setNumThreads(1);
  arena_ = std::make_unique<tbb::task_arena>(threads);
  for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { run(); });
}

size_t FusionWorker::queuedJobs() {
  std::lock_guard<std::mutex> lock(mutex_);
  return waiting_.size() + busy_ + encoded_.size();
}

const protocol::SharedFrame& FusedOutput::bundleFor(PeerCapabilities::Bundle layout) const {
  using Bundle = PeerCapabilities::Bundle;
  return layout == Bundle::kCurrent ? texture_bundle
         : layout == Bundle::kV1_2  ? texture_bundle_v1_2
                                    : texture_bundle_v1_1;
}

const protocol::SharedFrame& FusedOutput::statsFor(PeerCapabilities::Stats layout) const {
  using Stats = PeerCapabilities::Stats;
  return layout == Stats::kCurrent ? stats
         : layout == Stats::kV1_7  ? stats_v1_7
         : layout == Stats::kV1_2  ? stats_v1_2
                                   : stats_v1_0;
}

size_t FusionWorker::jobsNotTaken() {
  std::lock_guard<std::mutex> lock(mutex_);
  return waiting_.size() + busy_ + encoded_.size() + outputs_.size();
}

FusionWorker::~FusionWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  for (std::thread& thread : threads_) thread.join();
}

void FusionWorker::submit(GroupJob job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!lossless_ && !waiting_.empty()) {
      ++replaced_;
      waiting_.clear();
    }
    waiting_.push_back(std::move(job));
  }
  cv_.notify_one();
}

FusionWorker::Overlap FusionWorker::overlap() {
  std::lock_guard<std::mutex> lock(mutex_);
  return overlap_;
}

std::vector<FusedOutput> FusionWorker::takeOutputs() {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::move(outputs_);
}

std::optional<FusionWorker::Taken> FusionWorker::take() {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return stop_ || !waiting_.empty(); });
  if (stop_) return std::nullopt;
  Taken taken;
  taken.job = std::move(waiting_.front());
  waiting_.pop_front();
  taken.turn = next_turn_++;
  ++busy_;
  // The settings of the moment the group is taken: the voxel the error
  // target steers to (as the groups before it observed), the layers the
  // clients want.
  taken.settings = settings_;
  if (voxel_) taken.settings.hull.voxel_size = voxel_->voxel();
  taken.settings.layers.charts_face_surface_around = !layers_own_normal_charts_;
  taken.layers = {&layer_stage_, layers_lz4_, layers_video_, false, layers_lz4_camera_planes_};
  if (taken.layers.video) taken.layers.video_key_frame = video_key_frame_.exchange(false);
  return taken;
}

void FusionWorker::encode(Taken& taken) {
  taken.started_ns = monotonicNs();
  try {
    // The arena bounds this group's parallel loops, and the other groups',
    // to the fusion's threads.
    arena_->execute(
        [&] { taken.encoded = carveAndEncode(taken.job, taken.settings, taken.error); });
  } catch (const std::exception& e) {
    // One group that cannot be fused (memory for a hostile calibration's
    // image size, say) costs that frame, not the server.
    std::fprintf(stderr, "[server] frame %llu not fused: %s\n",
                 static_cast<unsigned long long>(taken.job.group.frame_id), e.what());
  }
}

std::optional<FusedOutput> FusionWorker::finish(Taken& taken) {
  if (!taken.encoded) return std::nullopt;
  try {
    FusedOutput out =
        finishFused(taken.job, taken.settings, std::move(*taken.encoded), taken.layers);
    out.silhouette_error = taken.error;
    return out;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[server] frame %llu not fused: %s\n",
                 static_cast<unsigned long long>(taken.job.group.frame_id), e.what());
    return std::nullopt;
  }
}

void FusionWorker::deliver(Taken taken) {
  // In the order the groups were taken: the layers keep their atlas and
  // video from frame to frame, the voxel follows the frames in order, and
  // clients get the frames in order.
  std::unique_lock<std::mutex> lock(mutex_);
  --busy_;
  encoded_.emplace(taken.turn, std::move(taken));
  if (finishing_) return;  // the thread finishing in order takes it up
  finishing_ = true;
  bool delivered = false;
  while (!stop_ && !encoded_.empty() && encoded_.begin()->first == turn_) {
    // The group stays in encoded_ while it is finished outside the lock
    // (other threads only add later turns): queuedJobs() counts it until
    // its output is in, or a server waiting for the last frames would
    // see nothing queued and stop without it.
    const auto next_it = encoded_.begin();
    Taken& next = next_it->second;
    lock.unlock();
    std::optional<FusedOutput> out = finish(next);
    const uint64_t finished_ns = monotonicNs();
    lock.lock();
    if (out) {
      if (last_finished_ns_) {
        ++overlap_.pairs;
        overlap_.at_once += next.started_ns < *last_finished_ns_;
      }
      last_finished_ns_ = finished_ns;
    }
    if (out && voxel_ && voxel_->observe(out->silhouette_error)) {
      std::fprintf(stderr,
                   "[server] hull voxel %.1f -> %.1f mm: silhouette error %.2f mm against the "
                   "target of %.2f mm%s\n",
                   1000 * next.settings.hull.voxel_size, 1000 * voxel_->voxel(),
                   1000 * out->silhouette_error.mean_m, 1000 * settings_.hull_error_target,
                   voxel_->unreachable()
                       ? " (out of reach: a finer voxel did not help, the silhouettes disagree)"
                       : "");
    }
    if (out) {
      outputs_.push_back(std::move(*out));
      delivered = true;
    }
    encoded_.erase(next_it);
    ++turn_;
  }
  finishing_ = false;
  lock.unlock();
  if (!delivered) return;
  const uint64_t one = 1;
  if (::write(wake_fd_, &one, sizeof(one)) < 0) {
    // The eventfd counter cannot overflow at our rates; nothing to do.
  }
}

void FusionWorker::run() {
  while (std::optional<Taken> taken = take()) {
    encode(*taken);
    deliver(std::move(*taken));
  }
}

}  // namespace holofuse::fusion
