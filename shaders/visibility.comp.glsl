#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 3 (paper 000 section 4.2): why each vertex is or is not seen by
// each camera: behind it, outside its image, on its background, behind its
// depth map, in its dilated discontinuities, or visible.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint v = gl_GlobalInvocationID.x;
  if (v >= push.vertex_count) return;
  vec3 p = vertexPosition(v);
  for (uint i = 0u; i < push.camera_count; ++i) {
    vec3 q = projectToCamera(i, p);
    uint sight;
    vec2 size = cameras[i].size.xy;
    if (q.z <= 0.0) {
      sight = HOLOFUSE_SIGHT_BEHIND;
    } else if (!(q.x >= 0.0 && q.y >= 0.0 && q.x < size.x && q.y < size.y)) {
      sight = HOLOFUSE_SIGHT_OUTSIDE_IMAGE;
    } else {
      ivec2 pixel = ivec2(q.xy);
      float mask = texelFetch(images, ivec3(pixel, int(i)), 0).a;
      float stored = storedDepth(i, pixel);
      if (mask <= 0.0) {
        sight = HOLOFUSE_SIGHT_BACKGROUND;
      } else if (q.z > stored * (1.0 + push.depth_tolerance)) {
        sight = HOLOFUSE_SIGHT_OCCLUDED;
      } else if (((discontinuities[v * cameraWords() + i / 32u] >> (i % 32u)) & 1u) != 0u) {
        sight = HOLOFUSE_SIGHT_DISCONTINUITY;
      } else {
        sight = HOLOFUSE_SIGHT_VISIBLE;
      }
    }
    sights[i * push.vertex_count + v] = sight;
  }
}
