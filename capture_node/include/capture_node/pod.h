// The synthetic camera pod: renders its camera of the synthetic scene,
// segments, computes the feather map, compresses and streams PodFrames to
// the fusion server at a fixed rate, with stage stamps.
#pragma once

#include <cstdint>
#include <string>

#include "codec/pod_frame_codec.h"
#include "config/rig_shape.h"
#include "protocol/messages.h"
#include "protocol/socket.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::capture {

struct PodOptions {
  protocol::Endpoint server;
  uint32_t pod_id = 0;
  int pods = RigShape{}.pods;  // --pods and --fps are the rig shape's (config/rig_shape.h)
  uint32_t width = 320, height = 240;
  double fps = RigShape{}.fps;
  uint64_t frames = 0;  // stop after this many frames sent; 0 = until signalled
  // Added to every frame id the pod sends: a pod whose clock is off by that
  // many frame periods (SECURITY.md's tests of the rig's clock).
  int64_t frame_id_offset = 0;
  scene::SceneOptions scene;
  // The calibration the pod reports is off by this much (scene presets).
  double calibration_error_degrees = 0.0;
  double calibration_error_metres = 0.0;
  PodEncoding encoding;
  std::vector<uint8_t> key;  // authenticates pod pod_id (protocol/auth.h); empty: none
  uint8_t max_minor = protocol::kVersionMinor;  // the newest protocol offered (--protocol)
};

// Everything a pod produces for one frame, before it goes on the wire.
struct PodCapture {
  uint64_t frame_id = 0;
  scene::RenderedView view;  // colour and the true mask
  Image8 mask;               // the segmented mask (what is sent)
  Image8 feather;
  std::vector<protocol::StageStamp> stamps;
  uint64_t capture_time_ns = 0;
};

// Renders, segments and feathers one frame, recording stage stamps: with
// the reference tracer (eval's inputs and truth), or with the closed-form
// renderer of the pod's camera (the live pods, scene::CameraRenderer).
// previous_mask: the pod's mask of the frame before, which the segmenter's
// hysteresis holds to (SegmentationOptions::hold).
PodCapture capturePodFrame(const scene::SyntheticScene& scene, const Camera& camera,
                           const BackgroundModel& background, uint64_t frame_id, uint16_t source,
                           const Image8* previous_mask = nullptr);
PodCapture capturePodFrame(const scene::CameraRenderer& renderer, const BackgroundModel& background,
                           uint64_t frame_id, uint16_t source,
                           const Image8* previous_mask = nullptr);

// The capture as the PodFrame it sends (codec/pod_frame_codec.h), the
// encode stamp appended to its stamps.
protocol::OutgoingFrame encodePodFrame(PodCapture& capture, uint32_t camera_id,
                                       const PodEncoding& encoding);

// Runs until stopped (signal, frame count) or the server refuses the
// version. Returns the process exit code.
int runPod(const PodOptions& options);

}  // namespace holofuse::capture
