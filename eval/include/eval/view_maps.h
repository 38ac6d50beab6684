// Float maps of one evaluated view, written as OpenEXR beside its PNGs for
// a person to inspect in any EXR viewer: the signed error per channel and
// each camera's blend weight per pixel.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "image/image.h"

namespace holofuse::eval {

// Named channels of float values, width * height * channels.size().
struct FloatMap {
  std::vector<std::string> channels;
  std::vector<float> values;
};

// rendered - truth per colour channel in [-1, 1] (1: a full grey scale too
// bright), 0 outside the truth's mask; channels error.R, error.G, error.B.
FloatMap signedErrorMap(const Image8& rendered, const Image8& truth, const Image8& mask);

// Each camera's texture-field weight at each pixel of the view (zero
// where no camera's field reaches and the blend falls back on the normal
// weights): the per-vertex weights (weights[vertex * camera_ids.size() + camera], as the
// texture-field passes leave them) interpolated over the visible triangle
// with perspective-correct barycentrics, as the rasteriser interpolates
// them. triangle_of: per pixel, the visible triangle (-1: none), as
// rasterizeDepth gives it. Only cameras that weigh somewhere in the view
// get a channel (weight.camera<id>); none when the weights do not match
// the mesh.
FloatMap viewWeightMap(const Mesh& mesh, const Camera& view,
                       const std::vector<int32_t>& triangle_of, const std::vector<float>& weights,
                       const std::vector<uint32_t>& camera_ids);

}  // namespace holofuse::eval
