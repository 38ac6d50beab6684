#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 5 (paper 000 section 4.3): seam triangles of each camera by the
// three rules, one invocation per triangle:
//   occlusion: some but not all vertices behind the depth map or in its
//     dilated discontinuities;
//   vote: the vertices the camera sees disagree in the majority vote;
//   field of view: some but not all vertices outside the image or on the
//     pod's background.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= push.triangle_count) return;
  // The corners once for every camera: the compiler may not move a load
  // past the store to seams[] (the buffers might alias).
  uvec3 corners = uvec3(indices[3u * t], indices[3u * t + 1u], indices[3u * t + 2u]);
  for (uint i = 0u; i < push.camera_count; ++i) {
    uint in_view = 0u, occluded = 0u, seen = 0u, seen_trusted = 0u;
    for (uint k = 0u; k < 3u; ++k) {
      uint index = i * push.vertex_count + corners[k];
      uint s = sights[index];
      bool hidden = s == HOLOFUSE_SIGHT_OCCLUDED || s == HOLOFUSE_SIGHT_DISCONTINUITY;
      in_view += (s == HOLOFUSE_SIGHT_VISIBLE || hidden) ? 1u : 0u;
      occluded += hidden ? 1u : 0u;
      if (s == HOLOFUSE_SIGHT_VISIBLE) {
        ++seen;
        seen_trusted += trusted[index] != 0u ? 1u : 0u;
      }
    }
    uint rules = 0u;
    if (occluded > 0u && occluded < 3u) rules |= HOLOFUSE_SEAM_OCCLUSION;
    if (seen_trusted > 0u && seen_trusted < seen) rules |= HOLOFUSE_SEAM_VOTE;
    if (in_view > 0u && in_view < 3u) rules |= HOLOFUSE_SEAM_FIELD_OF_VIEW;
    seams[i * push.triangle_count + t] = rules;
  }
}
