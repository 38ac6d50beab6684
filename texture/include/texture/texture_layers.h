// Layered view-dependent texture maps (Volino and Hilton 2016, section
// 3.1): per texel of a mesh's atlas, the colour from the l-th best camera
// that sees that point of the surface, with the camera alongside so a
// renderer knows whose view it is. The CPU reference.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "base/status.h"
#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "image/image.h"
#include "texture/texture_atlas.h"

namespace holofuse {

// A layer texel's camera byte where no camera sees the point.
inline constexpr uint8_t kNoLayerCamera = 255;

struct LayerView {
  const Camera* camera = nullptr;
  const Image8* color = nullptr;    // 3 or 4 channels, camera->width x height
  const Image8* mask = nullptr;     // 255 foreground; nullptr: every pixel
  const Image8* feather = nullptr;  // distance inside the silhouette, pixels; nullptr: none
};

struct LayerOptions {
  int layers = 3;  // L
  // A layer after the first holds a point only where its camera's score
  // (eq. 2's cosine times the feather weight) is at least this share of
  // the best camera's: a camera that sees the surface much more obliquely
  // than the best adds little to any view near the surface's normal, and
  // the texels it leaves empty cost a video coder almost nothing (eval's
  // clean scene, H.264 layers: 255 -> 206 KB a frame at the same SSIM;
  // many-cameras 250 -> 241 KB, SSIM -0.0006). 0: the L best, as the paper.
  double min_score_share = 0.5;
  // A layer keeps the camera of the texel to its left, or else above it,
  // where that camera sees this point with at least this share of the
  // score of the camera ranked for the layer: a greedy stand-in for the
  // seam term of Lempitsky and Ivanov 2007, so that a chart changes camera
  // less often along its rows and across them. Fewer changes are fewer
  // colour seams inside a chart, cheaper video and camera planes (eval,
  // h264 layers, left only against the ranking alone: clean 175 -> 171 KB
  // a frame, SSIM +0.0003; many-cameras 205 -> 190 KB, SSIM +0.0011, PSNR
  // +0.09 dB; left or above against left only: clean 172.9 -> 169.9 KB,
  // many-cameras 164.8 -> 157.0 KB, SSIM +0.0005). 1: the ranking alone.
  double keep_share = 0.5;
  // A point is seen unless it lies behind the camera's depth map by more
  // than relative_depth_tolerance of that depth plus depth_slack (0: the
  // mesh's mean edge length): the renderer's own per-fragment test
  // (Renderer::fragmentDepthSlack), so that a layer holds a camera where
  // the other modes' blend would take it.
  double relative_depth_tolerance = 0.015;
  double depth_slack = 0.0;
  // Pixels this close to the silhouette's border rank lower, linearly to
  // zero at the border (the feather weight of Li et al. 2004): a border
  // pixel mixes subject and background.
  double feather_ramp_px = 4.0;
  glm::u8vec3 hole{128, 128, 128};  // where no camera sees the point
};

struct TextureLayers {
  uint32_t texels = 0;
  // L RGBA images, texels x texels: RGB the colour, A the index in the
  // views of the camera it came from (kNoLayerCamera: none).
  std::vector<Image8> layers;
  // texels x texels: 1 where a triangle's footprint reaches the texel
  // (within a bilinear sample's reach); a renderer's taps read only these.
  std::vector<uint8_t> covered;
  uint64_t texels_covered = 0;  // texels of the mesh's triangles
  uint64_t texels_seen = 0;     // of those, seen by at least one camera
  // Texels inside two triangles' footprints (a layout that folds the
  // surface onto itself): each holds one of the points.
  uint64_t texels_contested = 0;
};

// Texture layers as a renderer takes them (Volino and Hilton 2016 section
// 3.2): L RGBA images of the atlas the mesh's corner_uvs point into, RGB
// the colour and A the index of the camera in camera_centers
// (kNoLayerCamera where none sees the point); eq. 3 weighs each layer by
// its camera's direction.
struct LayeredViews {
  std::vector<Image8> layers;
  std::vector<glm::dvec3> camera_centers;
};

// What a renderer refuses, by name: layers of different sizes or not RGBA,
// more than kMaxRenderedLayers, a camera index past camera_centers; and
// a mesh without a texture coordinate per corner or with one outside [0,1].
inline constexpr size_t kMaxRenderedLayers = 16;
Status checkLayeredViews(const LayeredViews& views);
Status checkLayerCoordinates(const Mesh& mesh);

// The atlas the mesh's corner_uvs point into (a texels-square texture)
// filled from the views: each texel holds the point of the surface whose
// triangle's footprint in the atlas is nearest, within the reach of a
// bilinear sample (border texels included, so sampling reads the
// triangle's own colours: Dong and Hollerer 2017, Fig. 4); cameras that
// see the point (depth test, facing it, inside the mask) rank by the
// cosine between the normal and the direction to the camera (Volino and
// Hilton eq. 2), times the feather weight. Refused by name with more than
// 254 views or inputs that disagree.
StatusOr<TextureLayers> buildTextureLayers(const Mesh& mesh, uint32_t texels,
                                           const std::vector<LayerView>& views,
                                           const LayerOptions& options = {});

// The colour of the texels no camera fills (camera byte kNoLayerCamera)
// spread in from the texels around them: the covered texels' means down a
// pyramid of halvings, filled back up level by level (push-pull). A video
// coder then meets no edge at a chart's border, and 4:2:0's shared chroma
// does not mix the hole colour into a chart's border texels. A renderer
// never reads the filled texels (it takes a layer's taps of its own camera
// only). colour: RGB; camera: one channel, the same size.
void fillUncoveredTexels(Image8& colour, const Image8& camera);

// The camera bytes of the texels no triangle reaches (covered 0: a
// renderer never taps them) taken from the texel above (in the first row,
// to the left), so that the plane's coder finds a gutter's rows in the
// rows before and meets an edge only where the camera changes on the
// surface. Eval, h264 layers, camera planes KB a frame: clean 20.3 ->
// 16.8, many-cameras 18.8 -> 14.5 (from the left: 18.6 and 15.7), the
// pictures the same bit for bit. camera: one channel; covered: as
// TextureLayers::covered.
void continueCamerasAcrossGutters(Image8& camera, const std::vector<uint8_t>& covered);

}  // namespace holofuse
