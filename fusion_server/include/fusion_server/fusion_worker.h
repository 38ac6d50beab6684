// FusionWorker turns frame groups into the frames every client gets
// (MeshFrame, TextureBundle, Stats) on threads of its own, so the I/O loop
// keeps serving pods and clients while hulls are carved. Several groups are
// fused at once, one per thread, and each group's hull and marching cubes
// spread over the same threads (oneTBB); the outputs come out in the order
// the groups went in. One group waits at most: a newer group replaces a
// waiting one (counted as dropped).
#pragma once

#include <tbb/task_arena.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "codec/mesh_codec.h"
#include "config/settings.h"
#include "fusion_server/frame_sync.h"
#include "fusion_server/layer_stage.h"
#include "fusion_server/peer_capabilities.h"
#include "fusion_server/photo_refine.h"
#include "geometry/camera.h"
#include "hull/hull_error.h"
#include "hull/visual_hull.h"
#include "protocol/connection.h"

namespace holofuse::fusion {

struct FusionSettings {
  hull::HullOptions hull;
  // Metres of silhouette error (hull::silhouetteError) the hull's voxel
  // follows from frame to frame, starting from hull.voxel_size and never
  // coarser; 0: the voxel is fixed.
  double hull_error_target = 0;
  // Photo-consistency refinement of the hull (refine.depth_voxels 0: none);
  // its voxel is the hull's of the frame.
  PhotoRefineOptions refine;
  DracoOptions draco;
  // What the meshes go out as to clients of 1.7 (older ones get Draco):
  // Draco, or half floats through LZ4 (the open Holoportation stack's).
  protocol::MeshCodec mesh_codec = protocol::MeshCodec::kDraco;
  protocol::Codec image_codec = protocol::Codec::kLz4PlanarDelta;
  int lz4_acceleration = 1;  // of the images sent to clients (1 = LZ4's default)
  int lz4_hc_level = 0;      // 0: LZ4's fast mode; 1-12: LZ4HC (codec/image_codec.h)
  uint32_t pods_expected = 0;
  // Texture layers for the clients that ask (protocol 1.5).
  LayerSettings layers;
  // Where the hull is carved: "cpu", or "vulkan" (the program opens the
  // device and sets hull.surface: hull/vulkan_hull_grid.h).
  std::string hull_device = "cpu";
  // Threads that fuse: groups in flight at once, and the threads each
  // group's hull spreads over (0: the machine's cores).
  int threads = 0;
};

// settings.threads, with 0 read as the machine's cores.
int fusionThreads(const FusionSettings& settings);

// The server's flags of FusionSettings (config/settings.h); eval and the
// launcher take the same.
const std::vector<Setting<FusionSettings>>& fusionFlags();

struct FusedOutput {
  uint64_t frame_id = 0;
  // mesh_frame in FusionSettings::mesh_codec (Draco's vertex keys in half
  // steps, protocol 1.11); mesh_frame_draco the same mesh in Draco with
  // its keys as two halves, for a client before 1.7 and, where mesh_frame
  // is Draco, before 1.11 (null when the job did not ask for it);
  // mesh_frame_v1_10 the one for a client of 1.7 to 1.10.
  protocol::SharedFrame mesh_frame, mesh_frame_draco, mesh_frame_v1_10, texture_bundle, stats;
  // The same images without the pods' feather maps, under a 1.1 header,
  // for a peer that agreed on 1.1 or 1.0.
  protocol::SharedFrame texture_bundle_v1_1;
  // For a peer that agreed on 1.2, which takes 64 cameras: the first 64
  // images under a 1.2 header where there are more (else texture_bundle),
  // and the Stats of 1.2 (the first 64 pods' arrivals, no count).
  protocol::SharedFrame texture_bundle_v1_2, stats_v1_2;
  protocol::SharedFrame
      stats_v1_0;  // the same Stats for a peer that agreed on 1.0 (no pod arrivals)
  // For a peer of 1.3 to 1.7: the Stats of 1.7, without the pods' clocks.
  protocol::SharedFrame stats_v1_7;
  // Of the above, the spelling a peer decodes.
  const protocol::SharedFrame& bundleFor(PeerCapabilities::Bundle layout) const;
  const protocol::SharedFrame& statsFor(PeerCapabilities::Stats layout) const;
  // For a client of 1.5 that asked for layers: the frame's texture layers
  // in place of the images; null when no layers were built (none asked,
  // or they were refused: layers_note says why, and such a client gets
  // the images).
  protocol::SharedFrame texture_bundle_layers;
  // For a client of 1.6 that asked for video: the same layers with their
  // colour as video frames (null when not wanted or refused).
  protocol::SharedFrame texture_bundle_layer_video;
  // The two for a client of 1.5 to 1.10: camera planes LZ4, not Zstandard
  // (null unless such a client asked).
  protocol::SharedFrame texture_bundle_layers_v1_10, texture_bundle_layer_video_v1_10;
  std::string layers_note;
  LayerStats layer_stats;
  size_t triangles = 0;
  double voxel_size = 0;
  hull::SilhouetteError silhouette_error;  // measured only under an error target
};

struct GroupJob {
  FrameGroup group;
  uint64_t late_frames = 0;
  uint64_t dropped_groups = 0;
  std::vector<protocol::PodArrivals>
      pod_arrivals;  // every pod's so far, when the group was dispatched
  // A client before 1.7 is connected: the mesh in Draco with its keys as
  // two halves too. One before 1.11: the same where the server's codec is
  // Draco. One before 1.13: the mesh as coordinates for every client (one
  // mesh for all, so that each layered client lays its charts out on the
  // mesh the layers were built on).
  bool draco_for_older = false;
  bool key_halves_for_older = false;
  bool coordinates_for_older = false;
};

// A pod's frame as the fusion takes it: its planes decoded (the whole image
// or the rectangle the pod sent, checked against camera, the calibration in
// force) and its stamps with the send stage ending at now_ns (its arrival)
// and the server_decode stage from then to the end of its decoding. The
// pod's times (its stamps and capture time) come onto the server's clock:
// pod_clock_offset_ns is the pod's clock minus the server's
// (protocol/clock_sync.h; 0 on one host). Without it (a pod not measured
// yet) the pod's stamps are left out and its capture time is taken as the
// arrival, the latest it can have been. A send that ends before it starts
// by no more than the offset's uncertainty is a transit shorter than the
// clocks can tell apart (loopback: about 0.1 ms): it is stamped 0, not
// left out, which would bias the stage's percentiles up. An error names
// the plane that does not fit or the plane that is missing.
StatusOr<PodImages> podImagesOf(const protocol::PodFrame& pod, uint64_t wire_bytes,
                                const Camera& camera, uint64_t now_ns,
                                std::optional<int64_t> pod_clock_offset_ns = 0,
                                uint64_t clock_uncertainty_ns = 0);

// The group's silhouettes and feather maps as whole images, for the hull.
std::vector<hull::HullView> hullViewsOf(const FrameGroup& group);
// The group's colour images as whole images, in hullViewsOf's order.
std::vector<Image8> colorsInFrame(const FrameGroup& group);

// Which texture layers a frame needs: built in stage (which keeps the
// atlas and the video streams from frame to frame; null: none asked), with
// LZ4 colour (clients of 1.5) and as video (clients of 1.6 that decode it),
// the video at a key frame when video_key_frame.
struct LayerRequest {
  LayerStage* stage = nullptr;
  bool lz4 = false, video = false, video_key_frame = false;
  bool lz4_camera_planes = false;  // a client before 1.11 takes them
  bool wanted() const { return stage != nullptr && (lz4 || video); }
};

// A group's mesh as the server fuses it, each step with its clock: the
// visual hull carved from the silhouettes (carveHull), then refined by
// photo-consistency at the hull's voxel where the settings refine
// (refineFused). fuseGroup runs the two; eval runs the same two on its
// frames, so that its meshes and their times are the loop's.
struct FusedMesh {
  Mesh carved;
  std::optional<Mesh> refined;  // none: not refined
  uint64_t carve_start_ns = 0, carve_end_ns = 0;
  uint64_t refine_start_ns = 0, refine_end_ns = 0;
  const Mesh& mesh() const { return refined ? *refined : carved; }
  double carveMs() const { return 1e-6 * static_cast<double>(carve_end_ns - carve_start_ns); }
  double refineMs() const { return 1e-6 * static_cast<double>(refine_end_ns - refine_start_ns); }
};
FusedMesh carveHull(const std::vector<hull::HullView>& views, const hull::HullOptions& hull,
                    hull::HullStats* stats = nullptr);
// Whether refine refines at all (depth_voxels > 0).
bool refines(const PhotoRefineOptions& refine);
// colors: the views' colour images in whole frames, in their order
// (colorsInFrame), read only where refine refines.
void refineFused(FusedMesh& fused, const std::vector<hull::HullView>& views,
                 const std::vector<Image8>& colors, const PhotoRefineOptions& refine,
                 double voxel_size);
// draco with the vertex keys in half steps on the lattice of hull's
// volume (DracoOptions::key_lattice, protocol 1.11) and the positions as
// places along the keys' edges (DracoOptions::edge_bits, 1.13), as the
// server sends a hull's mesh to clients of 1.13.
DracoOptions dracoOnHullLattice(DracoOptions draco, const hull::HullOptions& hull);

// The whole fusion of one group, callable without the thread (tests).
FusedOutput fuseGroup(const GroupJob& job, const FusionSettings& settings,
                      const LayerRequest& layers = {});

// A group's mesh and images encoded for the clients, before the texture
// layers: what encodeFused makes side by side with other groups, and
// finishFused completes in frame order (the layers keep their atlas and
// video from frame to frame).
struct EncodedGroup {
  StatusOr<std::vector<uint8_t>> mesh = std::vector<uint8_t>{};
  StatusOr<std::vector<uint8_t>> draco = std::vector<uint8_t>{};
  bool draco_apart = false;  // draco holds the mesh for clients before 1.7 (or 1.11)
  protocol::TextureBundle bundle, bundle_v1_1;
  // The compressed images and the Draco bytes are borrowed by the frames
  // (fanned out to every client without a copy) and live as long as they do.
  std::shared_ptr<std::deque<std::vector<uint8_t>>> storage;
  protocol::MeshFrame mesh_frame;  // all but the codec and the bytes
  uint64_t images_end_ns = 0;
  uint64_t present = 0;  // bits of cameras 0..63, as 1.0 to 1.2 read them
  uint64_t pod_bytes = 0;
};

// What fuseGroup sends for a given mesh (carved from hull_start_ns to
// hull_end_ns, refined from then to refine_end_ns; refine_end_ns 0: not
// refined, no refine stage): the MeshFrame, the TextureBundle of the pods' images
// re-encoded for clients, and the Stats. The evaluation packs its own
// meshes with it, so that its bytes and codec times are the loop's. It is
// encodeFused, then finishFused.
FusedOutput packageFused(const GroupJob& job, const FusionSettings& settings, const Mesh& mesh,
                         uint64_t hull_start_ns, uint64_t hull_end_ns, uint64_t refine_end_ns = 0,
                         const LayerRequest& layers = {});
EncodedGroup encodeFused(const GroupJob& job, const FusionSettings& settings, const Mesh& mesh,
                         uint64_t hull_start_ns, uint64_t hull_end_ns, uint64_t refine_end_ns);
FusedOutput finishFused(const GroupJob& job, const FusionSettings& settings, EncodedGroup encoded,
                        const LayerRequest& layers);

class FusionWorker {
 public:
  // wake_fd is written (8 bytes, eventfd style) whenever output is ready.
  // lossless: groups queue instead of replacing the waiting one (the
  // caller applies backpressure with queuedJobs()).
  FusionWorker(FusionSettings settings, int wake_fd, bool lossless = false);
  ~FusionWorker();

