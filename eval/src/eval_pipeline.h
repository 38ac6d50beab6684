// The live loop's path for one frame, in one process and timed per stage
// as the loop times it: pods' capture and encoding, the server's decoding,
// carving, refinement and packing, the client's decoding. What the
// leave-one-out evaluation renders and judges (leave_one_out.cpp).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "eval/leave_one_out.h"
#include "fusion_server/fusion_worker.h"
#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "hull/visual_hull.h"
#include "image/image.h"
#include "protocol/bytes.h"
#include "render_client/renderer.h"
#include "scene/synthetic_scene.h"

namespace holofuse::eval {

using Clock = std::chrono::steady_clock;

inline double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// One frame as the client receives it, and the truth it is judged by.
struct FrameData {
  uint64_t frame_id = 0;
  Mesh mesh;
  // With EvalOptions::hull_without_held_out, per held-out camera (by
  // index): the hull carved without its silhouette, as the client would
  // receive it.
  std::map<int, Mesh> mesh_without;
  std::vector<render::ViewImages>
      views;  // reported calibration, colour, segmented mask: the client's
  std::vector<Image8>
      true_colors;                 // per camera: its whole image, which leave-one-out compares with
  std::vector<Image8> true_masks;  // per camera
  // The pods' segmentation against the truth (synthetic scenes): per
  // camera, its mask's IoU with the true mask; of the true shadow's pixels
  // (studio scenes), how many it took for the subject.
  std::vector<double> mask_iou, mask_iou_agreed;  // alone, and after the rig's agreement
  uint64_t shadow_pixels = 0, shadow_taken = 0;
  std::vector<scene::RenderedView> novel_truth;  // per novel pose (SceneInput::novel_poses)
  double hull_ms = 0;
  double refine_ms = 0;  // the hull's photo-consistency refinement (EvalOptions::refine_voxels)
  // The codecs on the frame's way, per stage (codecStages()): the slowest
  // pod's encoding (pods work in parallel), the server's decoding of every
  // pod frame, its Draco and image encoding for clients, and the client's
  // decoding of both. Transport is not simulated.
  std::map<std::string, double> codec_ms;
  // The stages the live report samples once per pod frame (pod_encode,
  // server_decode): each pod's time, so their p50 and p95 mean what the
  // live report's do.
  std::map<std::string, std::vector<double>> per_pod_ms;
  size_t pod_link_bytes = 0;  // every pod's PodFrame, as the pods send them
  size_t client_link_bytes =
      0;                     // MeshFrame, TextureBundle and Stats, as the server sends each client
  size_t feather_bytes = 0;  // of them, the pods' feather maps (protocol 1.2)
  size_t bundle_bytes = 0;   // of them, the TextureBundle of camera images
  size_t mesh_bytes = 0;     // of them, the MeshFrame
  hull::HullStats hull_stats;
};

// The server's side of one pod frame (protocol bytes, as sent or
// recorded), decoded as fusion_server decodes it, into the frame's group.
// source names where the bytes came from in errors. Returns what the
// group now holds for that camera, or what is wrong with the bytes.
StatusOr<const fusion::PodImages*> receivePodFrame(const protocol::Bytes& wire,
                                                   const Camera& reported,
                                                   const std::string& source,
                                                   fusion::FrameGroup& group, FrameData& frame);

// The server's packing of the group's hull for clients (Draco, the images
// re-encoded) and the client's decoding of it: the frame's mesh and views
// are what a client of the live loop renders, its client-link bytes and
// codec times what the loop spends.
Status sendToClient(fusion::FrameGroup group, const Mesh& hull, const EvalOptions& options,
                    const std::vector<Camera>& reported, FrameData& frame);

// The cameras held out of a scene of that many: limit of them (0: all),
// spread evenly by index.
std::vector<int> heldOutCameras(int cameras, int limit);

// What follows the carving in the server (fusion::refineFused), timed as
// its refine stage, and the meshes the held-out cameras are compared with:
// the mesh the frame sends.
StatusOr<Mesh> refineCarved(const EvalOptions& options, const fusion::FrameGroup& group,
                            const std::vector<hull::HullView>& views, fusion::FusedMesh carved,
                            const hull::HullOptions& hull_options, FrameData& frame);

// One frame of a synthetic scene through the loop's whole path: the pods'
// capture and encoding from the true cameras (reporting the reported
// ones), the server's decoding, carving and refinement, its packing for
// clients and the client's decoding, with the truth it is judged by.
StatusOr<FrameData> prepareFrame(const EvalOptions& options, const scene::SyntheticScene& scene,
                                 const std::vector<Camera>& truth,
                                 const std::vector<Camera>& reported,
                                 const std::vector<Image8>& plates, uint64_t frame_id);

}  // namespace holofuse::eval
