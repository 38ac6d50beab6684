#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 2b, second half: the row-dilated discontinuities dilated along
// columns, giving the square of radius eps (see dilate.comp.glsl).
layout(local_size_x = HOLOFUSE_PIXEL_GROUP, local_size_y = HOLOFUSE_PIXEL_GROUP) in;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  uint camera = gl_GlobalInvocationID.z;  // all cameras in one dispatch
  if (p.x >= int(push.width) || p.y >= int(push.height) || camera >= push.camera_count) return;
  int r = max(push.dilation, 0);
  uint base = camera * push.height * push.width + uint(p.x);
  uint hit = 0u;
  for (int y = max(p.y - r, 0); y <= min(p.y + r, int(push.height) - 1); ++y) hit |= rows[base + uint(y) * push.width];
  dilated[base + uint(p.y) * push.width] = hit;
}
