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

// Neighbour q breaks the surface at depth d: empty, outside the image
// counts as continuous, or a relative jump.
bool breaks(uint camera, float d, ivec2 q) {
  if (q.x < 0 || q.y < 0 || q.x >= int(push.width) || q.y >= int(push.height)) return false;
  float e = storedDepth(camera, q);
  return e >= HOLOFUSE_NO_DEPTH * 0.5 || abs(e - d) > push.relative_jump * min(d, e);
}

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  uint camera = gl_GlobalInvocationID.z;  // all cameras in one dispatch
  if (p.x >= int(push.width) || p.y >= int(push.height) || camera >= push.camera_count) return;
  // A camera that sees none of the subject has an empty map: no edges.
  float d = blend.cameras[camera].flags.y != 0 ? HOLOFUSE_NO_DEPTH : storedDepth(camera, p);
  // Written out rather than looped over an offset table: a CPU Vulkan
  // device turns an indexed local array into scattered memory traffic.
  bool edge = d < HOLOFUSE_NO_DEPTH * 0.5 &&
              (breaks(camera, d, p + ivec2(-1, 0)) || breaks(camera, d, p + ivec2(1, 0)) ||
               breaks(camera, d, p + ivec2(0, -1)) || breaks(camera, d, p + ivec2(0, 1)));
  uint index = (camera * push.height + uint(p.y)) * push.width + uint(p.x);
  // With eps = 0 the edges are the dilated map: the dilation passes are skipped.
  if (push.dilation > 0) {
    edges[index] = edge ? 1u : 0u;
  } else {
    dilated[index] = edge ? 1u : 0u;
  }
}
