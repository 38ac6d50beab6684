#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 2a (paper 000 section 4.2): depth discontinuities of each camera's
// depth map (the camera is gl_GlobalInvocationID.z): a surface pixel whose
// 4-neighbour is empty or farther by more than relative_jump times the
// nearer depth.
//
// Each invocation does a run of HOLOFUSE_DISCONTINUITY_RUN pixels along a
// row with a sliding window, so a CPU device pays its per-invocation cost
// once per run (one pixel per invocation was 3.5 times slower than the CPU
// reference on lavapipe; an array of the run's row spilled to memory past
// 8 pixels). On lavapipe, 21 repeats: runs of 4, 8, 16 and 32 took
// 0.57-0.63, 0.48-0.50, 0.51-0.68 and 0.68-0.96 ms for 4 cameras.
layout(local_size_x = HOLOFUSE_PIXEL_GROUP, local_size_y = HOLOFUSE_PIXEL_GROUP) in;

const float kOutside = -1.0;  // beyond the image's border: continuous

float depthAt(uint camera, ivec2 q) {
  if (q.x < 0 || q.y < 0 || q.x >= int(push.width) || q.y >= int(push.height)) return kOutside;
  return storedDepth(camera, q);
}

// Neighbour depth e breaks the surface at depth d: empty, or a relative
// jump; outside the image counts as continuous.
bool breaks(float d, float e) {
  return e != kOutside && (e >= HOLOFUSE_NO_DEPTH * 0.5 || abs(e - d) > push.relative_jump * min(d, e));
}

void main() {
  const int run = HOLOFUSE_DISCONTINUITY_RUN;
  uint camera = gl_GlobalInvocationID.z;  // all cameras in one dispatch
  if (camera >= push.camera_count) return;
  // Only the camera's region can hold depth (CameraGpu::region; empty for
  // a camera that sees none of the subject); the flags are cleared
  // everywhere before this pass.
  ivec4 region = blend.cameras[camera].region;
  ivec2 start = region.xy + ivec2(int(gl_GlobalInvocationID.x) * run, int(gl_GlobalInvocationID.y));
  if (start.x >= region.z || start.y >= region.w) return;
  // A window of three along the row slides over the run: each pixel loads
  // its right neighbour and the two above and below.
  float left = depthAt(camera, start + ivec2(-1, 0)), centre = depthAt(camera, start);
  uint line = (camera * push.height + uint(start.y)) * push.width;
  for (int k = 0; k < run; ++k) {
    ivec2 p = start + ivec2(k, 0);
    if (p.x >= region.z) break;
    float right = depthAt(camera, p + ivec2(1, 0));
    float d = centre;
    bool edge = d < HOLOFUSE_NO_DEPTH * 0.5 &&
                (breaks(d, left) || breaks(d, right) || breaks(d, depthAt(camera, p + ivec2(0, -1))) ||
                 breaks(d, depthAt(camera, p + ivec2(0, 1))));
    left = centre;
    centre = right;
    // Both maps were cleared before this pass: only edges are written
    // (a CPU device pays for every scattered store). With eps = 0 the
    // edges are the dilated map: the dilation passes are skipped.
    if (!edge) continue;
    uint index = line + uint(p.x);
    if (push.dilation > 0) {
      edges[index] = 1u;
    } else {
      dilated[index] = 1u;
    }
  }
}
