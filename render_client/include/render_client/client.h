// The render client: receives calibration, texture bundles and meshes,
// renders the user's view with the chosen blending mode, writes PNG frames
// and, at the end, report.json.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "codec/layer_video.h"
#include "codec/mesh_codec.h"
#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "protocol/messages.h"
#include "protocol/socket.h"
#include "protocol/stage_budget.h"
#include "render_client/renderer.h"
#include "texture/texture_atlas.h"
#include "texture/texture_layers.h"

namespace holofuse::render {

struct ClientOptions {
  protocol::Endpoint server;
  uint32_t client_id = 0;
  std::vector<uint8_t> key;  // authenticates client client_id (protocol/auth.h); empty: none
  std::string out_dir = "out";
  // Finish (report written, exit 0) when the server says Bye: the end of a
  // replay, after every frame it sent has been read.
  bool exit_when_server_leaves = false;
  // The report warns when a host's clock moves this far from its first
  // estimate against the server's, beyond the estimates' uncertainty.
  double clock_drift_warn_ms = 1.0;
  uint8_t max_minor = protocol::kVersionMinor;  // the newest protocol offered (--protocol)
  uint64_t frames = 0;  // stop after this many rendered frames; 0 = until signalled
  // With frames 0: the frames the run is expected to bring (a replay's), for
  // the progress line's count and time left; 0: not known.
  uint64_t frames_expected = 0;
  // Exit (1) when no server has answered for this long, from the start or
  // since the connection was lost; 0: keep trying until signalled.
  double give_up_after_s = 0;
  double orbit_degrees_per_frame = 2.0;
  // A viewpoint jump (the viewpoint-jump scene): from rendered frame
  // jump_at_frame on, the user camera is turned this many degrees around
  // the pods' ring axis through the subject, at once.
  double jump_degrees = 0;
  uint64_t jump_at_frame = 0;
  uint32_t width = 320, height = 240;
  // The view, frames ahead, overlap, device and budget file its flags
  // gave; their mode is render.blend.mode's, which the renderer reads.
  ClientRunSettings run;
  RenderSettings render;    // render.blend.mode: the blending mode
  int exclude_camera = -1;  // leave this camera out of the blend
  bool write_frames = true;
  protocol::Budget budget;  // per-stage ms; violations are flagged in the reports
  // A shell command that starts the live judge (render_client/frame_judge.h;
  // the launcher's --quality gives eval's holofuse_judge): each written
  // frame is judged against the truth from its view, after it is written,
  // outside every stage's time. Empty: frames are not judged.
  std::string judge_command;
  // Caps on a received mesh, checked before Draco allocates (SECURITY.md).
  // Unless given (mesh_limits_given), each is lowered to what the rig can
  // produce: a visual hull's vertices, one a voxel, cannot usefully exceed
  // the pixels of the cameras that see it (at least 262144).
  DracoLimits mesh_limits;
  bool mesh_limits_given = false;
};

int runClient(const ClientOptions& options);

// The user camera for rendered frame frame_index: orbiting the subject (the
// bounds' centre) around the pods' ring axis, or at pod camera N, turned by
// the jump once it is due. None when there is no camera, or no pod N.
// The orbiting user camera's id: not a pod's (pods are 0..63), so that a
// synthetic truth renders it with a white balance of its own, as eval's
// novel views (ids from 1000).
inline constexpr uint32_t kOrbitCameraId = 1000;

// The viewer window's hold on the orbit (viewer_window.h): once held, the
// orbit stops turning by itself and sits at yaw degrees round the ring
// axis (from where the automatic orbit starts), pitch degrees above its
// height, its distance times zoom, its target moved by pan (in orbit
// radii, right and up in the view).
struct OrbitHold {
  bool held = false;
  double yaw = 0, pitch = 0, zoom = 1;
  double pan_right = 0, pan_up = 0;
};

std::optional<Camera> userCamera(const ClientOptions& options,
                                 const std::map<uint32_t, Camera>& cameras, const Bounds& bounds,
                                 size_t frame_index, const OrbitHold& hold = {});

// The pods' images a TextureBundle carries, decoded and each back in its
// whole frame (pods send their foreground's rectangle), with the
// calibration of its camera, and the feather map where one came (protocol
// 1.2). An error names the camera and what is wrong: no calibration, a
// plane that does not decode, images of the wrong size.
StatusOr<std::vector<ViewImages>> viewsOfBundle(const protocol::TextureBundle& bundle,
                                                const std::map<uint32_t, Camera>& cameras);

// A bundle's texture layers (protocol 1.5), decoded: RGBA layers (the
// camera byte an index into camera_centers) and the atlas layout that
// places the mesh in them (applyAtlasLayout, once the mesh arrives). An
// error names what is wrong: a plane that does not decode or is not the
// atlas's RGB or camera plane, a camera id without a calibration, slots
// that do not decode.
inline constexpr uint32_t kMaxLayerAtlasTexels = 4096;
struct DecodedLayers {
  LayeredViews views;
  AtlasLayout layout;
};
// The layers' video streams of one connection (protocol 1.6), a decoder
// per layer index, kept from bundle to bundle.
struct LayerStreams {
  std::vector<std::unique_ptr<LayerVideoDecoder>> decoders;
};
// streams: where a layer's colour as video is decoded; null: a video plane
// is refused by name.
StatusOr<DecodedLayers> layersOfBundle(const protocol::BundleLayers& layers,
                                       const std::map<uint32_t, Camera>& cameras,
                                       LayerStreams* streams = nullptr);

// The compressed bytes of a bundle's feather planes: what the feather maps
// add to the client link.
uint64_t featherBytes(const protocol::TextureBundle& bundle);

}  // namespace holofuse::render
