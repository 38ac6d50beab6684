#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 1 (paper 000 section 4.2): the depth map of each pod camera,
// rasterised from that camera once per new mesh. One invocation per
// (triangle, camera) covers the triangle's pixels (centres at .5, edges
// inclusive) and keeps the nearest depth with an atomic minimum on the
// float's bits (positive floats order like their bits), so the map does
// not depend on the order triangles run in. Depth is the camera-space z,
// interpolated perspective-correctly (1/z is linear in the image).
// A compute pass rather than a render pass: on a CPU Vulkan device a
// render pass per camera cost more than the whole map; the map lands in a
// buffer the later passes read without image fetches.
// CPU reference: render::reference::rasterizeDepth.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint t = gl_GlobalInvocationID.x;
  uint camera = gl_GlobalInvocationID.y;
  if (t >= push.triangle_count || camera >= push.camera_count) return;
  if (cameras[camera].flags.y != 0) return;  // sees none of the subject: its map stays empty
  vec3 q[3];
  for (uint k = 0u; k < 3u; ++k) {
    vec4 clip = cameras[camera].world_to_clip * vec4(vertexPosition(indices[3u * t + k]), 1.0);
    // Behind the near plane (or not a number): the whole triangle is
    // skipped, as the reference does.
    if (!(clip.z >= 0.0) || !(clip.w > 0.0)) return;
    q[k] = vec3((clip.xy / clip.w * 0.5 + 0.5) * cameras[camera].size.xy, clip.w);
  }
  float area = (q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (q[1].y - q[0].y);
  if (!(abs(area) > 1e-12)) return;
  int w = int(push.width), h = int(push.height);
  int x0 = max(0, int(floor(min(min(q[0].x, q[1].x), q[2].x) - 0.5)));
  int x1 = min(w - 1, int(ceil(max(max(q[0].x, q[1].x), q[2].x) - 0.5)));
  int y0 = max(0, int(floor(min(min(q[0].y, q[1].y), q[2].y) - 0.5)));
  int y1 = min(h - 1, int(ceil(max(max(q[0].y, q[1].y), q[2].y) - 0.5)));
  vec3 inverse_depth = 1.0 / vec3(q[0].z, q[1].z, q[2].z);
  uint base = camera * uint(h) * uint(w);
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      vec2 p = vec2(x, y) + 0.5;
      float b0 = ((q[1].x - p.x) * (q[2].y - p.y) - (q[2].x - p.x) * (q[1].y - p.y)) / area;
      float b1 = ((q[2].x - p.x) * (q[0].y - p.y) - (q[0].x - p.x) * (q[2].y - p.y)) / area;
      float b2 = 1.0 - b0 - b1;
      if (b0 < 0.0 || b1 < 0.0 || b2 < 0.0) continue;
      uint bits = floatBitsToUint(1.0 / dot(vec3(b0, b1, b2), inverse_depth));
      uint index = base + uint(y) * uint(w) + uint(x);
      if (bits < depth_bits[index]) atomicMin(depth_bits[index], bits);  // plain read first: most lose
    }
  }
}
