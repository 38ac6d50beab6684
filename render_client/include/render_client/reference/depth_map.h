// CPU reference (double precision) of texture-field stages 1 and 2 of
// docs/design.md section 6 (paper 000 section 4.2): the depth map of the mesh
// seen from a pod camera, and its depth discontinuities dilated by eps
// pixels. Slow and plain on purpose: the Vulkan passes are tested against it.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "geometry/camera.h"
#include "geometry/depth_raster.h"
#include "geometry/mesh.h"

namespace holofuse::render::reference {

// Stage 1's reference is the plain z-buffer shared with the fusion server.
using holofuse::DepthMap;
using holofuse::kNoDepth;
using holofuse::rasterizeDepth;

// Paper 000 (section 4.2) dilates by eps = 4 px on 2048-pixel-wide
// textures. Applied literally to a 320-pixel image that band is six times
// wider on the subject, and thin limbs lose every camera. The default keeps
// the band's width relative to the image: the edge pixel plus eps on each
// side spans 5 / 2048 of the width, so eps = round(5 w / 2048) - 1, at
// least 0 (4 at 2048, 2 at 1280, 1 at 640, 0 at 320).
constexpr int kDilationScaledToWidth = -1;
int scaledDilationPx(int image_width);

struct DiscontinuityOptions {
  int dilation_px = kDilationScaledToWidth;  // eps in pixels, or scaled from the paper's
  double relative_jump = 0.03;  // a neighbour this much farther (relative) is a discontinuity
};

// 1 where a pixel lies within dilation_px of a depth discontinuity in
// both x and y (the square window of radius eps, separable on the GPU): a surface pixel whose
// 4-neighbour is empty or differs in depth by more than relative_jump times the nearer depth.
std::vector<uint8_t> dilatedDiscontinuities(const DepthMap& map,
                                            const DiscontinuityOptions& options = {});

}  // namespace holofuse::render::reference
