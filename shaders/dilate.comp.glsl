#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 2b, first half: the discontinuities dilated along rows by eps
// pixels. The dilation window is the square of radius eps, which separates
// into a row pass and a column pass (2 (2 eps + 1) reads per pixel instead
// of (2 eps + 1)^2). Each invocation writes only its own pixel.
layout(local_size_x = HOLOFUSE_PIXEL_GROUP, local_size_y = HOLOFUSE_PIXEL_GROUP) in;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  uint camera = gl_GlobalInvocationID.z;  // all cameras in one dispatch
  if (p.x >= int(push.width) || p.y >= int(push.height) || camera >= push.camera_count) return;
  int r = max(push.dilation, 0);
  uint base = camera * push.height * push.width + uint(p.y) * push.width;
  uint hit = 0u;
  for (int x = max(p.x - r, 0); x <= min(p.x + r, int(push.width) - 1); ++x) hit |= edges[base + uint(x)];
  rows[base + uint(p.x)] = hit;
}
