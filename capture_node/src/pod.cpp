#include "capture_node/pod.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <utility>

#include "base/process.h"
#include "base/shutdown.h"
#include "capture_node/pod_link.h"
#include "codec/image_codec.h"
#include "codec/pod_frame_codec.h"
#include "protocol/clock.h"
#include "protocol/server_link.h"
#include "scene/scene_library.h"
#include "segmentation/segmentation.h"

namespace holofuse::capture {

using protocol::monotonicNs;
using protocol::Stage;

namespace {

// Segments and feathers a rendered view, stamped from t0 (the capture).
PodCapture silhouetteOf(scene::RenderedView view, const BackgroundModel& background,
                        uint64_t frame_id, uint16_t source, uint64_t t0, const Image8* previous) {
  PodCapture capture;
  capture.frame_id = frame_id;
  capture.capture_time_ns = t0;
  capture.view = std::move(view);
  const uint64_t t1 = monotonicNs();
  capture.mask = background.segment(capture.view.color, nullptr, previous);
  const uint64_t t2 = monotonicNs();
  capture.feather = featherMap(capture.mask);
  const uint64_t t3 = monotonicNs();
  capture.stamps = {{static_cast<uint16_t>(Stage::kPodRender), source, t0, t1},
                    {static_cast<uint16_t>(Stage::kSegment), source, t1, t2},
                    {static_cast<uint16_t>(Stage::kFeather), source, t2, t3}};
  return capture;
}

}  // namespace

PodCapture capturePodFrame(const scene::SyntheticScene& scene, const Camera& camera,
                           const BackgroundModel& background, uint64_t frame_id, uint16_t source,
                           const Image8* previous_mask) {
  const uint64_t t0 = monotonicNs();
  return silhouetteOf(scene.render(camera, frame_id), background, frame_id, source, t0,
                      previous_mask);
}

PodCapture capturePodFrame(const scene::CameraRenderer& renderer, const BackgroundModel& background,
                           uint64_t frame_id, uint16_t source, const Image8* previous_mask) {
  const uint64_t t0 = monotonicNs();
  return silhouetteOf(renderer.render(frame_id), background, frame_id, source, t0, previous_mask);
}

protocol::OutgoingFrame encodePodFrame(PodCapture& capture, uint32_t camera_id,
                                       const PodEncoding& encoding) {
  const PodPlanes planes{capture.frame_id, capture.capture_time_ns, &capture.view.color,
                         &capture.mask, &capture.feather};
  return holofuse::encodePodFrame(planes, capture.stamps, camera_id, encoding);
}

int runPod(const PodOptions& options) {
  const scene::SyntheticScene scene(options.scene);
  const auto cameras =
      scene::SyntheticScene::cameraRig(options.pods, options.width, options.height);
  const Camera& camera = cameras.at(options.pod_id);
  const BackgroundModel background(scene.backgroundPlate(camera));
  const scene::CameraRenderer renderer(scene, camera);
  const Camera reported =
      scene::reportedCalibration(camera, options.calibration_error_degrees,
                                 options.calibration_error_metres, options.scene.seed);
  std::fprintf(stderr,
               "[pod-%u] %ux%u at %g fps; colour %s at LZ4 acceleration %d, crop margin %d, LZ4HC "
               "level %d\n",
               options.pod_id, options.width, options.height, options.fps,
               imageCodecName(options.encoding.color_codec).c_str(),
               options.encoding.lz4_acceleration, options.encoding.crop_margin,
               options.encoding.lz4_hc_level);

  const std::string name = "pod-" + std::to_string(options.pod_id);
  PodLink pod_link(options.server, options.pod_id, name, options.key, options.max_minor,
                   toCalibration(reported));
  protocol::ServerLink& link = pod_link.link();

  const uint64_t period_ns = static_cast<uint64_t>(1e9 / options.fps);
  // A frame's work (render, segment, feather, encode, send: about 3 ms at
  // 320x240 here) in one run. With the default slice (1.4 ms on Linux
  // 6.18) the scheduler cut it at the next tick for another pod or the
  // server, and the sub-millisecond stages took the wait: segment's p95
  // was 12 times its p50 in the demo. Half the period: a frame's work has
  // to fit in the period anyway.
  if (!askForTimeSlice(
          std::clamp(std::chrono::nanoseconds(period_ns / 2), kMinTimeSlice, kMaxTimeSlice))) {
    std::fprintf(stderr, "[pod-%u] the system refused a longer time slice: %s\n", options.pod_id,
                 std::strerror(errno));
  }
  uint64_t last_frame_id = 0;
  uint64_t sent = 0, skipped = 0;
  Image8 previous_mask;  // the last frame's, for the segmenter's hysteresis
  while (!stopRequested()) {
    // Frame ids follow a grid on the wall clock, so pods in separate
    // processes (or hosts) agree on ids without talking to each other; a
    // pod that falls behind skips ids rather than drifting.
    const uint64_t now = protocol::realtimeNs();
    const uint64_t frame_id = now / period_ns;
    const uint64_t next_due = (frame_id + 1) * period_ns;
    if (frame_id <= last_frame_id || !link.ready()) {
      if (!pod_link.pump(
              static_cast<int>(std::min<uint64_t>((next_due - now) / 1000000 + 1, 50)))) {
        std::fprintf(stderr, "[%s] giving up: %s\n", name.c_str(),
                     link.fatalError()->toString().c_str());
        return 2;
      }
      continue;
    }
    if (last_frame_id != 0 && frame_id > last_frame_id + 1) skipped += frame_id - last_frame_id - 1;
    last_frame_id = frame_id;
    // A pod told its clock is off sends (and renders) the ids that clock
    // would give; it keeps time by the true clock.
    const uint64_t sent_id = frame_id + static_cast<uint64_t>(options.frame_id_offset);
    PodCapture capture =
        capturePodFrame(renderer, background, sent_id, static_cast<uint16_t>(options.pod_id),
                        previous_mask.empty() ? nullptr : &previous_mask);
    link.send(std::make_shared<const protocol::OutgoingFrame>(
        encodePodFrame(capture, camera.id, options.encoding)));
    previous_mask = capture.mask;
    pod_link.pump(0);
    ++sent;
    if (options.frames > 0 && sent >= options.frames) break;
  }
  link.close(stopRequested() ? "pod stopped by signal" : "pod finished its frames");
  std::fprintf(stderr,
               "[%s] sent %llu frames (%llu ids skipped to stay real-time), %.1f MB, %llu dropped "
               "by the queue\n",
               name.c_str(), static_cast<unsigned long long>(sent),
               static_cast<unsigned long long>(skipped), link.bytesOut() / 1e6,
               static_cast<unsigned long long>(link.framesDropped()));
  return 0;
}

}  // namespace holofuse::capture
