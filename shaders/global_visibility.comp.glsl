#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 7 (paper 000 eq. 4): how many vertices each camera sees and
// trusts. Integer atomics give the same total in any order, so the result
// is deterministic; g^i = count_i / max_j count_j is formed where it is
// used. The counters are cleared before this pass.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint v = gl_GlobalInvocationID.x;
  if (v >= push.vertex_count) return;
  for (uint i = 0u; i < push.camera_count; ++i) {
    uint index = i * push.vertex_count + v;
    if (sights[index] == HOLOFUSE_SIGHT_VISIBLE && trusted[index] != 0u) atomicAdd(visible_counts[i], 1u);
  }
}
