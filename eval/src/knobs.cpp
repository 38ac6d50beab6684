#include "eval/knobs.h"

#include <stdexcept>
#include <utility>

#include "codec/image_codec.h"
#include "config/command_line.h"
#include "protocol/messages.h"
#include "scene/scene_library.h"

namespace holofuse::eval {
namespace {

Knob knobOf(const std::string& name, const Setting<EvalOptions>& setting) {
  Knob knob;
  knob.name = name;
  knob.loop_flag = setting.flag;
  knob.meaning = setting.help;
  knob.apply = setting.set;
  knob.current = setting.get;
  return knob;
}

std::vector<Setting<EvalOptions>> makeEvalFlags() {
  std::vector<Setting<EvalOptions>> flags;
  embedSettings(
      flags, loopFlags(), [](EvalOptions & o) -> auto& { return o.loop; });
  // A voxel given overrides a dataset's own.
  for (Setting<EvalOptions>& setting : flags) {
    if (setting.flag != "--voxel") continue;
    setting.set = [set = setting.set](EvalOptions& o, const std::string& text) {
      std::string error = set(o, text);
      if (error.empty()) o.voxel_from_dataset = false;
      return error;
    };
  }
  // Leave-one-out needs a camera left to blend: 2 at least, where the
  // loop's --pods takes 1.
  Setting<EvalOptions> cameras = numberSetting<EvalOptions>(
      "--pods", "pods on the ring (default: the scene's)", 2,
      static_cast<int>(protocol::kMaxCameras), [](EvalOptions& o) -> int& { return o.cameras; });
  cameras.get = [](const EvalOptions& o) { return formatNumber(camerasOf(o)); };
  flags.push_back(std::move(cameras));
  return flags;
}

std::vector<Knob> makeKnobs() {
  // The knobs under their sweep names, in the order a sweep report lists
  // them; each is the eval flag of that name.
  const std::pair<const char*, const char*> named[] = {
      {"voxel", "--voxel"},
      {"hull-error-mm", "--hull-error-mm"},
      {"refine-voxels", "--refine-voxels"},
      {"k", "--geodesic-rings"},
      {"radius", "--geodesic-radius"},
      {"K", "--geodesic-passes"},
      {"alpha", "--alpha"},
      {"lambda", "--lambda"},
      {"beta", "--beta"},
      {"feather-width", "--feather-width"},
      {"fragment-test", "--fragment-test"},
      {"best-views", "--best-views"},
      {"cameras", "--pods"},
      {"dilation", "--dilation"},
      {"delta", "--vote-delta"},
      {"draco-bits", "--draco-bits"},
      {"mesh-codec", "--mesh-codec"},
      {"lz4-acceleration", "--lz4-acceleration"},
      {"lz4-hc-level", "--lz4-hc-level"},
      {"crop-margin", "--crop-margin"},
      {"image-codec", "--image-codec"},
      {"layers", "--layers"},
      {"chart-cells", "--chart-cells"},
      {"texels-per-voxel", "--texels-per-voxel"},
      {"layer-min-share", "--layer-min-share"},
      {"layer-keep-share", "--layer-keep-share"},
      {"atlas-size", "--atlas-size"},
      {"layer-video", "--layer-video"},
      {"layer-video-crf", "--layer-video-crf"},
      {"layer-video-crf-step", "--layer-video-crf-step"},
      {"layer-video-kbps", "--layer-video-kbps"},
      {"vertex-precision", "--vertex-precision"}};
  std::vector<Knob> knobs;
  for (const auto& [name, flag] : named) {
    const Setting<EvalOptions>* setting = findSetting(evalFlags(), flag);
    if (setting == nullptr) throw std::logic_error(std::string("no eval flag ") + flag);
    knobs.push_back(knobOf(name, *setting));
    // A dataset's cameras are recorded.
    knobs.back().synthetic_only = knobs.back().name == "cameras";
  }
  Knob size;
  size.name = "size";
  size.loop_flag = "--size";
  size.meaning = "camera and output image size WxH";
  size.apply = [](EvalOptions& o, const std::string& v) -> std::string {
    return parseImageSize(v, o.width, o.height);
  };
  size.current = [](const EvalOptions& o) {
    return std::to_string(o.width) + "x" + std::to_string(o.height);
  };
  size.synthetic_only = true;
  knobs.push_back(size);
  return knobs;
}

}  // namespace

int camerasOf(const EvalOptions& o) {
  if (o.cameras != 0 || o.scenes.empty()) return o.cameras;
  const scene::ScenePreset* scene = scene::findScene(o.scenes.front());
  return scene != nullptr ? scene->cameras : 0;
}

const std::vector<Knob>& sweepKnobs() {
  static const std::vector<Knob> knobs = makeKnobs();
  return knobs;
}

const Knob* findKnob(const std::string& name) {
  for (const auto& knob : sweepKnobs()) {
    if (knob.name == name) return &knob;
  }
  return nullptr;
}

const std::vector<Setting<EvalOptions>>& evalFlags() {
  static const std::vector<Setting<EvalOptions>> flags = makeEvalFlags();
  return flags;
}

std::string knobNames() {
  std::string names;
  for (const auto& knob : sweepKnobs()) names += (names.empty() ? "" : ", ") + knob.name;
  return names;
}

}  // namespace holofuse::eval
