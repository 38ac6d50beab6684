// Relighting from a light probe (paper 000, section 6.2, eqs. 6 to 8): an
// environment map projected to the first three bands of real spherical
// harmonics (Green 2003), the light it gives in a direction (eq. 7), and
// the non-linear blend of a picture's colour with that light (eq. 8),
// which leaves the colour as it is where the light is 50% grey.
#pragma once

#include <array>
#include <functional>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "base/status.h"
#include "image/image.h"
#include "image/image_io.h"

namespace holofuse::render {

struct LightProbe {
  // Per basis function (l = 0; 1, m = -1..1; 2, m = -2..2), red, green, blue.
  std::array<glm::vec3, 9> coefficients{};
};

// The nine real spherical harmonics of bands 0 to 2 at unit direction d.
std::array<float, 9> shBasis(const glm::vec3& d);

// The direction an equirectangular map's pixel centre (column x, row y of
// width x height) looks along: row 0 up (+y), the middle row the horizon;
// column 0 towards -z, the columns going round through +x.
glm::vec3 equirectangularDirection(uint32_t x, uint32_t y, uint32_t width, uint32_t height);

// A width x height equirectangular map (RGB) of colour(direction) at each
// pixel's centre: a synthetic probe (a sky, a single colour).
ImageValues equirectangularMap(uint32_t width, uint32_t height,
                               const std::function<glm::vec3(const glm::vec3&)>& colour);

// An equirectangular map's colour (display values in [0, 1], RGB or RGBA;
// grey taken as all three) projected onto the nine functions, each pixel
// weighed by its solid angle.
LightProbe projectEquirectangular(const ImageValues& map);

// An environment map file (EXR, HDR, PNG: whatever OpenImageIO reads, as
// display values) as a probe; an error names the file and the fault.
StatusOr<LightProbe> loadLightProbe(const std::string& path);

// Eq. 7: the probe's light in direction n, its three bands summed,
// clamped to [0, 1].
glm::vec3 probeLight(const LightProbe& probe, const glm::vec3& n);

// Eq. 8 for one channel: texture colour t lightened where the light l is
// above 50%, darkened below, unchanged at 50%:
// t + |1 - 2 l| (t^(1.5 - l) - t).
float relightChannel(float t, float l);

}  // namespace holofuse::render
