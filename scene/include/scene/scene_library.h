// Named synthetic scenes, each stressing one thing the texture-field
// pipeline has to cope with. The pods, the demo and the evaluation select
// them by name; everything stays deterministic and keeps its ground truth.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "config/settings.h"
#include "geometry/camera.h"
#include "scene/synthetic_scene.h"

namespace holofuse::scene {

struct ScenePreset {
  std::string name;
  std::string stresses;  // one line for people
  SceneOptions scene;
  int cameras = 8;
  // The pods report a calibration this far from the truth (rotation about a
  // random axis, translation in a random direction, per camera).
  double calibration_error_degrees = 0.0;
  double calibration_error_metres = 0.0;
  // Evaluation: halfway through, the user's view jumps by this much.
  double view_jump_degrees = 0.0;
};

const std::vector<ScenePreset>& sceneLibrary();
// nullptr when unknown; sceneNames() lists the valid ones for the message.
const ScenePreset* findScene(const std::string& name);
std::string sceneNames();

// Which synthetic scene the pods film: a preset by name, with its seed and
// noise replaced where given. The pods, the launcher (which forwards it)
// and the live judge (which must render what the pods render) bind it
// from sceneFlags().
struct SceneChoice {
  std::string name = "clean";
  std::optional<uint64_t> seed;  // the preset's unless given
  std::optional<double> noise;   // grey levels; the preset's unless given
  // The named preset (one of sceneLibrary(): the flag takes no other).
  const ScenePreset& preset() const;
  // The preset's scene with the given seed and noise.
  SceneOptions options() const;
};

const std::vector<Setting<SceneChoice>>& sceneFlags();

// The calibration a pod reports for its true camera: the truth turned by
// `degrees` about an axis and moved by `metres` in a direction, both drawn
// deterministically from the seed and the camera id.
Camera reportedCalibration(const Camera& truth, double degrees, double metres, uint64_t seed);

}  // namespace holofuse::scene
