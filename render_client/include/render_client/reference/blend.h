// CPU reference (double precision) of texture-field stage 11 of DESIGN.md
// section 6: fragment blending, paper 000 eq. 1. For each pixel of the
// user's view, the surface point the pixel sees, the per-vertex weights
// interpolated over its triangle (perspective-correct, as a rasteriser
// does), and each pod image sampled where the point projects:
//   colour = sum_i w_i M_i(project_i(p)) / sum_i w_i
// Where no weight reaches a pixel, the normal-weighted blend with its
// per-pixel occlusion test fills in (step 10); where nothing does, the hole
// colour. The Vulkan blend (shaders/blend.frag.glsl) is tested against it.
#pragma once

#include <vector>

#include "common/camera.h"
#include "common/image.h"
#include "common/mesh.h"
#include "render_client/reference/visibility.h"

namespace holofuse::render::reference {

struct BlendOptions {
  double alpha = 2.0;            // exponent of the normal weight of the fallback
  double depth_tolerance = 0.03; // metres behind a pod's depth map still visible to it
  glm::dvec3 hole_color{0.5, 0.5, 0.5};
  std::vector<bool> camera_enabled;  // per view; empty: every camera (BlendSettings::camera_enabled)
};

// How many covered pixels took each way: the interpolated fields, the
// normal-weighted fallback, or the hole colour.
struct BlendPaths {
  size_t fields = 0, fallback = 0, holes = 0;
};

// The pod image sampled as a GPU samples it: bilinear between texel
// centres, clamped at the border, colour and mask together (RGBA in 0..1,
// the mask in alpha). u, v in 0..1 across the image.
glm::dvec4 sampleBilinear(const PodView& view, double u, double v);

// The user's view, width x height of the user camera, RGBA: alpha 255
// where the mesh covers the pixel, 0 (and black) elsewhere. weights:
// [camera][vertex] normalised per-vertex fields of holoportation or
// montage4d; empty for mode normal (the normal-weighted blend everywhere).
Image8 blendView(const Mesh& mesh, const std::vector<PodView>& views, const std::vector<std::vector<double>>& weights,
                 const Camera& user, const BlendOptions& options = {}, BlendPaths* paths = nullptr);

}  // namespace holofuse::render::reference
