// capture_node: one camera pod (synthetic, a replay, or a real camera). Its
// --help lists the flags.
#include <cstdio>
#include <vector>

#include "base/process.h"
#include "base/shutdown.h"
#include "capture_node/camera_pod.h"
#include "capture_node/pod.h"
#include "capture_node/replay_pod.h"
#include "codec/image_codec.h"
#include "config/command_line.h"
#include "config/rig_shape.h"
#include "dataset/capture_formats.h"
#include "protocol/messages.h"
#include "scene/scene_library.h"

namespace {

// A real camera: the source, the rig's calibration, the plate; refused
// beside --replay and the synthetic scene's flags. Returns --source.
CLI::Option* addCameraOptions(CLI::App& app, holofuse::capture::CameraPodOptions& camera_options,
                              CLI::Option* replay_option) {
  using namespace holofuse;
  CLI::Option* source_option = app.add_option(
      "--source", camera_options.source,
      "a real camera instead of a synthetic scene: a V4L2 device (/dev/video0 or 0), an RTSP or "
      "HTTP stream URL, or a video file (played at its frame rate)");
  source_option->excludes(replay_option);
  for (CLI::Option* option :
       {app.get_option("--pods"), app.get_option("--size"), app.get_option("--scene"),
        app.get_option("--seed"), app.get_option("--noise"), app.get_option("--frame-id-offset")})
    source_option->excludes(option);
  std::vector<CLI::Option*> camera_flags = {
      app.add_option("--calibration", camera_options.calibration,
                     "with --source: the rig's calibration, a capture folder in any format "
                     "`holofuse dataset import` reads"),
      app.add_option("--calibration-format", camera_options.calibration_format,
                     std::string("with --source: the calibration's format: ") +
                         dataset::captureFormatNames())
          ->capture_default_str(),
      app.add_option("--camera", camera_options.camera,
                     "with --source: this camera's name in the calibration (default: the one "
                     "numbered --pod-id, in natural name order)"),
      app.add_option("--plate", camera_options.plate,
                     "with --source: the empty room, a picture or a video (default: the "
                     "camera's background in the calibration)"),
      app.add_option("--plate-frames", camera_options.plate_frames,
                     "with --source: learn the plate from this many frames of the source, with "
                     "the room empty")
          ->check(CLI::Range(0, 600)),
      app.add_flag("--plate-on-key", camera_options.plate_on_key,
                   "with --source and --plate-frames: take the plate when Enter is pressed (a "
                   "line on standard input), and again on each later Enter")};
  for (CLI::Option* option : camera_flags) option->needs(source_option);
  return source_option;
}

// --rig: a capture PC that knows only its name finds its pod in the rig
// file (--rig-host, or this machine's host name).
void addPodRigFlag(CLI::App& app) {
  using namespace holofuse;
  app.add_option("--rig-host",
                 "with --rig and no --pod-id: run the rig's pod on this host (default: this "
                 "machine's host name; on Kubernetes, give the node's name)")
      ->configurable(false);
  addRigFlag(app, "capture_node", [&app](const RigFile& rig) -> StatusOr<std::vector<RigOption>> {
    if (app.count("--pod-id") == 0) {
      const std::string host =
          app.count("--rig-host") ? app["--rig-host"]->results().front() : hostName();
      const auto pod = rig.podOnHost(host);
      if (!pod.isOk()) return pod.status();
      auto part = rig.podPart(*pod);
      if (part.isOk())
        part->push_back(
            {"pod-id", {std::to_string(*pod)}, rig.path + " (pod on host " + host + ")"});
      return part;
    }
    const auto pod = givenId(app, "--pod-id", std::nullopt);
    if (!pod.isOk()) return pod.status();
    return rig.podPart(*pod);
  });
}

}  // namespace

