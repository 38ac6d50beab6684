// Hull views of the synthetic figure from the pods' ring, with the true
// masks: what the hull, fusion and refinement tests carve.
#pragma once

#include <vector>

#include "hull/visual_hull.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::test {

inline std::vector<hull::HullView> syntheticViews(int count, uint64_t frame_id, uint32_t w = 240,
                                                  uint32_t h = 180) {
  const scene::SyntheticScene scene;
  std::vector<hull::HullView> views;
  for (const auto& cam : scene::SyntheticScene::cameraRig(count, w, h)) {
    const auto view = scene.render(cam, frame_id);
    views.push_back({cam, view.mask, featherMap(view.mask)});
  }
  return views;
}

}  // namespace holofuse::test
