#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 2a (paper 000 section 4.2): depth discontinuities of each camera's
// depth map (the camera is gl_GlobalInvocationID.z): a surface pixel whose
// 4-neighbour is empty or farther by more than relative_jump times the
// nearer depth.
layout(local_size_x = HOLOFUSE_PIXEL_GROUP, local_size_y = HOLOFUSE_PIXEL_GROUP) in;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  uint camera = gl_GlobalInvocationID.z;  // all cameras in one dispatch
  if (p.x >= int(push.width) || p.y >= int(push.height) || camera >= push.camera_count) return;
  float d = storedDepth(camera, p);
  uint edge = 0u;
  if (d < HOLOFUSE_NO_DEPTH * 0.5) {
    ivec2 offsets[4] = ivec2[](ivec2(-1, 0), ivec2(1, 0), ivec2(0, -1), ivec2(0, 1));
    for (int k = 0; k < 4; ++k) {
      ivec2 q = p + offsets[k];
      if (q.x < 0 || q.y < 0 || q.x >= int(push.width) || q.y >= int(push.height)) continue;
      float e = storedDepth(camera, q);
      if (e >= HOLOFUSE_NO_DEPTH * 0.5 || abs(e - d) > push.relative_jump * min(d, e)) edge = 1u;
    }
  }
  uint index = (camera * push.height + uint(p.y)) * push.width + uint(p.x);
  // With eps = 0 the edges are the dilated map: the dilation passes are skipped.
  if (push.dilation > 0) {
    edges[index] = edge;
  } else {
    dilated[index] = edge;
  }
}