  void submit(GroupJob job);
  // The fused groups not taken yet, in the order they were submitted.
  std::vector<FusedOutput> takeOutputs();
  uint64_t replacedJobs() const { return replaced_; }
  // Of the groups delivered after another, those whose fusion began before
  // the one before them was finished: the overlap --fusion-threads buys,
  // counted over every group (a client sees only the frames it took).
  struct Overlap {
    uint64_t pairs = 0, at_once = 0;
  };
  Overlap overlap();
  // Groups fused at once at most (FusionSettings::threads).
  int threads() const { return static_cast<int>(threads_.size()); }
  // Groups submitted and not yet fused (waiting or in progress).
  size_t queuedJobs();
  // Those and the fused groups whose output is not yet taken.
  size_t jobsNotTaken();
  // What the connected clients asked for: texture layers with LZ4 colour
  // (lz4) or as video, and what the older of them decode: the next groups
  // build them so (the server sets it as clients come and go).
  struct LayersWanted {
    bool lz4 = false, video = false;
    bool lz4_camera_planes = false;  // a client before 1.11
    bool own_normal_charts = false;  // a client before 1.12: every client's charts so
  };
  void setLayersWanted(const LayersWanted& wanted) {
    layers_lz4_ = wanted.lz4;
    layers_video_ = wanted.video;
    layers_lz4_camera_planes_ = wanted.lz4_camera_planes;
    layers_own_normal_charts_ = wanted.own_normal_charts;
  }
  // A client joined the layers' video or missed one of its frames: the next
  // layers start key frames.
  void requestLayerVideoKeyFrame() { video_key_frame_ = true; }

