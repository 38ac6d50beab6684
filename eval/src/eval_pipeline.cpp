#include "eval_pipeline.h"

#include <algorithm>
#include <optional>

#include "capture_node/pod.h"
#include "codec/image_codec.h"
#include "codec/mesh_codec.h"
#include "dataset/dataset.h"
#include "fusion_server/photo_refine.h"
#include "hull/mask_agreement.h"
#include "metrics/image_metrics.h"
#include "protocol/clock.h"
#include "render_client/client.h"

namespace holofuse::eval {
namespace {

// One whole protocol frame from bytes that must hold one (this process
// made or recorded them): the transport's parsing, which no codec stage of
// the loop counts.
StatusOr<protocol::Frame> parsedFrame(const protocol::Bytes& wire, const std::string& what) {
  return dataset::parseWholeFrame(wire, what);
}

// status with what prefixed to its message.
Status within(const std::string& what, const Status& status) {
  return Status(status.code(), what + ": " + status.message());
}

// For each camera held out, the mesh its image is compared with where that
// is not the frame's: the hull carved without its silhouette
// (EvalOptions::hull_without_held_out), and refined without its colour
// (the fusion's refine settings), so that beyond its silhouette, which paper
// 000's protocol lets shape the hull, nothing of a held-out image shapes
// what it is compared with. Through the mesh codec, as a client receives a mesh.
StatusOr<std::map<int, Mesh>> meshesForHeldOut(const EvalOptions& options,
                                               const std::vector<hull::HullView>& views,
                                               const std::vector<Image8>& colors, const Mesh& hull,
                                               const hull::HullOptions& hull_options) {
  std::map<int, Mesh> meshes;
  const fusion::PhotoRefineOptions& refine = options.loop.fusion.refine;
  if (!options.hull_without_held_out && !fusion::refines(refine)) return meshes;
  for (int held : heldOutCameras(static_cast<int>(views.size()), options.held_out_cameras)) {
    std::vector<hull::HullView> others = views;
    others.erase(others.begin() + held);
    std::vector<Image8> other_colors;
    if (!colors.empty()) {
      other_colors = colors;
      other_colors.erase(other_colors.begin() + held);
    }
    // The server's fusion of the other cameras (fusion_server/fusion_worker.h).
    fusion::FusedMesh without;
    if (options.hull_without_held_out) {
      without = fusion::carveHull(others, hull_options);
    } else {
      without.carved = hull;
    }
    fusion::refineFused(without, others, other_colors, refine, hull_options.voxel_size);
    const Mesh& mesh = without.mesh();
    const protocol::MeshCodec codec = options.loop.fusion.mesh_codec;
    // As the server spells it (encodeFused).
    auto bytes = encodeMesh(codec, mesh,
                            fusion::dracoOnHullLattice(options.loop.fusion.draco, hull_options));
    auto decoded = bytes.isOk() ? decodeMesh(codec, bytes->data(), bytes->size()) : bytes.status();
    if (!decoded.isOk()) {
      return within(
          "the hull without camera " + std::to_string(views[static_cast<size_t>(held)].camera.id),
          decoded.status());
    }
    meshes[held] = std::move(*decoded);
  }
  return meshes;
}

}  // namespace

StatusOr<const fusion::PodImages*> receivePodFrame(const protocol::Bytes& wire,
                                                   const Camera& reported,
                                                   const std::string& source,
                                                   fusion::FrameGroup& group, FrameData& frame) {
  const std::string what = source + ": camera " + std::to_string(reported.id);
  HOLOFUSE_ASSIGN_OR_RETURN(const protocol::Frame parsed, parsedFrame(wire, what));
  const auto t0 = Clock::now();
  protocol::PodFrame pod;
  Status status = protocol::decodeFrame(parsed, pod);
  auto images = status.isOk()
                    ? fusion::podImagesOf(pod, wire.size(), reported, protocol::monotonicNs())
                    : status;
  const double decode_ms = msSince(t0);
  frame.codec_ms["server_decode"] += decode_ms;
  frame.per_pod_ms["server_decode"].push_back(decode_ms);
  if (!images.isOk()) return within(what, images.status());
  frame.pod_link_bytes += wire.size();
  return &(group.pods[pod.camera_id] = std::move(*images));
}

Status sendToClient(fusion::FrameGroup group, const Mesh& hull, const EvalOptions& options,
                    const std::vector<Camera>& reported, FrameData& frame) {
  fusion::FusionSettings settings = options.loop.fusion;
  settings.pods_expected = static_cast<uint32_t>(reported.size());
  fusion::GroupJob job;
  job.group = std::move(group);  // the decoded images move on; the caller is done with them
  job.group.complete = true;
  // The Stats carry each pod's arrivals as the loop's do, so their bytes
  // are the loop's (no network here: no jitter).
  for (const auto& [id, pod] : job.group.pods)
    job.pod_arrivals.push_back({static_cast<uint16_t>(id), 1, 0});
  const uint64_t hull_end_ns = protocol::monotonicNs();
  const fusion::FusedOutput fused =
      fusion::packageFused(job, settings, hull, hull_end_ns, hull_end_ns);
  const protocol::Bytes mesh_wire = fused.mesh_frame->flatten(),
                        bundle_wire = fused.texture_bundle->flatten();
  const protocol::Bytes stats_wire = fused.stats->flatten();
  frame.client_link_bytes += mesh_wire.size() + bundle_wire.size() + stats_wire.size();
  frame.bundle_bytes += bundle_wire.size();
  frame.mesh_bytes += mesh_wire.size();
  HOLOFUSE_ASSIGN_OR_RETURN(const protocol::Frame bundle_frame,
                            parsedFrame(bundle_wire, "texture bundle"));
  HOLOFUSE_ASSIGN_OR_RETURN(const protocol::Frame mesh_frame_parsed,
                            parsedFrame(mesh_wire, "mesh frame"));
  std::map<uint32_t, Camera> cameras;
  for (const Camera& camera : reported) cameras[camera.id] = camera;
  const auto t0 = Clock::now();
  protocol::TextureBundle bundle;
  Status status = protocol::decodeFrame(bundle_frame, bundle);
  auto views = status.isOk() ? render::viewsOfBundle(bundle, cameras) : status;
  frame.feather_bytes += status.isOk() ? render::featherBytes(bundle) : 0;
  protocol::MeshFrame mesh_frame;
  status = protocol::decodeFrame(mesh_frame_parsed, mesh_frame);
  auto mesh = status.isOk()
                  ? decodeMesh(mesh_frame.codec, mesh_frame.mesh.data(), mesh_frame.mesh.size())
                  : status;
  frame.codec_ms["decode"] += msSince(t0);
  if (!views.isOk()) return within("the client's images", views.status());
  if (mesh_frame.mesh.empty()) {
    // The server sends no mesh bytes when encoding failed, and says why in the Stats.
    HOLOFUSE_ASSIGN_OR_RETURN(const protocol::Frame stats_frame, parsedFrame(stats_wire, "stats"));
    protocol::Stats stats;
    status = protocol::decodeFrame(stats_frame, stats);
    return Status(StatusCode::kMalformed,
                  "the server's mesh: " + (status.isOk() ? stats.note : status.message()));
  }
  if (!mesh.isOk()) return within("the client's mesh", mesh.status());
  // The server's encoding, from the stamps it put in the frames it sent.
  frame.codec_ms["mesh_encode"] +=
      protocol::stampedMs(mesh_frame.stamps, protocol::Stage::kMeshEncode);
  frame.codec_ms["image_encode"] +=
      protocol::stampedMs(bundle.stamps, protocol::Stage::kImageEncode);
  frame.mesh = std::move(*mesh);
  frame.views = std::move(*views);
  return Status::ok();
}

std::vector<int> heldOutCameras(int cameras, int limit) {
  std::vector<int> ids;
  const int count = limit > 0 ? std::min(limit, cameras) : cameras;
  for (int k = 0; k < count; ++k) ids.push_back(k * cameras / count);
  return ids;
}

StatusOr<Mesh> refineCarved(const EvalOptions& options, const fusion::FrameGroup& group,
                            const std::vector<hull::HullView>& views, fusion::FusedMesh fused,
                            const hull::HullOptions& hull_options, FrameData& frame) {
  const fusion::PhotoRefineOptions& refine = options.loop.fusion.refine;
  // The colours in whole frames only for the refinement, which reads them.
  const std::vector<Image8> colors =
      fusion::refines(refine) ? fusion::colorsInFrame(group) : std::vector<Image8>{};
  fusion::refineFused(fused, views, colors, refine, hull_options.voxel_size);
  if (fused.refined) frame.refine_ms = fused.refineMs();
  HOLOFUSE_ASSIGN_OR_RETURN(frame.mesh_without,
                            meshesForHeldOut(options, views, colors, fused.carved, hull_options));
  return fused.refined ? std::move(*fused.refined) : std::move(fused.carved);
}

StatusOr<FrameData> prepareFrame(const EvalOptions& options, const scene::SyntheticScene& scene,
                                 const std::vector<Camera>& truth,
                                 const std::vector<Camera>& reported,
                                 const std::vector<Image8>& plates, uint64_t frame_id) {
  FrameData frame;
  frame.frame_id = frame_id;
  fusion::FrameGroup group;
  group.frame_id = frame_id;
  double slowest_pod_ms = 0;
  std::vector<hull::HullView> pod_masks;
  for (size_t i = 0; i < truth.size(); ++i) {
    capture::PodCapture capture =
        capture::capturePodFrame(scene, truth[i], plates[i], frame_id, static_cast<uint16_t>(i));
    frame.true_colors.push_back(capture.view.color);
    frame.true_masks.push_back(capture.view.mask);
    frame.mask_iou.push_back(metrics::maskIoU(capture.mask, capture.view.mask));
    pod_masks.push_back({reported[i], capture.mask, capture.feather});
    for (size_t p = 0; p < capture.view.shadow.pixels.size(); ++p) {
      if (!capture.view.shadow.pixels[p]) continue;
      ++frame.shadow_pixels;
      frame.shadow_taken += capture.mask.pixels[p] != 0;
    }
    const protocol::Bytes wire =
        capture::encodePodFrame(capture, static_cast<uint32_t>(i), options.loop.pods).flatten();
    // As the pod stamps it: its planes' encoding, not the frame's packing.
    const double encode_ms = protocol::stampedMs(capture.stamps, protocol::Stage::kPodEncode);
    slowest_pod_ms = std::max(slowest_pod_ms, encode_ms);
    frame.per_pod_ms["pod_encode"].push_back(encode_ms);
    HOLOFUSE_RETURN_IF_ERROR(receivePodFrame(wire, reported[i], "pod", group, frame).status());
  }
  frame.codec_ms["pod_encode"] = slowest_pod_ms;
  if (pod_masks.size() >= 3) {
    hull::HullOptions volume;  // the synthetic rig's capture volume
    volume.voxel_size = options.loop.fusion.hull.voxel_size;
    const auto agreed = hull::agreeAcrossCameras(pod_masks, volume);
    for (size_t i = 0; i < agreed.size(); ++i)
      frame.mask_iou_agreed.push_back(metrics::maskIoU(agreed[i].mask, frame.true_masks[i]));
  }
  // The silhouettes back in whole frames before the hull's clock starts, as
  // in the server.
  const std::vector<hull::HullView> hull_views = fusion::hullViewsOf(group);
  hull::HullOptions hull_options;
  hull_options.voxel_size = options.loop.fusion.hull.voxel_size;
  Mesh hull;
  if (options.geometry == "truth") {  // the true surface at the hull's voxel size
    const auto t0 = Clock::now();
    hull = scene.truthMesh(frame_id, hull_options.voxel_size);
    frame.hull_ms = msSince(t0);
  } else {
    fusion::FusedMesh carved = fusion::carveHull(hull_views, hull_options, &frame.hull_stats);
    frame.hull_ms = carved.carveMs();
    HOLOFUSE_ASSIGN_OR_RETURN(
        hull, refineCarved(options, group, hull_views, std::move(carved), hull_options, frame));
  }
  HOLOFUSE_RETURN_IF_ERROR(sendToClient(std::move(group), hull, options, reported, frame));
  return frame;
}

}  // namespace holofuse::eval
