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

// Each workgroup counts in shared memory, then adds to the global counters
// once per camera: a few global atomics per group instead of one per
// vertex on the same few words (on a CPU device those serialise).
shared uint group_counts[HOLOFUSE_MAX_CAMERAS];

void main() {
  uint v = gl_GlobalInvocationID.x;
  uint local = gl_LocalInvocationID.x;
  if (local < HOLOFUSE_MAX_CAMERAS) group_counts[local] = 0u;
  barrier();
  if (v < push.vertex_count) {
    for (uint i = 0u; i < push.camera_count; ++i) {
      uint index = i * push.vertex_count + v;
      if (sights[index] == HOLOFUSE_SIGHT_VISIBLE && trusted[index] != 0u) atomicAdd(group_counts[i], 1u);
    }
  }
  barrier();
  if (local < push.camera_count && group_counts[local] != 0u) atomicAdd(visible_counts[local], group_counts[local]);
}
