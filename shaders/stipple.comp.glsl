#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
// Sketchy stippling over the final picture (Du et al. 2019, section 6.1,
// its four steps in one pass): (1) the picture T; (2) its box blur B over
// HOLOFUSE_STIPPLE_RADIUS pixels, dotted where a per-pixel random number
// falls under B's darkness (1 - luminance), a dot lifting it by
// HOLOFUSE_STIPPLE_STRENGTH; (3) the colour dodge of T by the inverted
// dotted image, T / (1 - (1 - D)) = T / D: white where the picture is as
// bright as around it, dark lines at its edges, dark dots where it is
// dark; (4) grey, the contrast raised by a power. The background (alpha
// 0) is left as it is. CPU reference: render::reference::stipple, which
// this matches to a level of 8 bits but for a dot on a threshold.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba8) uniform readonly image2D source;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D target;

// A random number in [0, 1) per pixel, the same on the CPU: an integer
// hash of (x, y), 24 bits of it.
float stippleRandom(uint x, uint y) {
  uint h = x * 0x8da6b343u ^ y * 0xd8163841u;
  h ^= h >> 16u;
  h *= 0x7feb352du;
  h ^= h >> 15u;
  h *= 0x846ca68bu;
  h ^= h >> 16u;
  return float(h >> 8u) * (1.0 / 16777216.0);
}

float luminance(vec3 c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

void main() {
  ivec2 size = imageSize(source);
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= size.x || p.y >= size.y) return;
  vec4 t = imageLoad(source, p);
  if (t.a == 0.0) {
    imageStore(target, p, t);
    return;
  }
  vec3 sum = vec3(0.0);
  for (int dy = -HOLOFUSE_STIPPLE_RADIUS; dy <= HOLOFUSE_STIPPLE_RADIUS; ++dy) {
    for (int dx = -HOLOFUSE_STIPPLE_RADIUS; dx <= HOLOFUSE_STIPPLE_RADIUS; ++dx) {
      sum += imageLoad(source, clamp(p + ivec2(dx, dy), ivec2(0), size - 1)).rgb;
    }
  }
  const float taps = float((2 * HOLOFUSE_STIPPLE_RADIUS + 1) * (2 * HOLOFUSE_STIPPLE_RADIUS + 1));
  vec3 blurred = sum / taps;
  bool stippled = stippleRandom(uint(p.x), uint(p.y)) < 1.0 - luminance(blurred);
  vec3 dotted = min(blurred * (stippled ? 1.0 + HOLOFUSE_STIPPLE_STRENGTH : 1.0), vec3(1.0));
  vec3 dodged = clamp(t.rgb / max(dotted, vec3(1.0 / 255.0)), 0.0, 1.0);
  float grey = pow(luminance(dodged), HOLOFUSE_STIPPLE_CONTRAST);
  imageStore(target, p, vec4(vec3(grey), t.a));
}