 private:
  // A group taken off the queue, with its place in the output order and
  // the settings it is fused with; encoded once its thread is done.
  struct Taken {
    GroupJob job;
    uint64_t turn = 0;
    FusionSettings settings;
    LayerRequest layers;
    std::optional<EncodedGroup> encoded;  // none: it could not be fused
    hull::SilhouetteError error;
    uint64_t started_ns = 0;  // its fusion began
  };
  std::optional<Taken> take();
  void run();
  void encode(Taken& taken);
  // Hands an encoded group over for output; the thread whose group is next
  // in order finishes it and every later one already encoded, while the
  // others go on to the next group instead of waiting.
  void deliver(Taken taken);
  std::optional<FusedOutput> finish(Taken& taken);

  FusionSettings settings_;
  std::optional<hull::VoxelController> voxel_;  // under an error target
  int wake_fd_;
  std::mutex mutex_;
  std::condition_variable cv_;  // a job waits, or stop_
  bool lossless_;
  std::deque<GroupJob> waiting_;
  std::atomic<bool> layers_lz4_{false}, layers_video_{false}, video_key_frame_{false};
  std::atomic<bool> layers_lz4_camera_planes_{false}, layers_own_normal_charts_{false};
  LayerStage layer_stage_;             // built in order, by one thread at a time
  size_t busy_ = 0;                    // groups being encoded
  uint64_t next_turn_ = 0;             // the next group taken gets this place in the output order
  uint64_t turn_ = 0;                  // the group whose output goes out next
  std::map<uint64_t, Taken> encoded_;  // encoded, waiting for the groups before them
  bool finishing_ = false;             // a thread is finishing groups in order
  std::vector<FusedOutput> outputs_;
  std::optional<uint64_t> last_finished_ns_;  // the group delivered last
  Overlap overlap_;
  bool stop_ = false;
  std::atomic<uint64_t> replaced_{0};
  // The threads the fusion runs on: a group per thread, each group's
  // parallel loops bounded by the arena (oneTBB) to the same count.
  std::unique_ptr<tbb::task_arena> arena_;
  std::vector<std::thread> threads_;
};

}  // namespace holofuse::fusion
