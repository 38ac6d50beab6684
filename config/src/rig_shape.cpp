#include "config/rig_shape.h"

#include "protocol/messages.h"

namespace holofuse {

const std::vector<Setting<RigShape>>& rigShapeFlags() {
  using S = RigShape;
  static const std::vector<Setting<S>> flags = {
      numberSetting<S>("--pods", "camera pods on the ring", 1,
                       static_cast<double>(protocol::kMaxCameras),
                       [](S& s) -> int& { return s.pods; }),
      numberSetting<S>("--fps", "frames per second each pod films", 0.1, 240,
                       [](S& s) -> double& { return s.fps; }),
  };
  return flags;
}

}  // namespace holofuse
