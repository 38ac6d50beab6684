// CPU reference (double precision) of texture-field stage 11 of docs/design.md
// section 6: fragment blending, paper 000 eq. 1. For each pixel of the
// user's view, the surface point the pixel sees, the per-vertex weights
// interpolated over its triangle (perspective-correct, as a rasteriser
// does), and each pod image sampled where the point projects:
//   colour = sum_i w_i M_i(project_i(p)) / sum_i w_i
// Mode fragment weighs each pod per pixel instead (Li, Magnor, Seidel
// 2004, eqs. 2 to 4): w_k = V_k F_k max(0, d_k . n)^alpha (d_k . d_v + 1)^beta,
// and the field modes may multiply their interpolated weights by the same
// V_k F_k (BlendOptions::fragment_test).
// Where no weight reaches a pixel, the normal-weighted blend with its
// per-pixel occlusion test fills in (step 10); where nothing does, the hole
// colour. The Vulkan blend (shaders/blend.frag.glsl) is tested against it.
#pragma once

#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "image/image.h"
#include "render_client/reference/visibility.h"
#include "texture/texture_layers.h"

namespace holofuse::render::reference {

struct BlendOptions {
  double alpha = 2.0;  // exponent of the normal weight (mode fragment's obliqueness too)
  double depth_tolerance =
      0.03;  // metres behind a pod's depth map still visible to the normal blend
  glm::dvec3 hole_color{0.5, 0.5, 0.5};
  std::vector<bool>
      camera_enabled;  // per view; empty: every camera (BlendSettings::camera_enabled)
  // Paper 004's per-fragment test (render::BlendSettings): visible within
  // relative_depth_tolerance of the depth plus depth_slack metres of the
  // pod's depth map and inside its mask; feather weight min(1, feather /
  // feather_width_px), 1 for a width of 0.
  bool fragment_mode = false;  // mode fragment: weights are ignored
  bool fragment_test = false;  // the field modes' weights times V_k F_k
  double relative_depth_tolerance = 0.015, depth_slack = 0.0;
  double feather_width_px = 8.0;
  double beta = 5.0;
  // The field modes blend each vertex's best views only (keepBestViews of
  // texture_fields.h); 0: every weighted camera.
  int best_views = 0;
};

// How many covered pixels took each way: the interpolated fields, the
// normal-weighted fallback, or the hole colour.
struct BlendPaths {
  size_t fields = 0, fallback = 0, holes = 0;
};

// The pod image sampled as the blend samples it: bilinear between texel
// centres, clamped at the border, over the foreground only (each texel's
// colour weighted by its mask, so the background beside the silhouette
// never bleeds in), RGBA in 0..1 with the mask's coverage in alpha. u, v
// in 0..1 across the image.
glm::dvec4 sampleBilinear(const PodView& view, double u, double v);
// The pod's feather map sampled the same way, in pixels (0..255).
double sampleFeather(const PodView& view, double u, double v);

// Paper 004's V_k * F_k of a point at depth (along the pod's axis) that
// lands at (u, v) in the pod's image, given the pod's depth map there and
// its colour and mask sampled there.
double sightAndFeather(const PodView& view, double u, double v, double depth, double stored_depth,
                       double mask, const BlendOptions& options);

// The user's view, width x height of the user camera, RGBA: alpha 255
// where the mesh covers the pixel, 0 (and black) elsewhere. weights:
// [camera][vertex] normalised per-vertex fields of holoportation or
// montage4d; empty for mode normal (the normal-weighted blend everywhere).
Image8 blendView(const Mesh& mesh, const std::vector<PodView>& views,
                 const std::vector<std::vector<double>>& weights, const Camera& user,
                 const BlendOptions& options = {}, BlendPaths* paths = nullptr);

// Mode layered (Volino and Hilton 2016, section 3.2, eqs. 3 and 4): per
// pixel, each layer at the surface point's atlas coordinates (the mesh's
// corner_uvs, interpolated perspective-correctly) gives a colour and the
// camera it came from; layer j weighs
//   w_j = max((d_j . n)(d_j . d_v), 0),
// d_j towards its camera's centre and d_v towards the user's eye, and the
// colour is sum_j w_j c_j / sum_j w_j. A layer's colour is bilinear over
// the texels of the nearest texel's camera only (a texel of another
// camera, or of none, never mixes in). Where every weight is 0 (the eye
// behind every layer's camera) the first layer's colour stands; where no
// layer has a camera, the hole colour. Checked with checkLayeredViews and
// checkLayerCoordinates first (throws std::invalid_argument on what they
// refuse).
Image8 blendLayers(const Mesh& mesh, const LayeredViews& layers, const Camera& user,
                   const glm::dvec3& hole_color, BlendPaths* paths = nullptr);

}  // namespace holofuse::render::reference
