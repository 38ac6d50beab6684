// The rig the fuzz targets receive for and the seed generator sends from:
// four small cameras on a ring, so a seed's planes fit the calibration the
// target holds and the fuzzer starts from frames the code accepts.
#pragma once

#include <map>

#include "geometry/camera.h"

namespace holofuse::fuzz {

inline constexpr uint32_t kRigWidth = 64;
inline constexpr uint32_t kRigHeight = 48;
inline constexpr int kRigCameras = 4;

inline std::map<uint32_t, Camera> fuzzRig() {
  std::map<uint32_t, Camera> rig;
  for (const Camera& c : ringCameras(kRigCameras, 2.5, 1.0, {0, 1, 0}, kRigWidth, kRigHeight, 50))
    rig.emplace(c.id, c);
  return rig;
}

}  // namespace holofuse::fuzz
