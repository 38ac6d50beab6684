// CPU reference of the stylisation passes over the final picture (paper
// 000, section 6): plain loops in float, as the Vulkan pass computes, so
// that the two agree to a level of 8 bits.
#pragma once

#include <cstdint>

#include "image/image.h"

namespace holofuse::render::reference {

// The stippling's random number in [0, 1) at pixel (x, y)
// (stipple.comp.glsl's stippleRandom, bit for bit).
float stippleRandom(uint32_t x, uint32_t y);

// Sketchy stippling (Du et al. 2019, section 6.1) of an RGBA picture:
// stipple.comp.glsl's steps; pixels of alpha 0 are left as they are.
Image8 stipple(const Image8& picture);

}  // namespace holofuse::render::reference