int main(int argc, char** argv) {
  using namespace holofuse;
  capture::PodOptions options;
  std::string server, size = "320x240";
  CLI::App app{
      "holofuse capture_node: a camera pod streaming to a fusion server: a synthetic camera, a "
      "recorded one (--replay), or a real one (--source)"};
  app.add_option("--server", server, "fusion server HOST:PORT")->required();
  app.add_option("--pod-id", options.pod_id,
                 "this pod's camera index (0-based); with --rig, by default the rig's pod on "
                 "this machine's host name")
      ->required();
  // What a synthetic pod makes and how it encodes it: a replay pod sends
  // the recorded bytes as they are, so these are refused with --replay.
  const SettingFlags<PodEncoding> encoding_flags(app, podEncodingFlags());
  const SettingFlags<scene::SceneChoice> scene_flags(app, scene::sceneFlags());
  const SettingFlags<RigShape> shape_flags(app, rigShapeFlags());
  std::vector<CLI::Option*> synthetic = {
      shape_flags.option("--pods"), app.add_option("--size", size, "image size WxH"),
      shape_flags.option("--fps"),
      app.add_option("--frames", options.frames,
                     "stop after this many frames (0: run until signalled)"),
      app.add_option("--frame-id-offset", options.frame_id_offset,
                     "add this many (negative: take) to every frame id, as a pod whose clock "
                     "is that many frame periods off would (tests of the rig's clock)")
          ->check(CLI::Range(-int64_t{1} << 40, int64_t{1} << 40))};
  for (CLI::Option* option : encoding_flags.options()) synthetic.push_back(option);
  for (CLI::Option* option : scene_flags.options()) synthetic.push_back(option);
  std::string replay, speed = "1";
  bool loop = false;
  CLI::Option* replay_option =
      app.add_option("--replay", replay,
                     "replay camera --pod-id of this dataset folder instead of a synthetic scene");
  for (CLI::Option* option : synthetic) replay_option->excludes(option);
  app.add_option(
      "--speed", speed,
      "with --replay: 1 the recorded pace, 2 twice as fast, max as fast as the server accepts");
  app.add_flag("--loop", loop, "with --replay or a video file's --source: start over at the end");
  capture::CameraPodOptions camera_options;
  addCameraOptions(app, camera_options, replay_option);
  PeerKeyFlags key_flags(app, "pod");
  const ProtocolFlag protocol_flag(app, "pod");
  addPodRigFlag(app);
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  RigShape shape{options.pods, options.fps};
  shape_flags.apply(shape);
  options.pods = shape.pods;
  options.fps = shape.fps;
  const auto key = key_flags.load(protocol::Role::kPod, options.pod_id);
  if (!key) return 2;
  options.key = *key;
  options.max_minor = protocol_flag.maxMinor();
  auto endpoint = protocol::parseEndpoint(server);
  if (!endpoint.isOk()) {
    std::fprintf(stderr, "--server: %s\n", endpoint.status().message().c_str());
    return 2;
  }
  if (!camera_options.source.empty()) {
    if (camera_options.calibration.empty()) {
      std::fprintf(stderr, "--source needs --calibration (the rig's calibration folder)\n");
      return 2;
    }
    camera_options.server = *endpoint;
    camera_options.pod_id = options.pod_id;
    camera_options.key = options.key;
    camera_options.max_minor = options.max_minor;
    camera_options.loop = loop;
    camera_options.frames = options.frames;
    if (shape_flags.given("--fps")) camera_options.fps = options.fps;
    encoding_flags.apply(camera_options.encoding);
    installStopSignals();
    const FreeMemoryReturner free_memory;
    return capture::runCameraPod(camera_options);
  }
  if (!replay.empty()) {
    capture::ReplayOptions replay_options;
    replay_options.dataset = replay;
    replay_options.pod_id = options.pod_id;
    replay_options.loop = loop;
    replay_options.key = options.key;
    replay_options.max_minor = options.max_minor;
    if (!capture::parseReplaySpeed(speed, replay_options.speed)) {
      std::fprintf(stderr, "--speed '%s': expected a factor in (0, 1000] or max\n", speed.c_str());
      return 2;
    }
    replay_options.server = *endpoint;
    installStopSignals();
    const FreeMemoryReturner free_memory;
    return capture::runReplayPod(replay_options);
  }
  scene::SceneChoice scene_choice;
  scene_flags.apply(scene_choice);
  options.scene = scene_choice.options();
  options.calibration_error_degrees = scene_choice.preset().calibration_error_degrees;
  options.calibration_error_metres = scene_choice.preset().calibration_error_metres;

  unsigned w = 0, h = 0;
  if (const std::string error = parseImageSize(size, w, h); !error.empty()) {
    std::fprintf(stderr, "--size %s\n%s", error.c_str(), app.help().c_str());
    return 2;
  }
  if (options.pod_id >= static_cast<uint32_t>(options.pods)) {
    std::fprintf(stderr, "--pod-id %u: must be below --pods %d\n", options.pod_id, options.pods);
    return 2;
  }
  options.server = *endpoint;
  options.width = w;
  options.height = h;
  options.scene.frames_per_second = options.fps;
  encoding_flags.apply(options.encoding);
  installStopSignals();
  const FreeMemoryReturner free_memory;
  return capture::runPod(options);
}
