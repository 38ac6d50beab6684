// holofuse_judge: the live loop's judge (render_client/frame_judge.h).
// Reads one request a line on stdin (a frame the client wrote, its view,
// its frame id), renders the synthetic scene the pods film from that view
// at that time, and answers the frame's PSNR and SSIM inside the true mask
// on stdout, a line each. The launcher's --quality starts it for the
// client; it ends when its stdin does.
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>

#include "capture_node/pod.h"
#include "config/command_line.h"
#include "config/rig_shape.h"
#include "image/image_io.h"
#include "metrics/image_metrics.h"
#include "render_client/frame_judge.h"
#include "scene/scene_library.h"
#include "scene/synthetic_scene.h"

namespace {

using namespace holofuse;

render::JudgeAnswer judgeFrame(const scene::SyntheticScene& scene,
                               const render::JudgeRequest& request) {
  auto picture = readImage(request.picture);
  if (!picture.isOk()) return {std::nullopt, picture.status().message()};
  if (picture->width != request.view.width || picture->height != request.view.height) {
    return {std::nullopt, request.picture + " is " + std::to_string(picture->width) + "x" +
                              std::to_string(picture->height) + ", its view " +
                              std::to_string(request.view.width) + "x" +
                              std::to_string(request.view.height)};
  }
  const scene::RenderedView truth = scene.render(request.view, request.frame_id);
  const metrics::ImageQuality q = metrics::compareInMask(*picture, truth.color, truth.mask);
  // Nothing of the subject in view: nothing to judge (PSNR would be the cap).
  if (q.pixels == 0) return {};
  return {report::FrameQuality{q.psnr_db, q.ssim}, ""};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "holofuse judge: judges the client's frames against the synthetic scene the pods film "
      "(requests on stdin, answers on stdout, a line of JSON each)"};
  // The pods' --fps, from their table: their frame ids' clock.
  const SettingFlags<RigShape> shape_flags(app, pickSettings(rigShapeFlags(), {"--fps"}));
  // The pods' scene flags, from the pods' own table: the truth must be
  // what they render.
  const SettingFlags<scene::SceneChoice> scene_flags(app, scene::sceneFlags());
  scene_flags.option("--scene")->required();
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  scene::SceneChoice choice;
  scene_flags.apply(choice);
  // The scene as the pods render it (capture_node --scene).
  scene::SceneOptions scene_options = choice.options();
  RigShape shape;
  shape_flags.apply(shape);
  scene_options.frames_per_second = shape.fps;  // as capture_node sets it from its --fps
  const scene::SyntheticScene scene(scene_options);
  std::string line;
  while (std::getline(std::cin, line)) {
    const auto request = render::decodeJudgeRequest(line);
    const render::JudgeAnswer answer =
        request.isOk() ? judgeFrame(scene, *request)
                       : render::JudgeAnswer{std::nullopt, request.status().message()};
    std::cout << render::encodeJudgeAnswer(answer) << std::endl;  // flushed: the client waits
  }
  return 0;
}
