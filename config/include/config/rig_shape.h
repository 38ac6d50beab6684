// The rig's shape, which every program of the loop takes the same way: how
// many camera pods there are and how fast they film. The pods, the server,
// the launcher (which forwards it), the judge and the benchmarks bind these
// flags from rigShapeFlags(), so that a value one takes every other takes.
#pragma once

#include <vector>

#include "config/settings.h"

namespace holofuse {

struct RigShape {
  int pods = 4;       // camera pods on the ring (1..protocol::kMaxCameras)
  double fps = 10.0;  // frames per second each pod films
};

const std::vector<Setting<RigShape>>& rigShapeFlags();

}  // namespace holofuse
