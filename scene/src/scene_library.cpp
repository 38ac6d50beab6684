#include "scene/scene_library.h"

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

namespace holofuse::scene {
namespace {

std::vector<ScenePreset> makeLibrary() {
  std::vector<ScenePreset> scenes;
  auto add = [&](const char* name, const char* stresses) -> ScenePreset& {
    ScenePreset preset;
    preset.name = name;
    preset.stresses = stresses;
    return scenes.emplace_back(preset);
  };
  add("clean", "nothing: eight cameras, mild gains, slow motion (the baseline)");
  {
    ScenePreset& s = add("calibration-error", "pods report poses off by 0.6 degrees and 8 mm");
    s.calibration_error_degrees = 0.6;
    s.calibration_error_metres = 0.008;
  }
  {
    ScenePreset& s = add("colour-imbalance",
                         "white balance and gain three times as uneven, and a specular highlight");
    s.scene.gain_spread = 3.0;
    s.scene.specular = 0.45;
  }
  {
    ScenePreset& s = add("fast-motion", "the subject moves four times as fast");
    s.scene.motion_speed = 4.0;
  }
  {
    ScenePreset& s = add("viewpoint-jump", "the user's view jumps 90 degrees halfway through");
    s.view_jump_degrees = 90.0;
  }
  {
    ScenePreset& s = add("few-cameras", "four cameras: wide gaps between views");
    s.cameras = 4;
  }
  {
    ScenePreset& s = add("many-cameras", "sixteen cameras: many overlapping views to blend");
    s.cameras = 16;
  }
  {
    ScenePreset& s = add("studio",
                         "a real room: a floor that takes the subject's shadow, a stand in view, "
                         "a checkerboard set down after the plate, lights that flicker by 12% "
                         "from frame to frame, the plate taken empty");
    s.scene.studio = true;
    s.scene.late_prop = true;
    s.scene.flicker = 0.12;
  }
  return scenes;
}

glm::dvec3 unitVector(uint64_t key) {
  const double z = 2 * hashToUnitInterval(key) - 1, a = 2 * M_PI * hashToUnitInterval(key + 1);
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  return {r * std::cos(a), r * std::sin(a), z};
}

}  // namespace

const std::vector<ScenePreset>& sceneLibrary() {
  static const std::vector<ScenePreset> library = makeLibrary();
  return library;
}

const ScenePreset* findScene(const std::string& name) {
  for (const auto& preset : sceneLibrary()) {
    if (preset.name == name) return &preset;
  }
  return nullptr;
}

std::string sceneNames() {
  std::string names;
  for (const auto& preset : sceneLibrary()) names += (names.empty() ? "" : ", ") + preset.name;
  return names;
}

const ScenePreset& SceneChoice::preset() const {
  const ScenePreset* found = findScene(name);
  return found != nullptr ? *found : sceneLibrary().front();
}

SceneOptions SceneChoice::options() const {
  SceneOptions scene = preset().scene;
  if (seed) scene.seed = *seed;
  if (noise) scene.noise_amplitude = *noise;
  return scene;
}

const std::vector<Setting<SceneChoice>>& sceneFlags() {
  using S = SceneChoice;
  static const std::vector<Setting<S>> flags = [] {
    std::vector<std::string> names;
    for (const ScenePreset& preset : sceneLibrary()) names.push_back(preset.name);
    return std::vector<Setting<S>>{
        choiceSetting<S>(
            "--scene", "named synthetic scene", names,
            [](S& s, const std::string& name) { s.name = name; },
            [](const S& s) { return s.name; }),
        optionalNumberSetting<S>("--seed",
                                 "synthetic pods' scene seed: their motion, texture and "
                                 "calibration error (default: the scene's)",
                                 0, 18446744073709551615.0,
                                 [](S& s) -> std::optional<uint64_t>& { return s.seed; }),
        optionalNumberSetting<S>(
            "--noise", "synthetic pods' sensor noise, grey levels (default: the scene's)", 0,
            kMaxNoise, [](S& s) -> std::optional<double>& { return s.noise; }),
    };
  }();
  return flags;
}

Camera reportedCalibration(const Camera& truth, double degrees, double metres, uint64_t seed) {
  if (degrees == 0.0 && metres == 0.0) return truth;
  const uint64_t key = (seed * 7919 + truth.id) * 4;
  const glm::dmat3 turn(glm::rotate(glm::dmat4(1.0), glm::radians(degrees), unitVector(key)));
  Camera reported = truth;
  // x_camera = R x_world + t: turning the camera by `turn` about its own
  // centre, then moving the centre.
  const glm::dvec3 centre = truth.center() + metres * unitVector(key + 2);
  reported.rotation = turn * truth.rotation;
  reported.translation = -reported.rotation * centre;
  return reported;
}

}  // namespace holofuse::scene
